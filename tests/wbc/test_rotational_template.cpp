// The rotational template (impedance_template.hpp) against independent oracles: two
// rigid bodies integrated on SO(3) under its law (fine steps, exponential map) agree
// with three independent 1-D templates at small angles, settle exactly at
// T/K_rb and T/K_re at large ones; and the whole-body controller with it on: every row
// of the equations of motion holds, the hand's angular acceleration is the template's,
// the trunk's torque is its law's, and its ticks do not allocate.
#include <cmath>
#include <memory>

#include <Eigen/Geometry>
#include <gtest/gtest.h>

#include "springbok/wbc/impedance_template.hpp"
#include "wbc_fixture.hpp"

namespace {
using namespace springbok;
using Eigen::Matrix3d;
using Eigen::Vector3d;
using wbc::RotationalTemplateParams;

Matrix3d exp_map(const Vector3d& w) {
  const double angle = w.norm();
  return angle < 1e-300 ? Matrix3d::Identity() : Eigen::AngleAxisd(angle, w / angle).toRotationMatrix();
}

// Trunk and hand as free rigid bodies with the template's inertias (world axes), moved by
// the template's law and a constant torque on the hand: Lie-group Euler, step h.
struct TwoBodies {
  Matrix3d r_base = Matrix3d::Identity(), r_ee = Matrix3d::Identity();
  Vector3d w_base = Vector3d::Zero(), w_ee = Vector3d::Zero();

  void run(const RotationalTemplateParams& p, const Vector3d& base_inertia, const Vector3d& torque, double t_end,
           double h) {
    const auto steps = static_cast<int>(std::llround(t_end / h));
    for (int k = 0; k < steps; ++k) {
      const wbc::RotationalTemplateState s = wbc::rotational_template_state(
          r_base, Matrix3d::Identity(), r_ee, Matrix3d::Identity(), w_base, Vector3d::Zero(), w_ee, Vector3d::Zero());
      const Vector3d acc_base = wbc::rotational_template_base_torque_nm(p, s).cwiseQuotient(base_inertia);
      const Vector3d acc_ee = wbc::rotational_template_ee_acceleration_rad_s2(p, s, torque);
      w_base += h * acc_base;
      w_ee += h * acc_ee;
      r_base = exp_map(h * w_base) * r_base;
      r_ee = exp_map(h * w_ee) * r_ee;
    }
  }
  Vector3d base_rad() const { return Eigen::AngleAxisd(r_base).angle() * Eigen::AngleAxisd(r_base).axis(); }
  Vector3d ee_rad() const { return Eigen::AngleAxisd(r_ee).angle() * Eigen::AngleAxisd(r_ee).axis(); }
};

RotationalTemplateParams anisotropic() {
  RotationalTemplateParams p;
  p.damping_base_nms_per_rad = {150.0, 120.0, 180.0};
  p.stiffness_base_nm_per_rad = {500.0, 700.0, 400.0};
  p.inertia_ee_kgm2 = {0.1, 0.2, 0.4};
  p.damping_ee_nms_per_rad = {4.5, 7.0, 8.0};
  p.stiffness_ee_nm_per_rad = {50.0, 60.0, 40.0};
  return p;
}

TEST(RotationalTemplate, SmallAnglesAreThreeIndependentAxes) {
  const RotationalTemplateParams p = anisotropic();
  const Vector3d base_inertia(6.0, 15.0, 18.0);
  const Vector3d torque = Vector3d(1.0, -2.0, 1.5) * 0.02;  // rotations of a few mrad
  wbc::TemplateReference ref(wbc::template_axes(p, base_inertia), 1e-3);
  TwoBodies bodies;
  for (int tick = 1; tick <= 600; ++tick) {
    ref.step(torque);
    bodies.run(p, base_inertia, torque, 1e-3, 2e-6);
    if (tick % 100 != 0) continue;
    const double scale = ref.ee_m().cwiseAbs().maxCoeff();
    ASSERT_GT(scale, 1e-4);
    EXPECT_LT((bodies.base_rad() - ref.base_m()).cwiseAbs().maxCoeff(), 2e-3 * scale) << "at tick " << tick;
    EXPECT_LT((bodies.ee_rad() - ref.ee_m()).cwiseAbs().maxCoeff(), 2e-3 * scale) << "at tick " << tick;
    EXPECT_LT((bodies.w_ee - ref.ee_velocity_m_s()).cwiseAbs().maxCoeff(), 2e-3 * ref.ee_velocity_m_s().cwiseAbs().maxCoeff() + 1e-6);
  }
}

TEST(RotationalTemplate, LargeAnglesSettleAtTorqueOverStiffness) {
  RotationalTemplateParams p;  // isotropic: the rest is a rotation vector T/K whatever its size
  p.stiffness_ee_nm_per_rad.setConstant(10.0);
  const Vector3d torque(4.0, -6.0, 5.0);  // |T|/K_re = 0.88 rad
  TwoBodies bodies;
  bodies.run(p, Vector3d(6.0, 6.0, 6.0), torque, 8.0, 2e-5);
  EXPECT_LT((bodies.base_rad() - wbc::steady_state_base_rad(p, torque)).norm(), 1e-6);
  const Matrix3d rest_from_base = exp_map(torque / 10.0);  // the hand turned T/K_re from the trunk's turn
  const Matrix3d expected = rest_from_base * bodies.r_base;
  EXPECT_LT((bodies.r_ee - expected).norm(), 1e-6);
  // Its rotation vector differs from the small-angle sum T/K_rb + T/K_re only by the composition.
  EXPECT_LT((bodies.ee_rad() - wbc::steady_state_ee_rad(p, torque)).norm(), 0.02);
}

// The left Jacobian against the exponential map: [J_l(phi) phi']x = (d/dt exp(phi)) exp(phi)^T,
// by central differences along a path phi(t) = phi0 + t phi' + t^2/2 phi''; and the
// acceleration's rest term (d/dt J_l) phi' against the difference of J_l(phi(t)) phi'(t).
TEST(RotationalTemplate, LeftJacobianGivesTheAngularVelocityAndItsRate) {
  const Vector3d rate(0.4, -0.9, 0.3), acc(1.0, 0.5, -2.0);
  for (const Vector3d& phi0 : {Vector3d(0.0, 0.0, 0.0), Vector3d(1e-3, -2e-3, 5e-4), Vector3d(0.3, -0.2, 0.1),
                               Vector3d(-0.4, 0.5, 0.2), Vector3d(0.005, 0.004, -0.003)}) {
    auto phi = [&](double t) { return Vector3d(phi0 + t * rate + 0.5 * t * t * acc); };
    auto phi_rate = [&](double t) { return Vector3d(rate + t * acc); };
    const double h = 1e-6;
    const Matrix3d rdot_rt = (exp_map(phi(h)) - exp_map(phi(-h))) / (2 * h) * exp_map(phi0).transpose();
    const Vector3d w_numeric(rdot_rt(2, 1), rdot_rt(0, 2), rdot_rt(1, 0));
    EXPECT_LT((wbc::so3_left_jacobian(phi0) * rate - w_numeric).norm(), 1e-8) << phi0.transpose();
    const Vector3d w_dot_numeric = (wbc::so3_left_jacobian(phi(h)) * phi_rate(h) -
                                    wbc::so3_left_jacobian(phi(-h)) * phi_rate(-h)) / (2 * h);
    const Vector3d w_dot = wbc::so3_left_jacobian(phi0) * acc + wbc::so3_left_jacobian_rate(phi0, rate);
    EXPECT_LT((w_dot - w_dot_numeric).norm(), 1e-7) << phi0.transpose();
  }
}

TEST(RotationalTemplate, ReferenceStepMatchesTheTranslationalAxisItIs) {
  const RotationalTemplateParams p = anisotropic();
  const Vector3d base_inertia(6.0, 15.0, 18.0);
  wbc::TemplateReference rot(wbc::template_axes(p, base_inertia), 1e-3);
  wbc::TemplateParams t;  // the same numbers as a translational template
  t.mass_base_kg = base_inertia;
  t.damping_base_ns_per_m = p.damping_base_nms_per_rad;
  t.stiffness_base_n_per_m = p.stiffness_base_nm_per_rad;
  t.mass_ee_kg = p.inertia_ee_kgm2;
  t.damping_ee_ns_per_m = p.damping_ee_nms_per_rad;
  t.stiffness_ee_n_per_m = p.stiffness_ee_nm_per_rad;
  wbc::TemplateReference trans(t, 1e-3);
  const Vector3d torque(5.0, 0.0, -3.0);
  for (int k = 0; k < 20000; ++k) {
    rot.step(torque);
    trans.step(torque);
  }
  EXPECT_EQ(rot.ee_m(), trans.ee_m());
  EXPECT_NEAR(rot.base_m().x(), 5.0 / 500.0, 1e-9);
  EXPECT_NEAR(rot.ee_m().z(), -3.0 / 400.0 - 3.0 / 40.0, 1e-9);
}

// ---- the whole-body controller with the rotational template on ------------------------

// With the rotational template on.
struct Controller : test::WbcFixture {
  void SetUp() override {
    params.rotational_template_enabled = true;
    WbcFixture::SetUp();
  }
};

TEST_F(Controller, TorqueOnTheHandIsRenderedWithEveryRowOfTheDynamics) {
  dyn::compute_tick(model, *data, in.state.q, in.state.v);
  const Vec3 torque_world(0.0, 5.0, -2.0);
  in.wrist_torque_world_nm = torque_world;
  const auto& out = tick();
  ASSERT_EQ(out.qp_status, qp::Status::optimal);
  EXPECT_LT((out.external_torque_world_nm - torque_world).norm(), 1e-9);
  Vec6 wrench;
  wrench << Vec3::Zero(), torque_world;
  EXPECT_LT(dynamics_residual(out, wrench).cwiseAbs().maxCoeff(), 1e-6);
  // At rest: the hand asks T / I_e, the trunk nothing; the solution gives the hand that
  // angular acceleration (the arm task is 6-D) and keeps its point still.
  const Vec3 expected = torque_world.cwiseQuotient(params.rotational_template.inertia_ee_kgm2);
  EXPECT_LT((out.ee_angular_acceleration_desired - expected).norm(), 1e-9);
  EXPECT_LT(out.base_wrench_desired.tail<3>().norm(), 1e-9);
  const Vec6 ee_acc = data->J_ee * out.udot + data->dJv_ee;
  EXPECT_LT((ee_acc.tail<3>() - expected).norm(), 0.05 * expected.norm());
  EXPECT_LT(ee_acc.head<3>().norm(), 0.05);
  for (int j = 0; j < kNj; ++j) EXPECT_LE(std::abs(out.tau_nm[j]), out.torque_limit_nm[j]);
}

TEST_F(Controller, TrunkTorqueIsTheTemplatesLaw) {
  // The trunk rolled 20 mrad and turning, the hand's joint 7 turned: the springs and dampers of
  // both bodies act on the trunk; I_b is the composite inertia (inertia: auto).
  const Matrix3d roll = Eigen::AngleAxisd(0.02, Vector3d::UnitX()).toRotationMatrix();
  Quat qb(roll);
  in.state.q.segment<4>(3) << qb.x(), qb.y(), qb.z(), qb.w();
  in.state.q[7 + kFirstArmJoint + 6] += 0.05;
  in.state.v[5] = 0.1;  // yaw rate, trunk axes
  in.state.set_rotation_from_q();
  const auto& out = tick();
  ASSERT_EQ(out.qp_status, qp::Status::optimal);
  const auto& ref = wbc->reference();
  const Vec3 w_base = in.state.rotation_wb * in.state.v.segment<3>(3);
  const Vec3 w_ee = data->J_ee.bottomRows<3>() * in.state.v;
  const wbc::RotationalTemplateState s = wbc::rotational_template_state(
      in.state.rotation_wb, ref.base_rotation, data->frames[kEeFrame].rotation, ref.ee_rotation, w_base, Vec3::Zero(), w_ee,
      Vec3::Zero());
  EXPECT_NEAR(s.base_rad.x(), 0.02, 1e-12);
  EXPECT_GT(s.ee_from_base_rad.norm(), 0.04);
  const Vec3 expected = wbc::rotational_template_base_torque_nm(params.rotational_template, s);
  EXPECT_LT((out.base_wrench_desired.tail<3>() - expected).norm(), 1e-9);
  // On four feet the trunk gets it: I_b w' = T_b^d.
  EXPECT_LT((out.base_wrench_applied.tail<3>() - expected).norm(), 0.05 * expected.norm());
  EXPECT_LT(dynamics_residual(out, Vec6::Zero()).cwiseAbs().maxCoeff(), 1e-6);
}

// A hand pose command turns the hand's rest orientation while the rest pose walks and turns:
// the reference's angular velocity and acceleration are the derivatives of its orientation
// (central differences of move_reference along analytic paths).
TEST_F(Controller, TheHandsRestOrientationMovesWithItsRates) {
  auto motion = [](double t) {
    wbc::PlanarMotion m;
    m.yaw_rad = 0.3 * t + 0.2 * t * t;
    m.yaw_rate_rad_s = 0.3 + 0.4 * t;
    m.yaw_acceleration_rad_s2 = 0.4;
    m.hand_rotation_rad = Vec3(0.2 + 0.1 * t, -0.3 * t * t, 0.05 + 0.2 * t * t * t);
    m.hand_rotation_rate_rad_s = Vec3(0.1, -0.6 * t, 0.6 * t * t);
    m.hand_rotation_acceleration_rad_s2 = Vec3(0.0, -0.6, 1.2 * t);
    return m;
  };
  auto rest_at = [&](double t) {
    wbc->move_reference(motion(t));
    return wbc->reference();
  };
  const double t = 0.7, h = 1e-5;
  const wbc::WbcReference now = rest_at(t), lo = rest_at(t - h), hi = rest_at(t + h);
  const Matrix3d rdot_rt = (hi.ee_rotation - lo.ee_rotation) / (2 * h) * now.ee_rotation.transpose();
  const Vec3 w_numeric(rdot_rt(2, 1), rdot_rt(0, 2), rdot_rt(1, 0));
  EXPECT_LT((now.ee_angular_velocity_rad_s - w_numeric).norm(), 1e-8);
  const Vec3 wdot_numeric = (hi.ee_angular_velocity_rad_s - lo.ee_angular_velocity_rad_s) / (2 * h);
  EXPECT_LT((now.ee_angular_acceleration_rad_s2 - wdot_numeric).norm(), 1e-7);
  // At rest in the motion: the hand's rest orientation is the engaged one turned by the
  // base's turn and, in the rest pose's horizontal frame, by exp(phi).
  const wbc::PlanarMotion m = motion(t);
  const Matrix3d turn = Eigen::AngleAxisd(m.yaw_rad, Vector3d::UnitZ()).toRotationMatrix();
  const Matrix3d expected = turn * exp_map(m.hand_rotation_rad) * wbc->engaged_reference().ee_rotation;  // heading0 = I
  EXPECT_LT((now.ee_rotation - expected).norm(), 1e-12);
}

TEST_F(Controller, OffByDefaultTheHandsOrientationIsFree) {
  params.rotational_template_enabled = false;
  wbc = std::make_unique<wbc::WholeBodyController>(params);
  wbc->set_reference(in.state.q, *data);
  dyn::compute_tick(model, *data, in.state.q, in.state.v);
  in.wrist_torque_world_nm = Vec3(0.0, 0.0, 3.0);
  const auto& out = tick();
  ASSERT_EQ(out.qp_status, qp::Status::optimal);
  EXPECT_EQ(out.ee_angular_acceleration_desired, Vec3::Zero());
}

TEST_F(Controller, TicksDoNotAllocate) {
  in.wrist_force_world_n = Vec3(10.0, -5.0, 3.0);
  in.wrist_torque_world_nm = Vec3(1.0, 2.0, -3.0);
  EXPECT_EQ(allocations_over_ticks(), 0u);
}

}  // namespace
