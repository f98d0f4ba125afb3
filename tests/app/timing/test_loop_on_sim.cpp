// The loop against the simulated robot (sim_hal, Bullet) on the stepped
// clock: it stands up from a crouch without a fault, and a whole tick
// (read -> controller -> safety -> write + physics step) allocates nothing.
#include <gtest/gtest.h>

#include "../../../firmware/app/sim/stepped_bullet_robot.hpp"
#include "alloc_trap.hpp"
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

}  // namespace
}  // namespace springbok::app::test
