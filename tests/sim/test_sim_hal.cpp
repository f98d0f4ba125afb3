// The Bullet backend as a HAL: lifecycle, allocation-free read/write, a
// broken command is refused, IMU readings (at rest: gravity; seeded noise),
// the ground contact report of a link other than a foot.
#include <algorithm>
#include <cmath>
#include <numbers>

#include <gtest/gtest.h>

#include "alloc_trap.hpp"
#include "hyq_actuator_oracle.hpp"
#include "springbok/sim_hal/bullet_robot.hpp"

namespace {
using namespace springbok;

sim::SimConfig resting_fixed_base() {
  sim::SimConfig c;
  c.fixed_base = true;
  c.ground = false;
  c.initial_q[2] = 1.0;
  return c;
}

TEST(SimHal, LifecycleOrderIsEnforced) {
  sim::BulletRobot robot(resting_fixed_base());
  hal::Measurements m;
  hal::JointCommands c;
  EXPECT_EQ(robot.read(m), hal::IoStatus::error);
  EXPECT_FALSE(robot.activate().ok);
  ASSERT_TRUE(robot.configure().ok);
  EXPECT_FALSE(robot.configure().ok);
  EXPECT_EQ(robot.write(c), hal::IoStatus::error);  // drives not powered yet
  EXPECT_EQ(robot.read(m), hal::IoStatus::ok);
  EXPECT_EQ(m.drives[0].state, hal::DriveState::ready);
  ASSERT_TRUE(robot.activate().ok);
  EXPECT_EQ(robot.read(m), hal::IoStatus::ok);
  EXPECT_EQ(m.drives[18].state, hal::DriveState::enabled);
  robot.deactivate();
  robot.deactivate();
  EXPECT_EQ(robot.write(c), hal::IoStatus::error);
}

TEST(SimHal, BadConfigurationIsRefusedWithTheField) {
  sim::SimConfig c = resting_fixed_base();
  c.ground_friction = std::nan("");
  sim::BulletRobot robot(c);
  const auto r = robot.configure();
  EXPECT_FALSE(r.ok);
  EXPECT_NE(r.message.find("ground_friction"), std::string::npos) << r.message;
}

// The CAN path's delays (CAN.md 3.3): a command acts one step after it is written, a joint
// state is read one tick after the world was in it.
TEST(SimHal, LatencyDelaysCommandsAndJointStatesByWholeTicks) {
  sim::SimConfig ideal_config = resting_fixed_base();
  ideal_config.gravity_m_s2 = 0.0;
  sim::SimConfig delayed_config = ideal_config;
  delayed_config.latency = sim::Latency{1, 0, 1};
  sim::BulletRobot ideal(ideal_config), delayed(delayed_config);
  for (sim::BulletRobot* r : {&ideal, &delayed}) {
    ASSERT_TRUE(r->configure().ok);
    ASSERT_TRUE(r->activate().ok);
  }
  hal::JointCommands c;
  c.mode = hal::CommandMode::enabled;
  c.tau_ff_nm[0] = 5.0;
  std::array<double, 4> ideal_truth{}, delayed_truth{}, delayed_read{};
  for (int k = 0; k < 4; ++k) {
    hal::Measurements m;
    ASSERT_EQ(ideal.write(c), hal::IoStatus::ok);
    ASSERT_EQ(delayed.write(c), hal::IoStatus::ok);
    ideal.step();
    delayed.step();
    ideal_truth[k] = ideal.ground_truth().v[6];
    delayed_truth[k] = delayed.ground_truth().v[6];
    ASSERT_EQ(delayed.read(m), hal::IoStatus::ok);
    delayed_read[k] = m.qd_rad_s[0];
  }
  EXPECT_GT(ideal_truth[0], 0.0);
  EXPECT_EQ(delayed_truth[0], 0.0);  // the first command acts in the second step
  for (int k = 1; k < 4; ++k) EXPECT_DOUBLE_EQ(delayed_truth[k], ideal_truth[k - 1]) << k;
  EXPECT_EQ(delayed_read[0], 0.0);
  EXPECT_EQ(delayed_read[1], 0.0);  // the state after step 1, before the command acted
  EXPECT_DOUBLE_EQ(delayed_read[2], delayed_truth[1]);
  EXPECT_DOUBLE_EQ(delayed_read[3], delayed_truth[2]);

  sim::SimConfig too_long = ideal_config;
  too_long.latency.command_ticks = sim::Latency::kMaxTicks + 1;
  sim::BulletRobot refused(too_long);
  const hal::LifecycleResult r = refused.configure();
  EXPECT_FALSE(r.ok);
  EXPECT_NE(r.message.find("latency"), std::string::npos) << r.message;
}

TEST(SimHal, ReadAndWriteDoNotAllocate) {
  sim::BulletRobot robot(resting_fixed_base());
  ASSERT_TRUE(robot.configure().ok);
  ASSERT_TRUE(robot.activate().ok);
  hal::Measurements m;
  hal::JointCommands c;
  c.mode = hal::CommandMode::enabled;
  robot.step();
  hal::IoStatus read_status{}, write_status{};
  const std::size_t n = test::count_allocations([&] {
    read_status = robot.read(m);
    write_status = robot.write(c);
  });
  EXPECT_EQ(n, 0u);
  EXPECT_EQ(read_status, hal::IoStatus::ok);
  EXPECT_EQ(write_status, hal::IoStatus::ok);
}

TEST(SimHal, ANonFiniteCommandIsRefusedAndTheDrivesGoLimp) {
  sim::BulletRobot robot(resting_fixed_base());
  ASSERT_TRUE(robot.configure().ok);
  ASSERT_TRUE(robot.activate().ok);
  hal::JointCommands c;
  c.mode = hal::CommandMode::enabled;
  c.tau_ff_nm.setConstant(5.0);
  ASSERT_EQ(robot.write(c), hal::IoStatus::ok);
  robot.step();
  EXPECT_DOUBLE_EQ(robot.ground_truth().tau_applied_nm[3], 5.0);
  c.tau_ff_nm[7] = std::nan("");
  EXPECT_EQ(robot.write(c), hal::IoStatus::error);
  robot.step();
  EXPECT_EQ(robot.ground_truth().tau_applied_nm, VecNj::Zero());
}

TEST(SimHal, TorquesSaturateAtTheJointsLimitsAtTheirAngles) {
  sim::BulletRobot robot(resting_fixed_base());
  ASSERT_TRUE(robot.configure().ok);
  ASSERT_TRUE(robot.activate().ok);
  hal::JointCommands c;
  c.mode = hal::CommandMode::enabled;
  c.tau_ff_nm.setConstant(-1000.0);
  ASSERT_EQ(robot.write(c), hal::IoStatus::ok);
  robot.step();
  hal::Measurements m;
  ASSERT_EQ(robot.read(m), hal::IoStatus::ok);
  for (int j = 0; j < kNj; ++j) {
    // The knees start beyond their stops (all joints at 0): the limit at the stop.
    const auto& range = robot::kJoints[j].limits;
    const double q = range.bounded ? std::clamp(robot.ground_truth().q[7 + j], range.lower_rad, range.upper_rad)
                                   : robot.ground_truth().q[7 + j];
    const double limit = j < kFirstArmJoint ? test::hyq_leg_limit_nm(j, q) : robot::kJoints[j].limits.effort_nm;
    EXPECT_NEAR(m.tau_nm[j], -limit, 2.0) << j;  // the angle moved within the step's substeps
    EXPECT_DOUBLE_EQ(robot.ground_truth().tau_applied_nm[j], -robot.ground_truth().tau_limit_nm[j]) << j;
  }
}

// A robot dropped limp from a crouch lies on its folded legs: its knees stay at their stops,
// where the real joints end (the limit rows solved in 3 passes let them creep 0.5 rad past).
TEST(SimHal, ALimpRobotLyingOnItsLegsKeepsItsJointsAtTheirStops) {
  sim::SimConfig c;
  c.initial_q[2] = 1.0;
  for (int leg = 0; leg < kFeet; ++leg) {
    const double side = leg < 2 ? 1.0 : -1.0;  // the front knees bend backwards, the hind forwards
    c.initial_q[7 + leg_first_joint(leg) + 1] = side;
    c.initial_q[7 + leg_first_joint(leg) + 2] = -2.0 * side;
  }
  sim::BulletRobot robot(c);
  ASSERT_TRUE(robot.configure().ok);
  ASSERT_TRUE(robot.activate().ok);
  double worst_rad = 0.0, settled_worst_rad = 0.0;  // past a stop: over the run, over its last 0.2 s
  bool at_a_stop = false;
  for (int k = 0; k < 1000; ++k) {
    robot.step();
    const VecNq& q = robot.ground_truth().q;
    for (int j = 0; j < kNj; ++j) {
      const auto& l = robot::kJoints[j].limits;
      if (!l.bounded) continue;
      const double past_rad = std::max(l.lower_rad - q[7 + j], q[7 + j] - l.upper_rad);
      worst_rad = std::max(worst_rad, past_rad);
      if (k >= 800) settled_worst_rad = std::max(settled_worst_rad, past_rad);
      at_a_stop = at_a_stop || q[7 + j] - l.lower_rad < 1e-2 || l.upper_rad - q[7 + j] < 1e-2;
    }
  }
  EXPECT_TRUE(at_a_stop) << "the legs folded onto their stops";
  EXPECT_TRUE(robot.ground_truth().non_foot_ground_contact) << "lying";
  EXPECT_LT(worst_rad, 0.05) << "landing";
  EXPECT_LT(settled_worst_rad, 0.005) << "lying";
}

TEST(SimHal, ImuAtRestReadsGravityAsSpecificForceInItsFrame) {
  sim::BulletRobot robot(resting_fixed_base());
  ASSERT_TRUE(robot.configure().ok);
  robot.step();
  robot.step();
  hal::Measurements m;
  ASSERT_EQ(robot.read(m), hal::IoStatus::ok);
  ASSERT_TRUE(m.imu.valid);
  const auto& imu = robot::kFrames[kImuFrame];
  const Mat3 r_imu = robot.frame_placement(sim::FrameRef{imu.body, imu.placement}).linear();
  EXPECT_LT((m.imu.linear_accel_m_s2 - r_imu.transpose() * Vec3(0, 0, kGravity_m_s2)).norm(), 1e-9);
  EXPECT_LT(m.imu.angular_rate_rad_s.norm(), 1e-12);
  EXPECT_LT((m.imu.orientation.toRotationMatrix() - r_imu).norm(), 1e-12);
  EXPECT_EQ(m.imu.stamp_ns, 2'000'000);
}

TEST(SimHal, ImuNoiseIsSeededWithTheConfiguredSpread) {
  const auto samples = [](std::uint64_t seed) {
    sim::SimConfig c = resting_fixed_base();
    c.imu.gyro_noise_rad_s = 0.01;
    c.imu.gyro_bias_rad_s = 0.1;
    c.imu.seed = seed;
    sim::BulletRobot robot(c);
    EXPECT_TRUE(robot.configure().ok);
    std::vector<double> x;
    hal::Measurements m;
    for (int k = 0; k < 2000; ++k) {
      robot.step();
      robot.read(m);
      x.push_back(m.imu.angular_rate_rad_s.x());
    }
    return x;
  };
  const auto a = samples(5), b = samples(5), c = samples(6);
  EXPECT_EQ(a, b);
  EXPECT_NE(a, c);
  double mean = 0.0;
  for (double v : a) mean += v / a.size();
  double var = 0.0;
  for (double v : a) var += (v - mean) * (v - mean) / (a.size() - 1);
  EXPECT_NEAR(std::sqrt(var), 0.01, 0.001);  // white noise spread
  EXPECT_GT(std::abs(mean), 1e-3);           // a constant bias drawn once (std 0.1)
}

// The sensor model behind read(): a preset's IMU, encoders, joint torques and F/T reach the
// measurements (quantised, biased: the model's own draws, which sensor_model() exposes); the
// default is ideal (the exact world, as the test above reads it).
TEST(SimHal, TheSensorModelShapesWhatReadReturns) {
  sim::SimConfig c = resting_fixed_base();
  c.sensors = sim::sensor_preset(sim::ImuPreset::mems);
  c.sensors.seed = 9;
  sim::BulletRobot robot(c);
  ASSERT_TRUE(robot.configure().ok);
  for (int k = 0; k < 20; ++k) robot.step();
  hal::Measurements m;
  ASSERT_EQ(robot.read(m), hal::IoStatus::ok);
  const sim::SensorModel& model = robot.sensor_model();
  const double gyro_lsb = c.sensors.imu.gyro.lsb;
  const double d = 2.0 * std::numbers::pi / (c.sensors.encoders.counts_per_rev * c.sensors.encoders.gear_ratio[0]);
  for (int i = 0; i < 3; ++i) {
    EXPECT_NEAR(m.imu.angular_rate_rad_s[i] / gyro_lsb, std::round(m.imu.angular_rate_rad_s[i] / gyro_lsb), 1e-6);
  }
  // At rest the gyro reads its bias (plus noise, 7.7 mrad/s per sample, and a scale error of nothing).
  EXPECT_LT((m.imu.angular_rate_rad_s - model.imu_errors().gyro_bias_rad_s).cwiseAbs().maxCoeff(), 0.05);
  EXPECT_GT(model.imu_errors().gyro_bias_rad_s.norm(), 1e-4);
  const sim::GroundTruth& truth = robot.ground_truth();
  for (int j = 0; j < kNj; ++j) {
    EXPECT_NEAR(m.q_rad[j] / d, std::round(m.q_rad[j] / d), 1e-6) << j;
    EXPECT_LE(std::abs(m.q_rad[j] - truth.q[7 + j]), 0.5 * d + 1e-12) << j;
  }
  EXPECT_NE(m.tau_nm, truth.tau_applied_nm);
  EXPECT_NEAR((m.wrist.force_n - model.wrist_errors().force_offset_n).norm(), 0.0, 1.0) << "no wrench: the offset";

  sim::SimConfig ideal = resting_fixed_base();
  EXPECT_TRUE(sim::is_ideal(ideal.sensors));
  sim::BulletRobot exact(ideal);
  ASSERT_TRUE(exact.configure().ok);
  exact.step();
  ASSERT_EQ(exact.read(m), hal::IoStatus::ok);
  EXPECT_EQ(m.q_rad, exact.ground_truth().q.tail<kNj>());
  EXPECT_EQ(m.tau_nm, exact.ground_truth().tau_applied_nm);
  EXPECT_EQ(m.wrist.force_n, Vec3::Zero());
}

// The legacy ImuNoise and a non-ideal sensors.imu describe one IMU twice: refused.
TEST(SimHal, LegacyImuNoiseAndTheSensorModelsImuAreRefusedTogether) {
  sim::SimConfig c = resting_fixed_base();
  c.imu.gyro_noise_rad_s = 0.01;
  c.sensors.imu = sim::imu_preset(sim::ImuPreset::tactical);
  sim::BulletRobot robot(c);
  const auto r = robot.configure();
  EXPECT_FALSE(r.ok);
  EXPECT_NE(r.message.find("sensors.imu"), std::string::npos) << r.message;
  c.sensors.imu = sim::ImuModelConfig{};
  c.sensors.encoders.velocity = sim::EncoderVelocity::lowpass;  // and no cutoff
  sim::BulletRobot bad(c);
  const auto r2 = bad.configure();
  EXPECT_FALSE(r2.ok);
  EXPECT_NE(r2.message.find("sensors.encoders.velocity_cutoff_hz"), std::string::npos) << r2.message;
}

// The trunk lying on its right side (base rolled +90 deg about x: trunk +y is
// world +z), welded in place with its right face (trunk y = -half width)
// `gap_m` above the ground.
sim::SimConfig trunk_on_its_side(double gap_m) {
  sim::SimConfig c;
  c.fixed_base = true;
  const auto& trunk_box = robot::kCollisions[0];  // the trunk box, centred on the trunk frame
  c.initial_q[2] = 0.5 * trunk_box.size_m[1] + gap_m;
  c.initial_q.segment<4>(3) << std::sin(std::numbers::pi / 4.0), 0.0, 0.0,
      std::cos(std::numbers::pi / 4.0);  // x y z w
  return c;
}

TEST(SimHal, ATrunkOnTheGroundIsANonFootContactCarryingForce) {
  sim::BulletRobot robot(trunk_on_its_side(-1.0e-3));
  ASSERT_TRUE(robot.configure().ok);
  robot.step();
  const sim::GroundTruth& truth = robot.ground_truth();
  EXPECT_TRUE(truth.non_foot_ground_contact);
  EXPECT_GT(truth.ground_force_n.z(), 0.0);  // the ground pushes the sunk trunk up
  EXPECT_FALSE(truth.foot_contact[0]);       // the left feet point sideways, 0.4 m up
  EXPECT_FALSE(truth.foot_contact[2]);
}

TEST(SimHal, ATrunkAboveTheGroundTouchesNothing) {
  sim::BulletRobot robot(trunk_on_its_side(0.1));
  ASSERT_TRUE(robot.configure().ok);
  robot.step();
  const sim::GroundTruth& truth = robot.ground_truth();
  EXPECT_FALSE(truth.non_foot_ground_contact);
  EXPECT_EQ(truth.ground_force_n.z(), 0.0);
  for (int f = 0; f < kFeet; ++f) EXPECT_FALSE(truth.foot_contact[f]) << f;
}

}  // namespace
