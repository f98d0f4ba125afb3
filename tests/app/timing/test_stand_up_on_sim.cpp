// The deployed loop stands the robot up from lying, on any robot: the robot file's lying pose
// (crouched_sim_config) on the simulated robot, the robot folder's shipped springbok.yaml,
// the operator's `start`. The stand-up ramps the posture (and, with gains.stand_feed_forward
// weight, the weight's feed-forward: ModeController); the robot must reach `stand` without a
// fault, the trunk near the height its stance puts it at (forward kinematics of the stand
// posture, trunk level).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <memory>

#include "alloc_trap.hpp"
#include "loop_fixture.hpp"
#include "springbok/dynamics/dynamics.hpp"
#include "springbok/sim_hal/stepped_bullet_robot.hpp"

namespace springbok::app::test {
namespace {

using Rig = LoopRig<sim::SteppedBulletRobot>;

// The trunk's height above flat ground with the joints at `q_rad`, the trunk level.
double standing_height_m(const VecNj& q_rad) {
  dyn::Model model;
  auto data = std::make_unique<dyn::Data>();
  VecNq q = RobotState{}.q;
  q.tail<kNj>() = q_rad;
  dyn::forward_kinematics(model, *data, q);
  double lowest_m = 0.0;
  for (const int frame : robot::kFootFrames) lowest_m = std::min(lowest_m, data->frames[frame].translation.z());
  return kFootRadius_m - lowest_m;
}

// The robot after start, stand_up_duration_s and 2 s of stand, from lying.
struct StandUp {
  safety::Mode mode = safety::Mode::idle;
  safety::FaultMask faults = 0;
  std::size_t allocations = 1;
  VecNj posture_error_rad = VecNj::Zero();
  double lying_z_m = 0.0, trunk_z_m = 0.0;
  double expected_ramp_s = 0.0;   // stand_up_ramp_s from the lying pose
  double stand_up_s = 0.0;        // start to the stand mode
  double peak_speed_fraction = 0.0;  // max over joints and ticks of |qd| / velocity limit
  int peak_joint = -1;
};
StandUp stand_up(const AppConfig& config) {
  rt::SteppedClock clock(0);
  sim::SteppedBulletRobot robot(sim::crouched_sim_config(1000));
  EXPECT_TRUE(robot.configure().ok);
  EXPECT_TRUE(robot.activate().ok);
  auto rig = std::make_unique<Rig>(clock, robot, config);
  rig->executive->run_ticks(500);  // idle: settled on the ground
  StandUp r;
  r.lying_z_m = robot.robot().ground_truth().q[2];
  EXPECT_EQ(rig->command(safety::OperatorCommand::start), safety::Verdict::accepted);
  springbok::test::AllocationTrap trap;
  r.expected_ramp_s = stand_up_ramp_s(config.stand_posture_rad - rig->loop.measurements().q_rad, config.stand_up_duration_s);
  const int ticks = static_cast<int>(1000.0 * r.expected_ramp_s) + 2000;
  for (int t = 0; t < ticks; ++t) {
    rig->executive->run_tick();
    if (r.stand_up_s == 0.0 && rig->supervisor.mode() == safety::Mode::stand) r.stand_up_s = 1e-3 * (t + 1);
    const VecNj& qd = rig->loop.measurements().qd_rad_s;
    for (int j = 0; j < kNj; ++j) {
      const double fraction = std::abs(qd[j]) / robot::kJoints[static_cast<std::size_t>(j)].limits.velocity_rad_s;
      if (fraction > r.peak_speed_fraction) {
        r.peak_speed_fraction = fraction;
        r.peak_joint = j;
      }
    }
  }
  r.allocations = trap.disarm();
  r.mode = rig->supervisor.mode();
  r.faults = rig->supervisor.faults();
  r.posture_error_rad = rig->loop.measurements().q_rad - config.stand_posture_rad;
  r.trunk_z_m = robot.robot().ground_truth().q[2];
  return r;
}

AppConfig shipped_config() {
  const ConfigResult loaded = load_config_file(SPRINGBOK_APP_CONFIG);
  EXPECT_TRUE(loaded.ok) << (loaded.errors.empty() ? "" : loaded.errors.front());
  return loaded.config;
}

// As deployed: the PD (and the feed-forward the config asks for) lifts the trunk most of the
// way to its stance height, within the config's tolerance of the posture, without a fault.
TEST(StandUpOnSim, TheShippedConfigStandsTheRobotUpFromLying) {
  const AppConfig config = shipped_config();
  const StandUp r = stand_up(config);
  // The arm lies straight and stands bent: its ramp is stretched past stand_up_duration_s where
  // a joint would need more than kStandUpSpeedFraction of its velocity limit, and no joint
  // reaches its limit (the drives' replies would be implausible, CAN.md 4.1).
  std::printf("stand-up %.3f s (ramp %.3f s, configured %.1f s); peak speed %.2f of joint %d's limit\n", r.stand_up_s,
              r.expected_ramp_s, config.stand_up_duration_s, r.peak_speed_fraction, r.peak_joint);
  EXPECT_GE(r.stand_up_s, r.expected_ramp_s);
  EXPECT_LT(r.peak_speed_fraction, 0.9);
  EXPECT_EQ(r.allocations, 0u) << "stand-up and stand allocate nothing";
  EXPECT_EQ(r.faults, 0u) << fault_list(r.faults);
  ASSERT_EQ(r.mode, safety::Mode::stand) << "posture error [rad]: " << r.posture_error_rad.transpose();
  EXPECT_LE(r.posture_error_rad.head<kFirstArmJoint>().cwiseAbs().maxCoeff(), config.stand_tolerance_rad);
  const double expected_z_m = standing_height_m(config.stand_posture_rad);
  EXPECT_GT(r.trunk_z_m, r.lying_z_m + 0.8 * (expected_z_m - r.lying_z_m)) << "the trunk rose";
}

// With the weight's feed-forward (gains.stand_feed_forward weight) the PD only corrects: the
// legs within 0.05 rad of the posture, the arm within 0.1, the trunk within 3 cm of the height
// the stance puts it at.
TEST(StandUpOnSim, TheWeightsFeedForwardHoldsThePostureWithoutSag) {
  AppConfig config = shipped_config();
  config.stand_weight_feed_forward = true;
  const StandUp r = stand_up(config);
  EXPECT_EQ(r.allocations, 0u) << "stand-up and stand allocate nothing";
  EXPECT_EQ(r.faults, 0u) << fault_list(r.faults);
  ASSERT_EQ(r.mode, safety::Mode::stand) << "posture error [rad]: " << r.posture_error_rad.transpose();
  EXPECT_LT(r.posture_error_rad.head<kFirstArmJoint>().cwiseAbs().maxCoeff(), 0.05) << r.posture_error_rad.transpose();
  EXPECT_LT(r.posture_error_rad.tail<kArmJoints>().cwiseAbs().maxCoeff(), 0.1) << r.posture_error_rad.transpose();
  EXPECT_NEAR(r.trunk_z_m, standing_height_m(config.stand_posture_rad), 0.03);
}

}  // namespace
}  // namespace springbok::app::test
