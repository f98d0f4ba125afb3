// The stand controller's gravity compensation: static equilibrium of the whole
// robot on its four feet, and an allocation-free tick.
#include <random>

#include <gtest/gtest.h>

#include "alloc_trap.hpp"
#include "springbok/wbc/stand_controller.hpp"

namespace {
using namespace springbok;

VecNq stance_q(const Quat& orientation) {
  VecNq q = VecNq::Zero();
  q.head<3>() = Vec3(0.3, -0.2, 0.63);
  q.segment<4>(3) = orientation.coeffs();
  q.tail<kNj>() = wbc::nominal_stance();
  return q;
}

TEST(StandController, FeetCarryTheWholeWeightAndTheJointsBalanceTheRest) {
  const dyn::Model model;
  auto data = std::make_unique<dyn::Data>();
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> small(-0.2, 0.2);
  for (int trial = 0; trial < 5; ++trial) {
    const Quat orientation = trial == 0 ? Quat::Identity()
                                        : Quat(Eigen::AngleAxisd(small(rng), Vec3::UnitX()) *
                                               Eigen::AngleAxisd(small(rng), Vec3::UnitY()) *
                                               Eigen::AngleAxisd(small(rng), Vec3::UnitZ()));
    VecNq q = stance_q(orientation);
    q.tail<kArmJoints>() = Vec<kArmJoints>::Constant(small(rng));
    wbc::StanceForces forces;
    wbc::stance_gravity_compensation(model, *data, q, forces);
    // Newton: the feet push up with the robot's weight, no net horizontal force.
    Vec3 total = Vec3::Zero();
    for (int f = 0; f < kFeet; ++f) total += forces.f_n.segment<3>(3 * f);
    const double weight_n = total_mass_kg() * kGravity_m_s2;
    EXPECT_NEAR(total.z(), weight_n, 1e-9 * weight_n);
    EXPECT_NEAR(total.x(), 0.0, 1e-9 * weight_n);
    EXPECT_NEAR(total.y(), 0.0, 1e-9 * weight_n);
    // Euler: the moment of the foot forces about the COM balances (COM under gravity has none).
    const Vec3 com = dyn::center_of_mass(model, *data, q);
    dyn::forward_kinematics(model, *data, q);
    Vec3 moment = Vec3::Zero();
    for (int f = 0; f < kFeet; ++f) {
      moment += (data->frames[kFootFrames[f]].translation - com).cross(forces.f_n.segment<3>(3 * f));
    }
    EXPECT_LT(moment.norm(), 1e-8 * weight_n);
    // Joint rows of the static equilibrium: g_j = tau + J_st,j^T f.
    const VecNv g = dyn::gravity(model, *data, q);
    dyn::point_jacobians(model, *data, q);
    VecNj residual = g.tail<kNj>() - forces.tau_gravity_nm;
    for (int f = 0; f < kFeet; ++f) {
      residual -= data->J_feet[f].rightCols<kNj>().transpose() * forces.f_n.segment<3>(3 * f);
    }
    EXPECT_LT(residual.cwiseAbs().maxCoeff(), 1e-9);
  }
}

TEST(StandController, TickFollowsTheLawAndDoesNotAllocate) {
  wbc::StandGains gains;
  wbc::StandController controller(gains, wbc::nominal_stance());
  const VecNq q = stance_q(Quat::Identity());
  hal::JointCommands cmd;
  const std::size_t allocations = test::count_allocations([&] { controller.tick(q, cmd); });
  EXPECT_EQ(allocations, 0u);
  EXPECT_EQ(cmd.mode, hal::CommandMode::enabled);
  EXPECT_EQ(cmd.q_des_rad, wbc::nominal_stance());
  EXPECT_EQ(cmd.tau_ff_nm, controller.stance_forces().tau_gravity_nm);
  EXPECT_DOUBLE_EQ(cmd.kp_nm_per_rad[0], gains.kp_leg_nm_per_rad);
  EXPECT_DOUBLE_EQ(cmd.kd_nms_per_rad[kFirstArmJoint], gains.kd_arm_nms_per_rad);
  // At the posture with no motion the drive torque is exactly the compensation.
  for (int j = 0; j < kNj; ++j) {
    EXPECT_DOUBLE_EQ(hal::drive_torque_nm(cmd, j, q[7 + j], 0.0), cmd.tau_ff_nm[j]);
  }
}

}  // namespace
