// The estimator on the Bullet robot against the simulator's ground truth: the
// robot stands on the joint-PD stand controller while its hand is pushed (the
// trunk moves centimetres), with an ideal IMU and with a noisy, biased one.
#include <cmath>

#include <gtest/gtest.h>

#include "springbok/estimation/base_estimator.hpp"
#include "springbok/sim_hal/bullet_robot.hpp"
#include "springbok/wbc/stand_controller.hpp"

namespace {

// The complementary filter (the cases below are its; filter ekf, the default, has its own).
springbok::est::EstimatorParams complementary() {
  springbok::est::EstimatorParams p;
  p.filter = springbok::est::BaseFilter::complementary;
  return p;
}

using namespace springbok;

struct Errors {
  double rms_velocity_m_s = 0.0;
  double max_velocity_m_s = 0.0;
  double max_position_m = 0.0;
  double max_angle_rad = 0.0;
  double base_travel_m = 0.0;  // how far the true trunk moved (the test must move it)
  bool all_feet_down = true;   // leg odometry's premise held throughout
};

Errors run(const sim::ImuNoise& noise) {
  sim::SimConfig config;
  config.imu = noise;
  config.initial_q.tail<kNj>() = wbc::nominal_stance();
  {  // start with the feet just on the ground
    const dyn::Model model;
    auto data = std::make_unique<dyn::Data>();
    dyn::forward_kinematics(model, *data, config.initial_q);
    double lowest = 1e9;
    for (int f : kFootFrames) lowest = std::min(lowest, data->frames[f].translation.z());
    config.initial_q[2] = kFootRadius_m - lowest;
  }
  sim::BulletRobot robot(config);
  EXPECT_TRUE(robot.configure().ok);
  EXPECT_TRUE(robot.activate().ok);
  sim::ExternalWrench push;
  push.frame = *sim::find_frame("arm_end_effector_link");
  push.axis_world = Vec3(0.8, 0.6, 0.0);
  push.profile.shape = sim::ProfileShape::chirp;
  push.profile.amplitude = 15.0;
  push.profile.start_s = 1.0;
  push.profile.duration_s = 4.0;
  push.profile.start_frequency_hz = 0.2;
  push.profile.end_frequency_hz = 1.0;
  EXPECT_TRUE(robot.add_external_wrench(push));
  wbc::StandController stand(wbc::StandGains{}, wbc::nominal_stance());
  est::BaseEstimator estimator(complementary());
  const Stance all{true, true, true, true};
  hal::Measurements m;
  hal::JointCommands cmd;
  Errors e;
  int n = 0;
  const Vec3 start = config.initial_q.head<3>();
  for (int k = 0; k < 5000; ++k) {
    EXPECT_EQ(robot.read(m), hal::IoStatus::ok);
    const sim::GroundTruth& truth = robot.ground_truth();
    if (k == 500) {  // settled: start estimating from the true horizontal position
      EXPECT_EQ(estimator.reset(m, all, truth.q.head<2>()), est::EstimateStatus::ok);
    } else if (k > 500) {
      const est::BaseEstimate& s = estimator.update(m, all, config.step_s);
      EXPECT_EQ(s.status, est::EstimateStatus::ok);
      const Vec3 dv = robot.ground_truth().v.head<3>() - s.v.head<3>();
      e.rms_velocity_m_s += dv.squaredNorm();
      e.max_velocity_m_s = std::max(e.max_velocity_m_s, dv.norm());
      ++n;
      for (bool c : truth.foot_contact) e.all_feet_down = e.all_feet_down && c;
      e.max_position_m = std::max(e.max_position_m, (truth.q.head<3>() - s.q.head<3>()).norm());
      const Quat qt(truth.q[6], truth.q[3], truth.q[4], truth.q[5]), qe(s.q[6], s.q[3], s.q[4], s.q[5]);
      e.max_angle_rad = std::max(e.max_angle_rad, qt.angularDistance(qe));
      e.base_travel_m = std::max(e.base_travel_m, (truth.q.head<3>() - start).norm());
    }
    stand.tick(truth.q, cmd);
    EXPECT_EQ(robot.write(cmd), hal::IoStatus::ok);
    robot.step();
  }
  e.rms_velocity_m_s = std::sqrt(e.rms_velocity_m_s / n);
  return e;
}

TEST(EstimatorSim, TracksTheTrunkOfThePushedRobot) {
  const Errors e = run(sim::ImuNoise{});
  RecordProperty("rms_velocity_m_s", std::to_string(e.rms_velocity_m_s));
  std::printf("ideal IMU: travel %.4f m, velocity rms %.5f max %.5f m/s, position max %.5f m, angle max %.2e rad\n",
              e.base_travel_m, e.rms_velocity_m_s, e.max_velocity_m_s, e.max_position_m, e.max_angle_rad);
  EXPECT_GT(e.base_travel_m, 0.01);
  EXPECT_TRUE(e.all_feet_down);
  EXPECT_LT(e.max_angle_rad, 1e-6);
  // Bullet's contacts are compliant (mm of penetration that varies with the load), so
  // leg odometry is not exact here: measured 7.4 mm/s rms, 4.8 mm over 49 mm of travel.
  EXPECT_LT(e.rms_velocity_m_s, 0.012);
  EXPECT_LT(e.max_position_m, 0.008);
}

TEST(EstimatorSim, NoisyBiasedImuStaysBounded) {
  sim::ImuNoise noise;
  noise.gyro_noise_rad_s = 0.005;
  noise.accel_noise_m_s2 = 0.05;
  noise.gyro_bias_rad_s = 0.002;
  noise.accel_bias_m_s2 = 0.05;
  noise.seed = 7;
  const Errors e = run(noise);
  std::printf("noisy IMU: velocity rms %.5f max %.5f m/s, position max %.5f m\n", e.rms_velocity_m_s, e.max_velocity_m_s,
              e.max_position_m);
  EXPECT_LT(e.rms_velocity_m_s, 0.015);
  EXPECT_LT(e.max_position_m, 0.01);
}

}  // namespace
