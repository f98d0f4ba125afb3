// The feet's kinematics of the WBC's rows against finite differences along
// q(t) = q (+) t v with v constant (udot = 0): what the rows call the velocity is
// the derivative of the position, what they call the bias is the acceleration.
#include <memory>
#include <random>

#include <gtest/gtest.h>

#include "random_state.hpp"
#include "springbok/wbc/contact_kinematics.hpp"

namespace {
using namespace springbok;
using springbok::test::integrate;
using springbok::test::random_state;

constexpr int kStates = 50;

double rel_err(const Vec3& a, const Vec3& b) { return (a - b).norm() / (1.0 + b.norm()); }

struct Tick {
  RobotState state;
  std::unique_ptr<dyn::Data> data = std::make_unique<dyn::Data>();
  Tick(const dyn::Model& model, const VecNq& q, const VecNv& v) {
    state.q = q;
    state.v = v;
    state.set_rotation_from_q();
    dyn::compute_tick(model, *data, q, v);
  }
};

// The swing task's point rho = R^T (p_f - p_b): rho' and rho'' (qdd = 0) by central
// differences of positions alone.
TEST(ContactKinematics, SwingPointVelocityAndBiasMatchFiniteDifferences) {
  dyn::Model model;
  std::mt19937_64 rng(19);
  constexpr double h = 1e-4;
  for (int n = 0; n < kStates; ++n) {
    const auto s = random_state(rng);
    const Tick now(model, s.q, s.v), plus(model, integrate(s.q, s.v, h), s.v), minus(model, integrate(s.q, s.v, -h), s.v);
    for (int f = 0; f < kFeet; ++f) {
      wbc::SwingKinematics k, kp, km;
      wbc::swing_kinematics(*now.data, now.state, f, k);
      wbc::swing_kinematics(*plus.data, plus.state, f, kp);
      wbc::swing_kinematics(*minus.data, minus.state, f, km);
      const Vec3 vel_fd = (kp.position_m - km.position_m) / (2 * h);
      const Vec3 acc_fd = (kp.position_m - 2.0 * k.position_m + km.position_m) / (h * h);
      EXPECT_LE(rel_err(k.velocity_m_s, vel_fd), 1e-7) << "state " << n << " foot " << f;
      EXPECT_LE(rel_err(k.bias_m_s2, acc_fd), 1e-5) << "state " << n << " foot " << f;
      // rho depends on the leg's joints alone: the velocity is J_rho qd_leg.
      const Vec3 from_leg = k.jacobian * s.v.segment<kLegJoints>(6 + leg_first_joint(f));
      EXPECT_LE(rel_err(from_leg, vel_fd), 1e-7) << "state " << n << " foot " << f;
      const Vec3 r = now.data->frames[kFootFrames[f]].translation - s.q.head<3>();
      EXPECT_LE(rel_err(k.position_m, now.state.rotation_wb.transpose() * r), 1e-15);
    }
  }
}

// The lower leg's material point at the ground contact, c = p_f - r e_z now: its velocity
// is J_c v; d/dt (J_c v) is the rolling constraint's bias (udot = 0).
TEST(ContactKinematics, RollingContactJacobianAndBiasMatchFiniteDifferences) {
  dyn::Model model;
  std::mt19937_64 rng(20);
  constexpr double h = 1e-5, radius_m = kFootRadius_m;
  for (int n = 0; n < kStates; ++n) {
    const auto s = random_state(rng);
    const Tick now(model, s.q, s.v), plus(model, integrate(s.q, s.v, h), s.v), minus(model, integrate(s.q, s.v, -h), s.v);
    for (int f = 0; f < kFeet; ++f) {
      const int lower_leg = leg_first_joint(f) + kLegJoints;  // the body the leg's last joint moves
      const Vec3 offset_body =
          now.data->body_rotation[lower_leg].transpose() * Vec3(0.0, 0.0, -radius_m);  // fixed in the lower leg
      const auto material_point = [&](const Tick& t) {
        return Vec3(t.data->frames[kFootFrames[f]].translation + t.data->body_rotation[lower_leg] * offset_body);
      };
      wbc::RollingContact c, cp, cm;
      wbc::rolling_contact(*now.data, now.state, f, radius_m, c);
      wbc::rolling_contact(*plus.data, plus.state, f, radius_m, cp);
      wbc::rolling_contact(*minus.data, minus.state, f, radius_m, cm);
      const Vec3 vel_fd = (material_point(plus) - material_point(minus)) / (2 * h);
      EXPECT_LE(rel_err(c.jacobian * s.v, vel_fd), 1e-7) << "state " << n << " foot " << f;
      const Vec3 acc_fd = (cp.jacobian * s.v - cm.jacobian * s.v) / (2 * h);
      EXPECT_LE(rel_err(c.bias_m_s2, acc_fd), 1e-6) << "state " << n << " foot " << f;
      // The bias is not the sphere centre's once the lower leg turns.
      if (n == 0 && f == 0) {
        EXPECT_GT((c.bias_m_s2 - now.data->dJv_feet[f]).norm(), 1e-3);
      }
    }
  }
}

// Radius 0: the foot frame's own Jacobian and Jdot v.
TEST(ContactKinematics, ZeroRadiusIsTheFootFrame) {
  dyn::Model model;
  std::mt19937_64 rng(21);
  const auto s = random_state(rng);
  const Tick now(model, s.q, s.v);
  for (int f = 0; f < kFeet; ++f) {
    wbc::RollingContact c;
    wbc::rolling_contact(*now.data, now.state, f, 0.0, c);
    EXPECT_EQ(c.jacobian, now.data->J_feet[f]);
    EXPECT_EQ(c.bias_m_s2, now.data->dJv_feet[f]);
  }
}

}  // namespace
