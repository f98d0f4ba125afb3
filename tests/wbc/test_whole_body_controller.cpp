// The whole-body controller, one tick at a time, against physics: the
// torques and forces it returns must satisfy the robot's equations of motion,
// Newton's law for the whole robot, the friction pyramid and the torque limits.
#include <cmath>
#include <limits>

#include <gtest/gtest.h>

#include "hyq_actuator_oracle.hpp"
#include "wbc_fixture.hpp"

namespace {
using namespace springbok;
using wbc::WbcInput;
using wbc::WbcParams;
using wbc::WholeBodyController;

using Fixture = test::WbcFixture;

// A force at the hand as the wrench [F; 0] (head<3>: the comma initialiser's dynamic-size block
// made GCC 12 warn of an AVX load past a Vec3 at -march=x86-64-v3).
Vec6 force_at_the_hand(const Vec3& force_n) {
  Vec6 w = Vec6::Zero();
  w.head<3>() = force_n;
  return w;
}
using test::standing_q;

TEST_F(Fixture, StandingStillIsAnEquilibrium) {
  const auto& out = tick();
  ASSERT_EQ(out.qp_status, qp::Status::optimal);
  EXPECT_FALSE(out.failed);
  EXPECT_LT(out.udot.cwiseAbs().maxCoeff(), 1e-3);
  double fz = 0;
  for (const auto& f : out.foot_force_n) fz += f.z();
  EXPECT_NEAR(fz, total_mass_kg() * kGravity_m_s2, 1.0);
  EXPECT_LT(dynamics_residual(out, Vec6::Zero()).cwiseAbs().maxCoeff(), 1e-6);
}

TEST_F(Fixture, PushOnTheHandObeysNewtonForTheWholeRobot) {
  in.wrist_force_world_n = Vec3(50.0, 0.0, 0.0);  // 50 N along world x
  const auto& out = tick();
  ASSERT_EQ(out.qp_status, qp::Status::optimal);
  EXPECT_NEAR(out.external_force_world_n.x(), 50.0, 1e-9);
  Vec6 wrench;
  wrench << 50.0, 0.0, 0.0, 0.0, 0.0, 0.0;
  // 1. Every row of the equations of motion (base rows: physical consistency; joint rows: eq. 19).
  EXPECT_LT(dynamics_residual(out, wrench).cwiseAbs().maxCoeff(), 1e-6);
  // 2. Newton for the whole robot: sum of external forces = m a_com (v = 0, so a_com = J_com udot).
  dyn::jacobian_center_of_mass(model, *data, in.state.q);
  Vec3 total = Vec3(50.0, 0.0, 0.0) + Vec3(0.0, 0.0, -total_mass_kg() * kGravity_m_s2);
  for (const auto& f : out.foot_force_n) total += f;
  EXPECT_LT((total - total_mass_kg() * (data->J_com * out.udot)).norm(), 1e-6);
  // 3. At rest, the template asks the base for nothing and the hand for F/M_e.
  EXPECT_NEAR(out.ee_acceleration_desired.x(), 50.0 / params.template_params.mass_ee_kg.x(), 1e-9);
  const Vec3 ee_acc = data->J_ee.topRows<3>() * out.udot + data->dJv_ee.head<3>();
  EXPECT_NEAR(ee_acc.x(), out.ee_acceleration_desired.x(), 0.05 * out.ee_acceleration_desired.x());
  const Mat3 rot = Mat3::Identity();
  EXPECT_LT((rot * out.udot.head<3>()).norm(), 0.05);
  // 4. Friction pyramid, unilateral contact, torque limits.
  const double mu = params.friction_mu / std::sqrt(2.0);
  for (const auto& f : out.foot_force_n) {
    EXPECT_GE(f.z(), params.normal_force_min_n - 1e-6);
    EXPECT_LE(std::abs(f.x()), mu * f.z() + 1e-6);
    EXPECT_LE(std::abs(f.y()), mu * f.z() + 1e-6);
  }
  for (int j = 0; j < kNj; ++j) EXPECT_LE(std::abs(out.tau_nm[j]), out.torque_limit_nm[j]);
}

// The base wrench the solution applies (logged against W_b^d, the paper's Fig. 10) is the
// template's base mass times the trunk acceleration of udot; on four feet the desired
// one is reachable, so the two agree.
TEST_F(Fixture, OnFourFeetTheAppliedBaseWrenchIsTheDesiredOne) {
  in.state.q[0] += 0.02;   // the base 2 cm forward and 1 cm left of its rest pose
  in.state.q[1] += 0.01;
  in.state.v[1] = 0.05;    // moving sideways (trunk axes = world axes here)
  const auto& out = tick();
  ASSERT_EQ(out.qp_status, qp::Status::optimal);
  const auto& tp = params.template_params;
  const Vec3 force_expected = -tp.stiffness_base_n_per_m.cwiseProduct(Vec3(0.02, 0.01, 0.0)) -
                              tp.damping_base_ns_per_m.cwiseProduct(Vec3(0.0, 0.05, 0.0)) +
                              tp.damping_ee_ns_per_m.cwiseProduct(data->J_ee.topRows<3>() * in.state.v - Vec3(0.0, 0.05, 0.0)) +
                              tp.stiffness_ee_n_per_m.cwiseProduct(Vec3(-0.02, -0.01, 0.0) +
                                                                   data->frames[kEeFrame].translation -
                                                                   wbc->reference().ee_position_m);
  EXPECT_LT((out.base_wrench_desired.head<3>() - force_expected).norm(), 1e-9);
  // Applied = M_b (R (d/dt v_B + w x v_B)); w = 0 here and R = I.
  EXPECT_LT((out.base_wrench_applied.head<3>() - tp.mass_base_kg.cwiseProduct(out.udot.head<3>())).norm(), 1e-9);
  EXPECT_LT((out.base_wrench_applied.tail<3>() -
             wbc->base_rotational_inertia_kgm2().cwiseProduct(out.udot.segment<3>(3))).norm(), 1e-9);
  EXPECT_LT((out.base_wrench_applied - out.base_wrench_desired).head<3>().norm(),
            0.02 * out.base_wrench_desired.head<3>().norm())
      << "desired " << out.base_wrench_desired.transpose() << "\napplied " << out.base_wrench_applied.transpose();
  EXPECT_LT((out.base_wrench_applied - out.base_wrench_desired).tail<3>().norm(), 1.0);
}

// The gait's force ramps bound a stance foot's normal force; the others carry the rest,
// Newton still holds; a bound below normal_force_min_n is that minimum.
TEST_F(Fixture, ANormalForceCapIsObeyedAndTheOtherFeetTakeTheLoad) {
  const double weight = total_mass_kg() * kGravity_m_s2;
  const auto& free = tick();
  ASSERT_EQ(free.qp_status, qp::Status::optimal);
  const double lf_free = free.foot_force_n[0].z();
  ASSERT_GT(lf_free, 150.0);
  for (double cap : {100.0, 20.0, 1.0}) {
    in.normal_force_cap_n = {cap, std::numeric_limits<double>::infinity(), std::numeric_limits<double>::infinity(),
                             std::numeric_limits<double>::infinity()};
    const auto& out = tick();
    ASSERT_EQ(out.qp_status, qp::Status::optimal) << cap;
    EXPECT_LE(out.foot_force_n[0].z(), std::max(cap, params.normal_force_min_n) + 1e-6) << cap;
    EXPECT_GE(out.foot_force_n[0].z(), params.normal_force_min_n - 1e-6) << cap;
    double fz = 0.0;
    for (const auto& f : out.foot_force_n) fz += f.z();
    EXPECT_NEAR(fz, weight, 0.05 * weight) << cap;  // at rest: the feet still carry the robot
    EXPECT_LT(dynamics_residual(out, Vec6::Zero()).cwiseAbs().maxCoeff(), 1e-6) << cap;
  }
}

// A ramping foot's tangential force is regularised by (weight / 4) / cap: with a push on the
// hand that the feet resist sideways, the foot capped low carries a tangential share that
// shrinks with its cap (inside its pyramid, not on a face of it), the uncapped feet the rest.
TEST_F(Fixture, ARampingFootCarriesATangentialShareThatShrinksWithItsCap) {
  const double inf = std::numeric_limits<double>::infinity();
  const double mu = params.friction_mu / std::sqrt(2.0);
  in.wrist_force_world_n = Vec3(60.0, 40.0, 0.0);
  for (double cap : {40.0, 10.0}) {
    in.normal_force_cap_n = {cap, inf, inf, inf};
    const auto& out = tick();
    ASSERT_EQ(out.qp_status, qp::Status::optimal) << cap;
    const Vec3& f0 = out.foot_force_n[0];
    double others = 0.0;
    for (int f = 1; f < kFeet; ++f) others = std::max(others, out.foot_force_n[f].head<2>().norm());
    EXPECT_LT(f0.head<2>().cwiseAbs().maxCoeff(), 0.5 * mu * f0.z()) << cap << ": " << f0.transpose();
    EXPECT_LT(f0.head<2>().norm(), 0.5 * others) << cap;
  }
}

// The hand's template acceleration is bounded in norm (arm.max_acceleration), its
// direction kept; below the bound it is the template's, F / M_e at rest.
TEST_F(Fixture, TheHandsTemplateAccelerationIsBoundedInNorm) {
  params.template_params.mass_ee_kg = Vec3::Constant(0.4);
  params.ee_acceleration_limit_m_s2 = 100.0;
  WholeBodyController light(params);
  light.set_reference(in.state.q, *data);
  in.wrist_force_world_n = Vec3(30.0, 0.0, 0.0);  // 75 m/s^2: below
  EXPECT_LT((tick(light).ee_acceleration_desired - Vec3(75.0, 0.0, 0.0)).norm(), 1e-9);
  in.wrist_force_world_n = Vec3(80.0, -60.0, 0.0);  // 250 m/s^2: bounded to 100
  const auto& out = tick(light);
  ASSERT_EQ(out.qp_status, qp::Status::optimal);
  EXPECT_NEAR(out.ee_acceleration_desired.norm(), 100.0, 1e-9);
  EXPECT_LT((out.ee_acceleration_desired.normalized() - Vec3(0.8, -0.6, 0.0)).norm(), 1e-12);
  params.ee_acceleration_limit_m_s2 = std::numeric_limits<double>::infinity();  // `none`: the paper's
  WholeBodyController unbounded(params);
  unbounded.set_reference(in.state.q, *data);
  EXPECT_NEAR(tick(unbounded).ee_acceleration_desired.norm(), 250.0, 1e-9);
}

TEST_F(Fixture, JointFrictionIsCompensatedInTheTorquesAndTheirLimits) {
  // Moving joints with a push on the hand: with friction b the same motion and forces, each
  // torque b qd higher (the equations of motion of a robot with that friction: M udot + h + B qd
  // = S^T tau + J^T F).
  in.state.v.tail<kNj>() = VecNj::LinSpaced(-0.4, 0.5);
  in.wrist_force_world_n = Vec3(30.0, 0.0, 10.0);
  WbcParams with_friction = params;
  with_friction.joint_viscous_friction_nms_per_rad = VecNj::LinSpaced(0.2, 2.0);
  WholeBodyController rubbing(with_friction);
  rubbing.set_reference(in.state.q, *data);
  const wbc::WbcOutput plain = tick();
  const wbc::WbcOutput& out = tick(rubbing);
  ASSERT_EQ(plain.qp_status, qp::Status::optimal);
  ASSERT_EQ(out.qp_status, qp::Status::optimal);
  EXPECT_LT((out.udot - plain.udot).cwiseAbs().maxCoeff(), 1e-7);
  const VecNj friction_nm = with_friction.joint_viscous_friction_nms_per_rad.cwiseProduct(in.state.v.tail<kNj>());
  EXPECT_LT((out.tau_nm - plain.tau_nm - friction_nm).cwiseAbs().maxCoeff(), 1e-6);
  // A torque limit binds with the friction counted: an elbow whose friction alone is 5 N m past
  // its limit: the torque stays within the limit, the motion gives way (the elbow decelerates).
  constexpr int kElbow = kFirstArmJoint + 3;
  const double limit_nm = robot::kJoints[kElbow].limits.effort_nm;
  in.state.v[6 + kElbow] = 1.0;
  with_friction.joint_viscous_friction_nms_per_rad[kElbow] = limit_nm + 5.0;
  WholeBodyController stuck(with_friction);
  stuck.set_reference(in.state.q, *data);
  const wbc::WbcOutput& limited = tick(stuck);
  ASSERT_EQ(limited.qp_status, qp::Status::optimal);
  EXPECT_LE(std::abs(limited.tau_nm[kElbow]), limit_nm + 1e-6);
  EXPECT_LT(limited.udot[6 + kElbow], -1.0);
  const Vec6 wrench = force_at_the_hand(in.wrist_force_world_n);
  VecNv residual = dynamics_residual(limited, wrench);
  residual.tail<kNj>() += with_friction.joint_viscous_friction_nms_per_rad.cwiseProduct(in.state.v.tail<kNj>());
  EXPECT_LT(residual.cwiseAbs().maxCoeff(), 1e-6) << "the motion obeys the dynamics with friction";
}

// The joints' speeds stay within the URDF's velocity limits: no acceleration takes a joint
// past v_max faster than within the horizon, and a joint already past it is slowed.
// The torque rows bound each joint by its limit at the tick's angle (ACTUATORS.md: HyQ's knee
// gives 161.6 N m at 80 deg, 106.8 at 130 deg). One hind knee bent deeper than the stance's;
// the limits scaled down until the most loaded knee's stance torque is beyond its own: that
// knee's torque is exactly its (scaled) limit at its angle, every joint is within its own, and
// the solution still balances the equations of motion (the QP held it, not the final clamp).
TEST_F(Fixture, TheTorqueRowsBoundEachJointByItsLimitAtTheTicksAngle) {
  in.state.q[7 + robot::kJoint_rh_kfe_joint] = 2.27;  // 130 deg
  const wbc::WbcOutput free = tick();
  ASSERT_EQ(free.qp_status, qp::Status::optimal);
  for (int j = 0; j < kNj; ++j) {
    const double q = in.state.q[7 + j];
    const double oracle = j < kFirstArmJoint ? test::hyq_leg_limit_nm(j, q) : robot::kJoints[j].limits.effort_nm;
    EXPECT_NEAR(free.torque_limit_nm[j], oracle, 1e-9) << j;
  }
  EXPECT_NEAR(free.torque_limit_nm[robot::kJoint_rh_kfe_joint], 106.8, 0.2);  // the table's 130 deg
  int knee = -1;
  double ratio = 0.0;
  for (int j : {robot::kJoint_lf_kfe_joint, robot::kJoint_rf_kfe_joint, robot::kJoint_lh_kfe_joint,
                robot::kJoint_rh_kfe_joint}) {
    if (std::abs(free.tau_nm[j]) / free.torque_limit_nm[j] > ratio) {
      ratio = std::abs(free.tau_nm[j]) / free.torque_limit_nm[j];
      knee = j;
    }
  }
  ASSERT_GT(ratio, 0.1);
  params.torque_limit_scale = 0.8 * ratio;
  WholeBodyController scaled(params);
  scaled.set_reference(standing_q(), *data);
  const wbc::WbcOutput& out = tick(scaled);
  ASSERT_EQ(out.qp_status, qp::Status::optimal);
  EXPECT_NEAR(std::abs(out.tau_nm[knee]), params.torque_limit_scale * free.torque_limit_nm[knee], 1e-6) << knee;
  for (int j = 0; j < kNj; ++j) {
    EXPECT_LE(std::abs(out.tau_nm[j]), params.torque_limit_scale * out.torque_limit_nm[j] + 1e-6) << j;
  }
  EXPECT_LT(dynamics_residual(out, Vec6::Zero()).cwiseAbs().maxCoeff(), 1e-6);
}

TEST_F(Fixture, JointAccelerationsKeepTheSpeedsWithinTheirLimits) {
  constexpr int kWrist2 = kFirstArmJoint + 5;  // Gen3 joint 6, 1.2218 rad/s
  const double v_max = robot::kJoints[kWrist2].limits.velocity_rad_s;
  ASSERT_NEAR(v_max, 1.2218, 1e-12) << "the URDF's figure, through urdf2model";
  in.wrist_force_world_n = Vec3(0.0, 60.0, -40.0);
  const double t_s = params.joint_velocity_horizon_s;
  for (const double speed : {0.99 * v_max, 1.3 * v_max, -1.3 * v_max}) {
    in.state.v.tail<kNj>().setZero();
    in.state.v[6 + kWrist2] = speed;
    const wbc::WbcOutput& out = tick();
    ASSERT_EQ(out.qp_status, qp::Status::optimal) << speed;
    for (int j = 0; j < kNj; ++j) {
      const double limit = robot::kJoints[j].limits.velocity_rad_s, qd = in.state.v[6 + j];
      EXPECT_LE(out.udot[6 + j], (limit - qd) / t_s + 1e-6) << "joint " << j << " at " << speed;
      EXPECT_GE(out.udot[6 + j], (-limit - qd) / t_s - 1e-6) << "joint " << j << " at " << speed;
    }
    if (std::abs(speed) > v_max) {
      EXPECT_LT(out.udot[6 + kWrist2] * speed, 0.0) << "a joint past its limit is slowed: " << speed;
    }
    const Vec6 wrench = force_at_the_hand(in.wrist_force_world_n);
    EXPECT_LT(dynamics_residual(out, wrench).cwiseAbs().maxCoeff(), 1e-6);
  }
}

// A joint far past its speed limit, faster than its torque can brake within the horizon:
// with the speed rows the QP has no solution; it is solved without them instead of failing
// (and that tick does not allocate either).
TEST_F(Fixture, SpeedRowsGiveWayWhereTheTorqueCannotBrake) {
  tick();  // warm up
  constexpr int kWrist2 = kFirstArmJoint + 5;
  in.state.v[6 + kWrist2] = 20.0;  // braking to 1.22 rad/s within 0.02 s asks ~940 rad/s^2
  wbc::WbcOutput out;
  ASSERT_NO_FATAL_FAILURE(tick_solved_without_allocating(out));
  EXPECT_FALSE(out.failed);
  EXPECT_TRUE(out.velocity_limits_relaxed);
  EXPECT_FALSE(out.joint_limits_relaxed);
  EXPECT_LE(std::abs(out.tau_nm[kWrist2]), robot::kJoints[kWrist2].limits.effort_nm + 1e-9);
  EXPECT_LT(out.udot[6 + kWrist2], 0.0) << "it still brakes";
  EXPECT_LT(dynamics_residual(out, Vec6::Zero()).cwiseAbs().maxCoeff(), 1e-6);
  // Back within its limit: the speed rows hold again.
  in.state.v[6 + kWrist2] = 0.5;
  const wbc::WbcOutput& calm = tick();
  EXPECT_FALSE(calm.velocity_limits_relaxed);
}

// A push the arm cannot hold: at rest, 150 N along x at the hand asks more of the elbow
// (arm joint 4) than its 39 N m just to hold still. The arm is overloaded: it yields, its
// acceleration bounds open, and the base keeps its task (at rest in the template: no
// acceleration). Before, the QP gave the arm's task and bounds the base instead: it
// accelerated the trunk to relieve the shoulder, and in closed loop the robot toppled.
TEST_F(Fixture, AnArmOverloadedByAPushYieldsAndTheBaseKeepsItsTask) {
  tick();  // warm up
  const Vec3 push(150.0, 0.0, 0.0);
  in.wrist_force_world_n = push;
  constexpr int kElbow = kFirstArmJoint + 3;
  wbc::WbcOutput out;
  ASSERT_NO_FATAL_FAILURE(tick_solved_without_allocating(out));
  EXPECT_FALSE(out.failed);
  EXPECT_TRUE(out.arm_overloaded);
  EXPECT_TRUE(out.arm_reference_saturated);
  EXPECT_FALSE(out.velocity_limits_relaxed);
  EXPECT_FALSE(out.joint_limits_relaxed);
  // The arm gives what it has; the trunk is not used to relieve it.
  EXPECT_NEAR(std::abs(out.tau_nm[kElbow]), robot::kJoints[kElbow].limits.effort_nm, 1e-3);
  for (int j = 0; j < kNj; ++j) EXPECT_LE(std::abs(out.tau_nm[j]), out.torque_limit_nm[j] + 1e-9) << j;
  EXPECT_LT(out.base_wrench_desired.norm(), 1e-9) << "at rest in the template: no base acceleration asked";
  EXPECT_LT(out.base_wrench_applied.head<3>().norm(), 1.0) << out.base_wrench_applied.transpose();
  EXPECT_LT(out.base_wrench_applied.tail<3>().norm(), 1.0) << out.base_wrench_applied.transpose();
  // The arm's cut reference is what it does.
  EXPECT_LT((out.udot.segment<wbc::kArmDofs>(wbc::kArmCol) - out.arm_qdd_desired).cwiseAbs().maxCoeff(), 1e-3);
  const Vec6 wrench = force_at_the_hand(push);
  EXPECT_LT(dynamics_residual(out, wrench).cwiseAbs().maxCoeff(), 1e-6);

  // Yielding, the elbow is past its speed limit: no bound brakes it (with one, only the
  // base could have).
  in.state.v[6 + kElbow] = -2.0 * robot::kJoints[kElbow].limits.velocity_rad_s;
  const wbc::WbcOutput& fast = tick();
  ASSERT_EQ(fast.qp_status, qp::Status::optimal);
  EXPECT_TRUE(fast.arm_overloaded);
  EXPECT_FALSE(fast.velocity_limits_relaxed);
  EXPECT_LT(fast.base_wrench_applied.tail<3>().norm(), 1.0) << fast.base_wrench_applied.transpose();

  // The push gone, the arm holds again and its bounds are back.
  in.wrist_force_world_n.setZero();
  in.state.v.setZero();
  const wbc::WbcOutput& calm = tick();
  ASSERT_EQ(calm.qp_status, qp::Status::optimal);
  EXPECT_FALSE(calm.arm_overloaded);
  EXPECT_FALSE(calm.arm_reference_saturated);
}

// After an overload the hand is wherever the push put it, and its spring (K_e x_be) would
// drag the base after it: it pulls the base by at most the push |F_e| until it is back within
// the push (plus 10 N). The same displaced hand without an overload pulls with its full spring.
TEST_F(Fixture, AfterAnOverloadTheHandSpringPullsTheBaseByAtMostThePush) {
  const Vec3 push(150.0, 0.0, 0.0);
  in.wrist_force_world_n = push;
  ASSERT_TRUE(tick().arm_overloaded);
  // The arm folded by the push: the elbow 0.8 rad further, the hand ~0.3 m away.
  const VecNq folded = [this] {
    VecNq q = in.state.q;
    q[7 + kFirstArmJoint + 3] -= 0.8;
    return q;
  }();
  in.state.q = folded;
  in.wrist_force_world_n = Vec3::Zero();
  dyn::compute_tick(model, *data, in.state.q, in.state.v);
  in.wrist_force_world_n = push;
  const Vec3 spring = params.template_params.stiffness_ee_n_per_m.cwiseProduct(
      data->frames[kEeFrame].translation - wbc->reference().ee_position_m);
  ASSERT_GT(spring.norm(), push.norm() + 10.0) << "the case: a spring stretched beyond the push";
  const wbc::WbcOutput& limited = tick();
  ASSERT_EQ(limited.qp_status, qp::Status::optimal);
  EXPECT_TRUE(limited.hand_coupling_limited);
  EXPECT_NEAR(limited.base_wrench_desired.head<3>().norm(), push.norm(), 1e-9);  // at rest: the pull alone
  EXPECT_LT((limited.base_wrench_desired.head<3>().normalized() - spring.normalized()).norm(), 1e-9);
  // The hand back: the spring is within the push again, the limit ends.
  in.state.q = standing_q();
  const wbc::WbcOutput& back = tick();
  EXPECT_FALSE(back.hand_coupling_limited);
  EXPECT_LT(back.base_wrench_desired.head<3>().norm(), 1e-9);

  // A controller that saw no overload: the full spring.
  WholeBodyController fresh(params);
  fresh.set_reference(standing_q(), *data);
  in.state.q = folded;
  in.wrist_force_world_n = Vec3::Zero();
  const wbc::WbcOutput& full = tick(fresh);
  EXPECT_FALSE(full.hand_coupling_limited);
  EXPECT_LT((full.base_wrench_desired.head<3>() - spring).norm(), 1e-9);
}

// A light hand (M_e 0.2 kg) under 50 N: its template asks 250 m/s^2, which needs more than
// the arm's torques though holding still does not. The reference is cut to what the torques
// give, the arm keeps its bounds (not overloaded), and the QP meets both tasks. (The hand's
// acceleration bound is lifted and the speed rows' horizon short here: with the defaults, 100
// m/s^2 and 0.02 s, those bind before the torques.)
TEST_F(Fixture, AnArmReferenceBeyondItsTorquesIsCutToWhatTheyGive) {
  params.template_params.mass_ee_kg = Vec3::Constant(0.2);
  params.ee_acceleration_limit_m_s2 = 1e3;
  params.joint_velocity_horizon_s = 1e-3;
  wbc = std::make_unique<WholeBodyController>(params);
  wbc->set_reference(in.state.q, *data);
  tick();
  const Vec3 push(50.0, 0.0, 0.0);
  in.wrist_force_world_n = push;
  const wbc::WbcOutput& out = tick();
  ASSERT_EQ(out.qp_status, qp::Status::optimal);
  EXPECT_TRUE(out.arm_reference_saturated);
  EXPECT_FALSE(out.arm_overloaded);
  bool at_limit = false;
  for (int j = kFirstArmJoint; j < kNj; ++j) {
    at_limit = at_limit || std::abs(out.tau_nm[j]) > robot::kJoints[j].limits.effort_nm - 1e-3;
    EXPECT_LE(std::abs(out.tau_nm[j]), robot::kJoints[j].limits.effort_nm + 1e-9) << j;
  }
  EXPECT_TRUE(at_limit) << out.tau_nm.tail<wbc::kArmDofs>().transpose();
  EXPECT_LT((out.udot.segment<wbc::kArmDofs>(wbc::kArmCol) - out.arm_qdd_desired).cwiseAbs().maxCoeff(), 1e-3);
  EXPECT_LT(out.base_wrench_applied.norm(), 1.0) << out.base_wrench_applied.transpose();
  const Vec3 ee_acc = data->J_ee.topRows<3>() * out.udot + data->dJv_ee.head<3>();
  EXPECT_GT(ee_acc.x(), 10.0) << "the hand still moves with the push";
  EXPECT_LT(ee_acc.x(), out.ee_acceleration_desired.x());
  const Vec6 wrench = force_at_the_hand(push);
  EXPECT_LT(dynamics_residual(out, wrench).cwiseAbs().maxCoeff(), 1e-6);
}

// The support limit: the static centre of pressure under gravity and the hand's wrench, and
// how far it is inside the stance feet's polygon, against an independent computation (the
// centre of mass from dyn::center_of_mass, the polygon's edges in the feet's known
// counter-clockwise order, a lateral push moving the CoP by (p_s,z - z_g) F_y / (m g));
// within support_margin_m of an edge, and only then, the base is pushed back along the
// edge's inward normal, in proportion to how far inside the margin the CoP is; only after
// the stance has held 250 ticks, never while a foot's force ramps or on two feet.
// Signed distance of a point inside the four feet's polygon (min over its edges, in the feet's
// known counter-clockwise order lf, lh, rh, rf), and that edge's inward normal.
double inside_four_feet(const dyn::Data& data, const Eigen::Vector2d& p, Eigen::Vector2d& normal) {
  const std::array<int, 4> ccw = {0, 2, 3, 1};
  double best = std::numeric_limits<double>::infinity();
  for (int k = 0; k < 4; ++k) {
    const Eigen::Vector2d a = data.frames[kFootFrames[ccw[k]]].translation.head<2>();
    const Eigen::Vector2d b = data.frames[kFootFrames[ccw[(k + 1) % 4]]].translation.head<2>();
    const Eigen::Vector2d n = Eigen::Vector2d(a.y() - b.y(), b.x() - a.x()).normalized();
    if (n.dot(p - a) < best) best = n.dot(p - a), normal = n;
  }
  return best;
}

TEST_F(Fixture, TheSupportLimitHoldsTheBaseBackFromTheEdgeAPushTipsItOver) {
  dyn::Data other;
  const Vec3 com = dyn::center_of_mass(model, other, in.state.q);
  const double weight_n = total_mass_kg() * kGravity_m_s2;
  double ground_z = 0.0;
  for (int f = 0; f < kFeet; ++f) ground_z += data->frames[kFootFrames[f]].translation.z() / kFeet;
  Eigen::Vector2d normal;
  const double at_rest_m = inside_four_feet(*data, com.head<2>(), normal);
  ASSERT_GT(at_rest_m, params.support_margin_m);
  for (int t = 0; t < 249; ++t) {
    const wbc::WbcOutput& out = tick();
    ASSERT_FALSE(out.support_limited);
    ASSERT_TRUE(std::isinf(out.support_distance_m)) << "tick " << t << ": the stance has not held long enough";
  }
  const wbc::WbcOutput& rest = tick();
  EXPECT_NEAR(rest.support_distance_m, at_rest_m, 1e-9);
  EXPECT_FALSE(rest.support_limited);

  // A lateral push at the wrist (+y): the CoP moves toward the left edge (lf - lh).
  const double lever_m = data->frames[kWristFtFrame].translation.z() - ground_z;
  const Eigen::Vector2d left_normal = Eigen::Vector2d(0.0, -1.0);
  std::array<double, 2> pushed_n{}, distance_m{};
  for (int k = 0; k < 2; ++k) {
    const double target_m = params.support_margin_m - 0.01 * (k + 1);  // 1 and 2 cm inside the margin
    // The push that puts the CoP target_m inside the left edge.
    const Eigen::Vector2d a = data->frames[kFootFrames[0]].translation.head<2>();
    const Eigen::Vector2d b = data->frames[kFootFrames[2]].translation.head<2>();
    const Eigen::Vector2d n = Eigen::Vector2d(a.y() - b.y(), b.x() - a.x()).normalized();
    ASSERT_LT(n.y(), -0.99) << "the left edge runs along x";
    const double fy = (n.dot(com.head<2>() - a) - target_m) / (-n.y()) * weight_n / lever_m;
    in.wrist_force_world_n = Vec3(0.0, fy, 0.0);
    wbc::WbcOutput out;
    ASSERT_NO_FATAL_FAILURE(tick_solved_without_allocating(out));
    EXPECT_NEAR(out.support_distance_m, target_m, 1e-6) << fy << " N";
    EXPECT_TRUE(out.support_limited);
    // At rest in the template (no displacement yet): the desired base force is the limit's
    // push alone, along the left edge's inward normal.
    EXPECT_NEAR(out.base_wrench_desired.x(), 0.0, 1e-9);
    EXPECT_LT(out.base_wrench_desired.y(), -1.0);
    EXPECT_NEAR(Eigen::Vector2d(out.base_wrench_desired.x(), out.base_wrench_desired.y()).normalized().dot(left_normal), 1.0, 1e-12);
    pushed_n[static_cast<std::size_t>(k)] = -out.base_wrench_desired.y();
    distance_m[static_cast<std::size_t>(k)] = out.support_distance_m;
  }
  EXPECT_NEAR(pushed_n[1] / pushed_n[0],
              (params.support_margin_m - distance_m[1]) / (params.support_margin_m - distance_m[0]), 1e-9);

  // The same CoP from a push the wrist does not measure (WbcInput::unmeasured_force_world_n,
  // at the centre of mass): it moves the CoP by (c_z - z_g) F / W.
  const Vec3 wrist_push_n = in.wrist_force_world_n;
  in.wrist_force_world_n.setZero();
  {
    const Eigen::Vector2d a = data->frames[kFootFrames[0]].translation.head<2>();
    const double target_m = params.support_margin_m - 0.015;
    in.unmeasured_force_world_n = Vec3(0.0, (a.y() - com.y() - target_m) * weight_n / (com.z() - ground_z), 0.0);
    const wbc::WbcOutput& out = tick();
    EXPECT_NEAR(out.support_distance_m, target_m, 1e-6) << in.unmeasured_force_world_n.y() << " N";
    EXPECT_TRUE(out.support_limited);
    EXPECT_LT(out.base_wrench_desired.y(), -1.0);
  }
  in.unmeasured_force_world_n.setZero();
  in.wrist_force_world_n = wrist_push_n;

  // The same push while a foot's force ramps (stepping), on two feet, or right after a stance
  // change: no limit.
  in.normal_force_cap_n[1] = 200.0;
  EXPECT_FALSE(tick().support_limited);
  in.normal_force_cap_n[1] = std::numeric_limits<double>::infinity();
  ASSERT_TRUE(tick().support_limited);
  in.state.stance = {true, false, false, true};
  EXPECT_FALSE(tick().support_limited);
  in.state.stance = kAllFeet;
  EXPECT_FALSE(tick().support_limited) << "the stance changed a tick ago";
  // Off: support_margin_m 0.
  params.support_margin_m = 0.0;
  WholeBodyController off(params);
  off.set_reference(in.state.q, *data);
  for (int t = 0; t < 300; ++t) ASSERT_FALSE(tick(off).support_limited);
}

// The capture point of that centre of pressure: the CoP moved by the trunk's horizontal
// velocity times sqrt(h / g), h the centre of mass's height over the feet (the linear
// inverted pendulum's time constant), against the same independent polygon; the support
// distance itself does not see the velocity. At rest the two coincide.
TEST_F(Fixture, TheCapturePointLeadsTheCentreOfPressureByTheTrunksVelocity) {
  dyn::Data other;
  const Vec3 com = dyn::center_of_mass(model, other, in.state.q);
  double ground_z = 0.0;
  for (int f = 0; f < kFeet; ++f) ground_z += data->frames[kFootFrames[f]].translation.z() / kFeet;
  const double lead_s = std::sqrt((com.z() - ground_z) / kGravity_m_s2);
  ASSERT_GT(lead_s, 0.2);
  ASSERT_LT(lead_s, 0.3);
  for (int t = 0; t < 250; ++t) tick();
  Eigen::Vector2d normal;
  const double at_rest_m = inside_four_feet(*data, com.head<2>(), normal);
  EXPECT_NEAR(tick().capture_distance_m, at_rest_m, 1e-9);
  for (const Vec3& v_world : {Vec3(0.3, 0.0, 0.0), Vec3(-0.5, 0.2, 0.1), Vec3(0.0, 1.5, 0.0)}) {
    in.state.v.head<3>() = in.state.rotation_wb.transpose() * v_world;  // trunk axes
    const wbc::WbcOutput& out = tick();
    EXPECT_NEAR(out.support_distance_m, at_rest_m, 1e-9);
    const double expected_m = inside_four_feet(*data, com.head<2>() + lead_s * v_world.head<2>(), normal);
    EXPECT_NEAR(out.capture_distance_m, expected_m, 1e-9) << v_world.transpose();
    EXPECT_LT(out.capture_distance_m, at_rest_m) << "toward an edge";
  }
  EXPECT_LT(tick().capture_distance_m, 0.0) << "1.5 m/s sideways: past the left edge, no stopping on these feet";
  // Fewer than three feet, or the stance not settled: not computed.
  in.state.stance = {true, false, false, true};
  EXPECT_TRUE(std::isinf(tick().capture_distance_m));
}

TEST_F(Fixture, SwingFootCarriesNoForceAndTracksItsTarget) {
  in.state.stance = {true, false, false, true};  // trot pair LF + RH on the ground
  for (int f : {1, 2}) {
    const Vec3 r = data->frames[kFootFrames[f]].translation - in.state.q.head<3>();
    in.swing[f].position_m = r + Vec3(0.0, 0.0, 0.05);  // lift 5 cm
  }
  const auto& out = tick();
  ASSERT_EQ(out.qp_status, qp::Status::optimal);
  EXPECT_EQ(out.foot_force_n[1].norm(), 0.0);
  EXPECT_EQ(out.foot_force_n[2].norm(), 0.0);
  EXPECT_LT(dynamics_residual(out, Vec6::Zero()).cwiseAbs().maxCoeff(), 1e-6);
  // The swing feet accelerate upwards (relative to the trunk) towards their targets.
  for (int f : {1, 2}) {
    const Vec3 acc = data->J_feet[f] * out.udot + data->dJv_feet[f];
    EXPECT_GT(acc.z() - out.udot[2], 1.0) << "foot " << f;
  }
}

// A failed QP is said and counted; the torques stay those of the last solved tick
// (what a failed tick commands is the supervisor's decision, not the controller's).
TEST_F(Fixture, QpFailureIsReportedAndCounted) {
  const wbc::WbcOutput solved = tick();
  ASSERT_FALSE(solved.failed);
  WbcParams bad = params;
  bad.normal_force_min_n = 2000.0;  // above the maximum: no feasible contact force
  WholeBodyController failing(bad);
  failing.set_reference(in.state.q, *data);
  const auto& out = tick(failing);
  EXPECT_NE(out.qp_status, qp::Status::optimal);
  EXPECT_TRUE(out.failed);
  EXPECT_EQ(failing.qp_failures(), 1u);
  EXPECT_EQ(out.tau_nm, VecNj::Zero());  // never solved: the initial torques
  // The good controller, failing after a solved tick, keeps that tick's torques.
  in.state.q[2] = std::numeric_limits<double>::quiet_NaN();
  const auto& after = tick();
  EXPECT_TRUE(after.failed);
  EXPECT_EQ(wbc->qp_failures(), 1u);
  EXPECT_EQ(after.tau_nm, solved.tau_nm);
}

// Tick after tick with the same contacts, the last tick's active set is this tick's:
// the solver takes it directly (its shortcut), and the answer is the cold one.
TEST_F(Fixture, SteadyTicksAreSolvedOnTheLastActiveSet) {
  in.wrist_force_world_n = Vec3(50.0, 0.0, 0.0);
  const wbc::WbcOutput first = tick();  // cold
  ASSERT_EQ(first.qp_status, qp::Status::optimal);
  EXPECT_FALSE(first.qp_from_hint);
  for (int i = 0; i < 3; ++i) {
    const auto& out = tick();
    ASSERT_EQ(out.qp_status, qp::Status::optimal);
    EXPECT_TRUE(out.qp_from_hint) << "tick " << i;
    EXPECT_EQ(out.qp_iterations, 0);
    EXPECT_LT((out.udot - first.udot).cwiseAbs().maxCoeff(), 1e-9);
    EXPECT_LT((out.tau_nm - first.tau_nm).cwiseAbs().maxCoeff(), 1e-8);
  }
  // A change of contacts: the set is moved to the new rows (a hint only); the answer is the
  // cold one (a second controller that starts cold with this stance).
  in.state.stance = {true, false, true, true};
  const wbc::WbcOutput out = tick();
  ASSERT_EQ(out.qp_status, qp::Status::optimal);
  auto cold_wbc = std::make_unique<wbc::WholeBodyController>(params);
  cold_wbc->set_reference(in.state.q, *data);
  const auto& cold = tick(*cold_wbc);
  ASSERT_EQ(cold.qp_status, qp::Status::optimal);
  EXPECT_EQ(cold.qp_from_hint, false);
  EXPECT_LT((out.udot - cold.udot).cwiseAbs().maxCoeff(), 1e-9);
  EXPECT_LT((out.tau_nm - cold.tau_nm).cwiseAbs().maxCoeff(), 1e-8);
}

// A touch-down ramp's start: a cap at or below normal_force_min_n makes the foot's normal
// row an equality (lb == ub). When the next tick's cap opens the range, the row is hinted
// on the side its multiplier pushed (here the upper: the foot wants more than the cap), so
// that tick is solved on the hinted set with no repair, and its answer is the cold one.
TEST_F(Fixture, AnEqualityForceRowThatOpensIsHintedOnItsMultipliersSide) {
  const double inf = std::numeric_limits<double>::infinity();
  in.normal_force_cap_n = {1.0, inf, inf, inf};
  ASSERT_EQ(tick().qp_status, qp::Status::optimal);
  const auto& pinned = tick();
  ASSERT_EQ(pinned.qp_status, qp::Status::optimal);
  EXPECT_NEAR(pinned.foot_force_n[0].z(), params.normal_force_min_n, 1e-9);
  in.normal_force_cap_n[0] = params.normal_force_min_n + 1.0;
  const wbc::WbcOutput out = tick();
  ASSERT_EQ(out.qp_status, qp::Status::optimal);
  EXPECT_TRUE(out.qp_from_hint);
  EXPECT_EQ(out.qp_iterations, 0);
  EXPECT_NEAR(out.foot_force_n[0].z(), params.normal_force_min_n + 1.0, 1e-9);
  auto cold_wbc = std::make_unique<wbc::WholeBodyController>(params);
  cold_wbc->set_reference(in.state.q, *data);
  const auto& cold = tick(*cold_wbc);
  ASSERT_EQ(cold.qp_status, qp::Status::optimal);
  EXPECT_LT((out.udot - cold.udot).cwiseAbs().maxCoeff(), 1e-9);
  EXPECT_LT((out.tau_nm - cold.tau_nm).cwiseAbs().maxCoeff(), 1e-8);
}

// The problem's zero pattern is laid out once and cleared only where a contact switch changes
// it: through a sequence of switches (feet lifting, landing, the other diagonal, three feet)
// every tick's answer is that of a fresh controller built for that tick's stance. A stale
// entry moves a foot's force by newtons; a warm start's repaired set (semi-normal equations,
// one refinement) agrees with the cold solve to about 1e-10 of the feet's few hundred newtons.
TEST_F(Fixture, ContactSwitchesLeaveNoStaleEntriesInTheProblem) {
  in.wrist_force_world_n = Vec3(20.0, 5.0, 0.0);
  const std::array<Stance, 7> stances = {{{true, true, true, true},
                                          {true, false, false, true},
                                          {true, false, false, true},
                                          {false, true, true, false},
                                          {true, true, true, true},
                                          {true, true, false, true},
                                          {false, true, true, false}}};
  for (std::size_t k = 0; k < stances.size(); ++k) {
    in.state.stance = stances[k];
    const wbc::WbcOutput out = tick();
    ASSERT_EQ(out.qp_status, qp::Status::optimal) << "tick " << k;
    auto fresh = std::make_unique<wbc::WholeBodyController>(params);
    fresh->set_reference(in.state.q, *data);
    const auto& expected = tick(*fresh);
    ASSERT_EQ(expected.qp_status, qp::Status::optimal) << "tick " << k;
    EXPECT_LT((out.udot - expected.udot).cwiseAbs().maxCoeff(), 1e-9) << "tick " << k;
    EXPECT_LT((out.tau_nm - expected.tau_nm).cwiseAbs().maxCoeff(), 1e-8) << "tick " << k;
    for (int f = 0; f < kFeet; ++f)
      EXPECT_LT((out.foot_force_n[f] - expected.foot_force_n[f]).cwiseAbs().maxCoeff(), 1e-7) << "tick " << k;
  }
}

TEST_F(Fixture, TicksDoNotAllocate) {
  in.wrist_force_world_n = Vec3(10.0, -5.0, 3.0);
  EXPECT_EQ(allocations_over_ticks(), 0u);
}
}  // namespace
