// The base state a run gives the WBC (controller.params.state_source, springbok-sim
// --state-source), the sensors it runs on (--sensors), the still start-up before it
// (BulletRobot::hold_still) and the estimator's errors against the truth (EstimatorErrors).
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <string>

#include "cli_test_util.hpp"
#include "estimator_errors.hpp"
#include "springbok/sim_hal/bullet_robot.hpp"

namespace springbok::test {
namespace {

using Pose = Eigen::Matrix<double, 7, 1>;

Pose pose(double x, double y, double z, const Eigen::Quaterniond& q) {
  Pose p;
  p << x, y, z, q.x(), q.y(), q.z(), q.w();
  return p;
}

// Closed-form cases: a constant tilt error, a heading error growing at a known rate, a position
// error growing along a straight walk.
TEST(EstimatorErrors, TiltYawAndDriftAreTheirDefinitions) {
  constexpr double dt = 1e-3;
  constexpr double kTilt = 2e-3;           // rad, about x
  constexpr double kYawRate = 1e-3;        // rad/s of heading error
  constexpr double kWalk = 0.5;            // m/s along x
  constexpr double kDriftRate = 0.005;     // m/s of position error along y: 1 % of the distance
  simtool::EstimatorErrors e;
  const int n = 60001;  // 60 s
  for (int k = 0; k < n; ++k) {
    const double t = k * dt;
    const double yaw_true = 0.3 * std::sin(t);  // the truth turns too: only the error counts
    const Eigen::Quaterniond q_true(Eigen::AngleAxisd(yaw_true, Eigen::Vector3d::UnitZ()));
    const Eigen::Quaterniond q_est =
        Eigen::AngleAxisd(yaw_true + kYawRate * t, Eigen::Vector3d::UnitZ()) * Eigen::AngleAxisd(kTilt, Eigen::Vector3d::UnitX());
    const Pose truth = pose(kWalk * t, 0.0, 0.6, q_true);
    const Pose est = pose(kWalk * t, kDriftRate * t, 0.6, q_est);
    e.add(est, Eigen::Vector3d(kWalk, 0.01, 0.0), truth, Eigen::Vector3d(kWalk, 0.0, 0.0), true, dt);
  }
  EXPECT_NEAR(e.tilt_rms_rad(), kTilt, 1e-9);
  EXPECT_NEAR(e.yaw_drift_rad_per_min(), kYawRate * 60.0, 1e-9);
  EXPECT_NEAR(e.distance_walked_m(), kWalk * 60.0, 1e-6);
  EXPECT_NEAR(e.position_drift_percent(), 100.0 * kDriftRate / kWalk, 1e-6);
  EXPECT_NEAR(e.velocity_rms_m_s(), 0.01, 1e-12);
  EXPECT_NE(e.json().find("\"all_ok\": true"), std::string::npos) << e.json();
}

// The heading error split by turning: the truth turns at 0.5 rad/s for 20 s (10 rad; the estimate
// turns 1 % more: a gyro scale error), then stands 40 s while the estimate drifts at 1 mrad/s.
// In place: the drift's 0.06 rad/min; per turn: 1 % (the low-pass's onset counts as in place,
// its decay after the turn, 1.2 s of drift, as turning: 1.01 %).
TEST(EstimatorErrors, TheHeadingErrorIsSplitIntoTurningAndInPlace) {
  constexpr double dt = 1e-3, kTurn = 0.5, kScale = 0.01, kDrift = 1e-3;
  simtool::EstimatorErrors e;
  double yaw_true = 0.0, yaw_est = 0.0;
  for (int k = 0; k <= 60000; ++k) {
    const bool turning = k > 0 && k <= 20000;
    yaw_true += turning ? kTurn * dt : 0.0;
    yaw_est += turning ? (1.0 + kScale) * kTurn * dt : (k > 20000 ? kDrift * dt : 0.0);
    e.add(pose(0, 0, 0.6, Eigen::Quaterniond(Eigen::AngleAxisd(yaw_est, Eigen::Vector3d::UnitZ()))),
          Eigen::Vector3d::Zero(), pose(0, 0, 0.6, Eigen::Quaterniond(Eigen::AngleAxisd(yaw_true, Eigen::Vector3d::UnitZ()))),
          Eigen::Vector3d::Zero(), true, dt);
  }
  EXPECT_NEAR(e.turned_rad(), 10.0, 0.1);
  EXPECT_NEAR(e.yaw_error_per_turn_percent(), 100.0 * kScale, 0.02);
  EXPECT_NEAR(e.yaw_drift_in_place_rad_per_min(), kDrift * 60.0, 0.002);
  EXPECT_NEAR(e.yaw_drift_rad_per_min(), (kScale * 10.0 + kDrift * 40.0) / 1.0, 1e-6);
  EXPECT_NE(e.json().find("\"yaw_error_per_turn_percent\": 1.0"), std::string::npos) << e.json();
}

// A heading error that crosses +-pi is one error, not a jump of 2 pi; under 0.5 m walked there is
// no drift per distance; one bad estimate says so.
TEST(EstimatorErrors, TheHeadingUnwrapsAndShortWalksHaveNoDrift) {
  simtool::EstimatorErrors e;
  for (int k = 0; k <= 1000; ++k) {
    const double err = 3.1 + 1e-4 * k;  // past pi at k = 416
    const Pose est = pose(0, 0, 0.6, Eigen::Quaterniond(Eigen::AngleAxisd(err, Eigen::Vector3d::UnitZ())));
    e.add(est, Eigen::Vector3d::Zero(), pose(0, 0, 0.6, Eigen::Quaterniond::Identity()), Eigen::Vector3d::Zero(),
          k != 500, 1e-3);
  }
  EXPECT_NEAR(e.yaw_drift_rad_per_min(), 0.1 * 60.0, 1e-9);
  EXPECT_LT(e.position_drift_percent(), 0.0);
  EXPECT_NE(e.json().find("\"position_drift_percent\": null"), std::string::npos) << e.json();
  EXPECT_NE(e.json().find("\"yaw_error_per_turn_percent\": null"), std::string::npos) << e.json();
  EXPECT_NE(e.json().find("\"all_ok\": false"), std::string::npos) << e.json();
}

// Held still, the robot's sensors sample it anew each tick (their stamps advance, the MEMS gyro's
// noise is new), while the world and its clock stand.
TEST(BulletRobotHold, TheSensorsSampleTheStillRobotAndTheClockStands) {
  sim::SimConfig c;
  c.sensors = sim::sensor_preset(sim::ImuPreset::mems);
  sim::BulletRobot robot(c);
  ASSERT_TRUE(robot.configure().ok);
  hal::Measurements first, m;
  ASSERT_EQ(robot.read(first), hal::IoStatus::ok);
  const VecNq q0 = robot.ground_truth().q;
  double rate_sq = 0.0;
  Eigen::Vector3d rate_sum = Eigen::Vector3d::Zero();
  constexpr int kTicks = 2000;
  for (int i = 1; i <= kTicks; ++i) {
    robot.hold_still();
    ASSERT_EQ(robot.read(m), hal::IoStatus::ok);
    ASSERT_EQ(m.imu.stamp_ns - first.imu.stamp_ns, static_cast<std::int64_t>(i) * 1000000) << i;
    rate_sum += m.imu.angular_rate_rad_s;
    rate_sq += m.imu.angular_rate_rad_s.squaredNorm();
  }
  EXPECT_EQ(robot.time_s(), 0.0);
  EXPECT_EQ(robot.ground_truth().q, q0);
  // The samples: the turn-on bias plus white noise of the preset's density (0.014 deg/s/sqrt(Hz) at
  // 1 kHz: 7.7 mrad/s per sample), their mean the bias the model drew.
  const Eigen::Vector3d mean = rate_sum / kTicks;
  const double spread = std::sqrt(rate_sq / kTicks - mean.squaredNorm()) / std::sqrt(3.0);
  EXPECT_NEAR(spread, 0.014 * M_PI / 180.0 * std::sqrt(1000.0), 1e-3);
  EXPECT_LT((mean - robot.sensor_model().imu_errors().gyro_bias_rad_s).norm(), 5.0 * spread / std::sqrt(kTicks));
}

std::string stand_wbc(double duration_s) {
  return "duration_s: " + std::to_string(duration_s) +
         "\ninitial: {joint_positions_rad: [0, 0.7, -1.4, 0, 0.7, -1.4, 0, -0.7, 1.4, 0, -0.7, 1.4, 0, 0.6, 0, 1.9, 0, "
         "0.9, 0], feet_clearance_m: 0.0}\n"
         "controller: {type: wbc, settle_s: 0.5, params: {contact: {foot_radius: 0.02175}}}\n";
}

// --state-source and --sensors over the scenario; summary.json says what the run was, and the
// estimator is scored either way; bad values are refused naming the option.
TEST(SimStateSource, TheCommandLineChoosesTheStateAndTheSensors) {
  const fs::path dir = scratch("state_source");
  std::ofstream(dir / "s.yaml") << stand_wbc(1.5);
  std::string truth, estimated;
  ASSERT_NO_FATAL_FAILURE(run_to_summary((dir / "s.yaml").string(), dir / "truth", truth));
  EXPECT_NE(truth.find("\"state_source\": \"truth\""), std::string::npos) << truth;
  EXPECT_NE(truth.find("\"sensors\": \"ideal\""), std::string::npos) << truth;
  const CliResult r = run((dir / "s.yaml").string(), dir / "est", "--state-source estimated --sensors mems --sensors-seed 3");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  estimated = slurp(dir / "est" / "summary.json");
  EXPECT_NE(estimated.find("\"state_source\": \"estimated\""), std::string::npos) << estimated;
  EXPECT_NE(estimated.find("\"sensors\": \"mems\""), std::string::npos) << estimated;
  expect_upright_and_solved(estimated);
  // Standing: the EKF, its gyro calibrated in the still start-up, against the truth.
  EXPECT_LT(member(estimated, "estimator", "tilt_rms_error_mrad"), 2.0) << estimated;
  EXPECT_LT(member(estimated, "estimator", "velocity_rms_error_m_s"), 0.03) << estimated;
  EXPECT_LT(std::abs(member(estimated, "estimator", "yaw_drift_deg_per_min")), 2.0) << estimated;
  // The log's per-tick errors are the summary's: the tilt's rms, the heading error's last change.
  const std::vector<double> active = log_column(dir / "est" / "log.csv", "wbc_active");
  const std::vector<double> tilt = log_column(dir / "est" / "log.csv", "estimate_tilt_error_rad");
  const std::vector<double> yaw = log_column(dir / "est" / "log.csv", "estimate_yaw_drift_rad");
  const std::vector<double> speed = log_column(dir / "est" / "log.csv", "estimate_velocity_error_m_s");
  ASSERT_EQ(tilt.size(), active.size());
  ASSERT_EQ(speed.size(), active.size());
  double tilt_sq = 0.0, speed_sq = 0.0;
  int ticks = 0;
  for (std::size_t i = 0; i < active.size(); ++i) {
    if (active[i] != 1.0) continue;
    tilt_sq += tilt[i] * tilt[i];
    speed_sq += speed[i] * speed[i];
    ++ticks;
  }
  ASSERT_GT(ticks, 500);
  EXPECT_NEAR(1e3 * std::sqrt(tilt_sq / ticks), member(estimated, "estimator", "tilt_rms_error_mrad"), 1e-3);
  EXPECT_NEAR(std::sqrt(speed_sq / ticks), member(estimated, "estimator", "velocity_rms_error_m_s"), 1e-6);
  EXPECT_NEAR(yaw.back() * 180.0 / M_PI / ((ticks - 1) * 1e-3 / 60.0),
              member(estimated, "estimator", "yaw_drift_deg_per_min"), 1e-3);
  // Ideal sensors: the estimate is the truth to within what the filter's models leave.
  EXPECT_LT(member(truth, "estimator", "tilt_rms_error_mrad"), 0.1) << truth;

  EXPECT_NE(run((dir / "s.yaml").string(), dir / "bad", "--state-source guess").err.find("--state-source"),
            std::string::npos);
  EXPECT_NE(run((dir / "s.yaml").string(), dir / "bad", "--sensors perfect").err.find("--sensors"), std::string::npos);
  std::ofstream(dir / "k.yaml") << stand_wbc(1.0).replace(stand_wbc(1.0).find("contact:"), 0, "state_source: ground, ");
  const CliResult k = run((dir / "k.yaml").string(), dir / "bad");
  EXPECT_EQ(k.exit_code, 2);
  EXPECT_NE(k.err.find("controller.params.state_source"), std::string::npos) << k.err;
  std::string still = stand_wbc(1.0);
  still.replace(still.find("settle_s:"), 0, "still_start_s: -1, ");
  std::ofstream(dir / "still.yaml") << still;
  const CliResult st = run((dir / "still.yaml").string(), dir / "bad");
  EXPECT_EQ(st.exit_code, 2);
  EXPECT_NE(st.err.find("controller.still_start_s"), std::string::npos) << st.err;
}

}  // namespace
}  // namespace springbok::test
