// Properties of springbok::dyn on random states, each checked against an
// independent oracle: linear algebra identities between the algorithms,
// finite differences along q(t), and mechanical energy.
#include <gtest/gtest.h>

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <memory>

#include "random_state.hpp"

namespace {
using namespace springbok;
using springbok::test::integrate;
using springbok::test::random_state;

constexpr int kStates = 20;

double rel_err(const Eigen::MatrixXd& a, const Eigen::MatrixXd& b) {
  return ((a - b).cwiseAbs().array() / b.cwiseAbs().array().max(1.0)).maxCoeff();
}

class Properties : public ::testing::Test {
 protected:
  const dyn::Model model;
  std::unique_ptr<dyn::Data> data = std::make_unique<dyn::Data>();
  std::mt19937_64 rng{20240611};
};

TEST_F(Properties, MassMatrixIsSymmetricPositiveDefinite) {
  for (int n = 0; n < kStates; ++n) {
    const auto s = random_state(rng);
    const MatNv m = dyn::crba(model, *data, s.q);
    EXPECT_EQ((m - m.transpose()).cwiseAbs().maxCoeff(), 0.0);
    const Eigen::SelfAdjointEigenSolver<MatNv> eig(m);
    EXPECT_GT(eig.eigenvalues().minCoeff(), 1e-6) << "state " << n;
    EXPECT_NEAR(m(0, 0), model.total_mass_kg, 1e-12);
  }
}

TEST_F(Properties, RneaIsMassMatrixTimesVdotPlusNonlinearEffects) {
  for (int n = 0; n < kStates; ++n) {
    const auto s = random_state(rng);
    const VecNv tau = dyn::rnea(model, *data, s.q, s.v, s.vdot);
    const MatNv m = dyn::crba(model, *data, s.q);
    const VecNv h = dyn::nonlinear_effects(model, *data, s.q, s.v);
    EXPECT_LE(rel_err(m * s.vdot + h, tau), 1e-11) << "state " << n;
    // Each column of M is what RNEA needs to produce a unit acceleration.
    const VecNv g = dyn::gravity(model, *data, s.q);
    for (int k = 0; k < kNv; ++k) {
      const VecNv col = dyn::rnea(model, *data, s.q, VecNv::Zero(), VecNv::Unit(k)) - g;
      EXPECT_LE(rel_err(col, m.col(k)), 1e-11) << "state " << n << " column " << k;
    }
    EXPECT_LE(rel_err(g, dyn::rnea(model, *data, s.q, VecNv::Zero(), VecNv::Zero())), 1e-12);
    EXPECT_LE(rel_err(h, dyn::rnea(model, *data, s.q, s.v, VecNv::Zero())), 1e-12);
  }
}

TEST_F(Properties, AbaInvertsRnea) {
  for (int n = 0; n < kStates; ++n) {
    const auto s = random_state(rng);
    const VecNv tau = dyn::rnea(model, *data, s.q, s.v, s.vdot);
    const VecNv a = dyn::aba(model, *data, s.q, s.v, tau);
    EXPECT_LE(rel_err(a, s.vdot), 1e-9) << "state " << n;
  }
}

// Central differences along q(t) = q (+) t v, v constant (so vdot = 0):
// d/dt p = J v and d/dt (J v) = Jdot v.
TEST_F(Properties, JacobiansAndJdotVMatchFiniteDifferences) {
  constexpr double dt = 1e-5;
  for (int n = 0; n < kStates; ++n) {
    const auto s = random_state(rng);
    const VecNq qp = integrate(s.q, s.v, dt), qm = integrate(s.q, s.v, -dt);
    auto plus = std::make_unique<dyn::Data>(), minus = std::make_unique<dyn::Data>();
    dyn::compute_tick(model, *data, s.q, s.v);
    dyn::compute_tick(model, *plus, qp, s.v);
    dyn::compute_tick(model, *minus, qm, s.v);
    for (int f = 0; f < kFeet; ++f) {
      const int k = kFootFrames[f];
      const Vec3 vel_fd = (plus->frames[k].translation - minus->frames[k].translation) / (2 * dt);
      EXPECT_LE(rel_err(data->J_feet[f] * s.v, vel_fd), 1e-7) << "state " << n << " foot " << f;
      const Vec3 acc_fd = (plus->J_feet[f] * s.v - minus->J_feet[f] * s.v) / (2 * dt);
      EXPECT_LE(rel_err(data->dJv_feet[f], acc_fd), 1e-6) << "state " << n << " foot " << f;
    }
    const Mat3 dr = plus->frames[kEeFrame].rotation * minus->frames[kEeFrame].rotation.transpose();
    const Eigen::AngleAxisd aa(dr);
    Vec6 ee_vel_fd;
    ee_vel_fd << (plus->frames[kEeFrame].translation - minus->frames[kEeFrame].translation) / (2 * dt),
        aa.angle() * aa.axis() / (2 * dt);
    EXPECT_LE(rel_err(data->J_ee * s.v, ee_vel_fd), 1e-7) << "state " << n;
    const Vec6 ee_acc_fd = (plus->J_ee * s.v - minus->J_ee * s.v) / (2 * dt);
    EXPECT_LE(rel_err(data->dJv_ee, ee_acc_fd), 1e-6) << "state " << n;
  }
}

TEST_F(Properties, CenterOfMassJacobianMatchesFiniteDifferences) {
  constexpr double dt = 1e-6;
  for (int n = 0; n < kStates; ++n) {
    const auto s = random_state(rng);
    const Mat3Nv jcom = dyn::jacobian_center_of_mass(model, *data, s.q);
    const Vec3 cp = dyn::center_of_mass(model, *data, integrate(s.q, s.v, dt));
    const Vec3 cm = dyn::center_of_mass(model, *data, integrate(s.q, s.v, -dt));
    EXPECT_LE(rel_err(jcom * s.v, (cp - cm) / (2 * dt)), 1e-7) << "state " << n;
    // The COM moves with the linear momentum: m J_com = R_WB M[0:3, :].
    const MatNv m = dyn::crba(model, *data, s.q);
    const Mat3 r = springbok::test::base_quaternion(s.q).toRotationMatrix();
    // Evaluated into a fixed-size matrix first: assigned straight into rel_err's dynamic
    // argument, Eigen's 8-wide AVX-512 path for the 3-row product is dead code at run
    // time that GCC 12 cannot prove dead (-Warray-bounds on r's 72 bytes).
    const Mat3Nv momentum_rows = r * m.topRows<3>();
    EXPECT_LE(rel_err(model.total_mass_kg * jcom, momentum_rows), 1e-12);
  }
}

// g(q) is the gradient of the potential energy m g z_com along q (+) dt e_k.
TEST_F(Properties, GravityIsGradientOfPotentialEnergy) {
  constexpr double dt = 1e-6;
  const auto potential = [&](const VecNq& q) {
    return model.total_mass_kg * kGravity_m_s2 * dyn::center_of_mass(model, *data, q).z();
  };
  for (int n = 0; n < 5; ++n) {
    const auto s = random_state(rng);
    const VecNv g = dyn::gravity(model, *data, s.q);
    for (int k = 0; k < kNv; ++k) {
      const VecNv e = VecNv::Unit(k);
      const double fd = (potential(integrate(s.q, e, dt)) - potential(integrate(s.q, e, -dt))) / (2 * dt);
      EXPECT_NEAR(g[k], fd, 1e-6 * std::max(1.0, std::abs(g[k]))) << "state " << n << " k " << k;
    }
  }
}

// Moving as one rigid body about its COM (joints still), the kinetic energy is
// 1/2 w' I_com w with the composite inertia.
TEST_F(Properties, CompositeInertiaGivesRigidKineticEnergy) {
  for (int n = 0; n < kStates; ++n) {
    const auto s = random_state(rng);
    const Mat3 inertia = dyn::composite_inertia(model, *data, s.q);
    const Vec3 com = data->com_world_m;
    const Mat3 r = springbok::test::base_quaternion(s.q).toRotationMatrix();
    const Vec3 w_world = s.v.segment<3>(3);
    VecNv v = VecNv::Zero();
    v.segment<3>(0) = r.transpose() * w_world.cross(s.q.head<3>() - com);  // COM at rest
    v.segment<3>(3) = r.transpose() * w_world;
    const MatNv m = dyn::crba(model, *data, s.q);
    EXPECT_NEAR(v.dot(m * v), w_world.dot(inertia * w_world), 1e-10 * w_world.squaredNorm() * inertia.norm());
    EXPECT_LE((inertia - inertia.transpose()).cwiseAbs().maxCoeff(), 1e-12);
  }
}

// ---- energy along trajectories of vdot = aba(q, v, tau) -------------------------
struct State {
  VecNq q;
  VecNv v;
};

// d/dt of (p, quaternion, joints) for the body-frame base twist.
VecNq configuration_rate(const VecNq& q, const VecNv& v) {
  const Eigen::Quaterniond quat = springbok::test::base_quaternion(q);
  VecNq rate;
  rate.head<3>() = quat.toRotationMatrix() * v.segment<3>(0);
  const Eigen::Quaterniond w(0.0, v[3], v[4], v[5]);
  const Eigen::Quaterniond qdot = quat * w;
  rate.segment<4>(3) = 0.5 * qdot.coeffs();
  rate.tail<kNj>() = v.tail<kNj>();
  return rate;
}

// Classic RK4 on (q in R^26, v), tau constant.
State rk4(const dyn::Model& model, dyn::Data& data, State x, const VecNv& tau, double dt, int steps) {
  for (int i = 0; i < steps; ++i) {
    const auto f = [&](const State& y, VecNq& dq, VecNv& dv) {
      dq = configuration_rate(y.q, y.v);
      dv = dyn::aba(model, data, y.q, y.v, tau);
    };
    VecNq k1q, k2q, k3q, k4q;
    VecNv k1v, k2v, k3v, k4v;
    f(x, k1q, k1v);
    f({x.q + 0.5 * dt * k1q, x.v + 0.5 * dt * k1v}, k2q, k2v);
    f({x.q + 0.5 * dt * k2q, x.v + 0.5 * dt * k2v}, k3q, k3v);
    f({x.q + dt * k3q, x.v + dt * k3v}, k4q, k4v);
    x.q += dt / 6.0 * (k1q + 2 * k2q + 2 * k3q + k4q);
    x.v += dt / 6.0 * (k1v + 2 * k2v + 2 * k3v + k4v);
  }
  return x;
}

double energy(const dyn::Model& model, dyn::Data& data, const State& x) {
  const MatNv m = dyn::crba(model, data, x.q);
  return 0.5 * x.v.dot(m * x.v) +
         model.total_mass_kg * kGravity_m_s2 * dyn::center_of_mass(model, data, x.q).z();
}

TEST_F(Properties, PowerBalanceAlongTrajectory) {
  std::normal_distribution<double> normal(0.0, 5.0);
  for (int n = 0; n < 5; ++n) {
    const auto s = random_state(rng);
    VecNv tau;
    for (int k = 0; k < kNv; ++k) tau[k] = k < 6 ? 0.0 : normal(rng);
    const State x0{s.q, s.v};
    constexpr double h = 1e-5, dt = 1e-6;  // light wrist links: stiff, keep steps tiny
    const State xp = rk4(model, *data, x0, tau, dt, 10), xm = rk4(model, *data, x0, tau, -dt, 10);
    const double de_dt = (energy(model, *data, xp) - energy(model, *data, xm)) / (2 * h);
    // dE/dt = v' tau (tau[0:6] = 0: no force on the floating base).
    EXPECT_NEAR(de_dt, s.v.dot(tau), 1e-5 * std::max(1.0, std::abs(s.v.dot(tau)))) << "state " << n;
  }
}

TEST_F(Properties, PassiveMotionConservesEnergy) {
  for (int n = 0; n < 2; ++n) {
    const auto s = random_state(rng);
    const State x0{s.q, s.v};
    const State x1 = rk4(model, *data, x0, VecNv::Zero(), 1e-4, 1000);  // 0.1 s free flight
    const double e0 = energy(model, *data, x0), e1 = energy(model, *data, x1);
    const double kinetic = 0.5 * x0.v.dot(dyn::crba(model, *data, x0.q) * x0.v);
    EXPECT_NEAR(e1, e0, 1e-8 * kinetic) << "state " << n;
    EXPECT_GT((x1.q - x0.q).norm(), 1e-2);  // it did move
  }
}

// The rotors (kRotorInertia_kgm2) add the kinetic energy of a massless inertia I_a spinning
// with its joint's body about the joint's axis z_j: 1/2 I_a (z_j . w_body)^2, so
//   M - M_without_rotors = sum_j I_a,j c_j c_j^T,  c_j . v = z_j . w_body(j),
// with w_body = R w_B + sum over the chain's joints k of a_k qd_k.
TEST_F(Properties, RotorsAddTheirInertiaAboutTheJointAxes) {
  const dyn::Model bare{Rotors::none};
  auto other = std::make_unique<dyn::Data>();
  for (int n = 0; n < kStates; ++n) {
    const auto s = random_state(rng);
    const MatNv with = dyn::crba(model, *data, s.q);
    const MatNv without = dyn::crba(bare, *other, s.q);
    const Mat3 rot = springbok::test::base_quaternion(s.q).toRotationMatrix();
    MatNv expected = MatNv::Zero();
    for (int j = 0; j < kNj; ++j) {
      const Vec3& z = data->joint_axis[j];
      Eigen::Matrix<double, 1, kNv> c = Eigen::Matrix<double, 1, kNv>::Zero();
      c.segment<3>(3) = z.transpose() * rot;
      for (int k = j; k >= 0; k = robot::kJoints[k].parent_body - 1) c[6 + k] = z.dot(data->joint_axis[k]);
      expected += kRotorInertia_kgm2[j] * c.transpose() * c;
    }
    EXPECT_LE((with - without - expected).cwiseAbs().maxCoeff(), 1e-12) << "state " << n;
    // The last joint (no rotor beyond it) grows by exactly its rotor's inertia.
    EXPECT_NEAR(with(kNv - 1, kNv - 1) - without(kNv - 1, kNv - 1), kRotorInertia_kgm2[kNj - 1], 1e-12);
  }
}

}  // namespace
