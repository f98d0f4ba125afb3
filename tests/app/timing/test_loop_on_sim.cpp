// The loop against the simulated robot (sim_hal, Bullet) on the stepped
// clock: it stands up from a crouch without a fault, and a whole tick
// (read -> controller -> safety -> write + physics step) allocates nothing;
// in control mode the whole-body controller on the estimated base state
// renders a push at the hand.
#include <gtest/gtest.h>

#include "../../../firmware/app/sim/stepped_bullet_robot.hpp"
#include "alloc_trap.hpp"
#include "springbok/app/control_mode.hpp"
#include "loop_fixture.hpp"

namespace springbok::app::test {
namespace {

using Rig = LoopRig<SteppedBulletRobot>;

TEST(LoopOnSim, StandsUpFromACrouchAndHolds) {
  rt::SteppedClock clock(0);
  SteppedBulletRobot robot(crouched_sim_config(1000));
  ASSERT_TRUE(robot.configure().ok);
  ASSERT_TRUE(robot.activate().ok);
  AppConfig config = test_config();
  config.stand_up_duration_s = 1.0;
  config.stand_tolerance_rad = 0.15;  // joint PD without gravity compensation sags under 95 kg
  config.stand_gains.kp_nm_per_rad.head<kFirstArmJoint>().setConstant(1000.0);
  config.stand_gains.kd_nms_per_rad.head<kFirstArmJoint>().setConstant(20.0);
  config.control_gains = config.stand_gains;
  auto rig = std::make_unique<Rig>(clock, robot, config);
  rig->executive->run_ticks(10);
  ASSERT_EQ(rig->command(safety::OperatorCommand::start), safety::Verdict::accepted);
  rig->executive->run_ticks(3000);
  EXPECT_EQ(rig->supervisor.faults(), 0u) << fault_list(rig->supervisor.faults());
  EXPECT_EQ(rig->supervisor.mode(), safety::Mode::stand)
      << "posture error [rad]: " << (rig->loop.measurements().q_rad - config.stand_posture_rad).transpose();
  // The trunk rose: legs at the stand posture put the feet about 0.61 m below it.
  const double trunk_z_m = robot.robot().ground_truth().q[2];
  EXPECT_GT(trunk_z_m, 0.5);

  ASSERT_EQ(rig->command(safety::OperatorCommand::mode_control), safety::Verdict::accepted);
  springbok::test::AllocationTrap trap;
  rig->executive->run_ticks(200);
  const std::size_t allocations = trap.disarm();
  EXPECT_EQ(allocations, 0u);
  EXPECT_EQ(rig->supervisor.mode(), safety::Mode::control);
}

TEST(LoopOnSim, ControlModeRunsTheWholeBodyControllerOnTheEstimatedState) {
  rt::SteppedClock clock(0);
  SteppedBulletRobot robot(crouched_sim_config(1000));
  ASSERT_TRUE(robot.configure().ok);
  ASSERT_TRUE(robot.activate().ok);
  AppConfig config = test_config();
  config.stand_up_duration_s = 1.0;
  config.stand_tolerance_rad = 0.15;
  config.stand_gains.kp_nm_per_rad.head<kFirstArmJoint>().setConstant(1000.0);
  config.stand_gains.kd_nms_per_rad.head<kFirstArmJoint>().setConstant(20.0);
  config.control_gains = config.stand_gains;
  config.stand_posture_rad.tail<kArmJoints>() << 0.0, 0.6, 0.0, 1.9, 0.0, 0.9, 0.0;  // arm bent, off singularity
  config.control_mode = ControlModeKind::wbc;
  config.wbc.template_params.mass_base_kg.setConstant(4.0);  // fast: settles within a second
  config.wbc.template_params.damping_base_ns_per_m.setConstant(126.5);
  auto rig = std::make_unique<LoopRig<SteppedBulletRobot, ControlMode>>(clock, robot, config);
  rig->executive->run_ticks(10);
  ASSERT_EQ(rig->command(safety::OperatorCommand::start), safety::Verdict::accepted);
  rig->executive->run_ticks(3000);
  ASSERT_EQ(rig->supervisor.mode(), safety::Mode::stand);
  ASSERT_EQ(rig->command(safety::OperatorCommand::mode_control), safety::Verdict::accepted);
  rig->executive->run_ticks(300);  // hold the reference
  const Eigen::Isometry3d ee_start = robot.robot().frame_placement(*sim::find_frame("arm_end_effector_link"));
  sim::ExternalWrench push;
  push.frame = *sim::find_frame("arm_end_effector_link");
  push.axis_world = Vec3::UnitX();
  push.profile.amplitude = 30.0;
  push.profile.start_s = robot.robot().time_s();
  EXPECT_TRUE(robot.robot().add_external_wrench(push));
  springbok::test::AllocationTrap trap;
  rig->executive->run_ticks(200);
  const std::size_t allocations = trap.disarm();
  EXPECT_EQ(allocations, 0u);
  rig->executive->run_ticks(2300);
  EXPECT_EQ(rig->supervisor.mode(), safety::Mode::control);
  EXPECT_EQ(rig->supervisor.faults(), 0u) << fault_list(rig->supervisor.faults());
  EXPECT_EQ(rig->control.failed_ticks(), 0u);
  EXPECT_EQ(rig->control.estimate().status, est::EstimateStatus::ok);
  // The template's static displacement of the hand for 30 N: F/K_b + F/K_e = 0.03 + 0.06 m.
  // (Bullet's feet creep a little under the push, which the estimator cannot see.)
  const double ee_dx = robot.robot().frame_placement(*sim::find_frame("arm_end_effector_link")).translation().x() -
                       ee_start.translation().x();
  EXPECT_NEAR(ee_dx, 0.09, 0.02);
  EXPECT_GT(robot.robot().ground_truth().q[2], 0.5);
}

}  // namespace
}  // namespace springbok::app::test
