// springbok-sim with the WBC on the ESTIMATED base state (controller.params.estimator):
// the robot must render a 50 N step at the hand without falling or failing a QP,
// every estimator update must be ok, and the estimate the WBC used must track the
// simulator's ground truth. A bad estimator parameter is refused naming its field.
#include <gtest/gtest.h>

#include <fstream>
#include <string>

#include "../sim/cli_test_util.hpp"

namespace springbok::test {
namespace {

std::string scenario(const std::string& estimator) {
  return wbc_scenario_head("3.0", "0.2", "{mass: 4, damping: 126.5, stiffness: 1000}", "{mass: 4, damping: 90, stiffness: 500}") +
         "    estimator: " + estimator + "\n"
         "external_wrenches:\n"
         "  - {frame: arm_end_effector_link, axis: [1, 0, 0], profile: step, amplitude: 50, start_s: 0.5}\n";
}

TEST(SimEstimatedWbc, StepWithTheEstimatedBaseState) {
  const fs::path dir = scratch("wbc_estimated");
  std::ofstream(dir / "s.yaml") << scenario("{filter: complementary, velocity_gain: 30, position_gain: 10}");
  std::string json;
  ASSERT_NO_FATAL_FAILURE(run_to_summary((dir / "s.yaml").string(), dir / "out", json));
  expect_upright_and_solved(json);
  EXPECT_TRUE(json_true(json.substr(json.find("\"estimator\":")), "all_ok")) << json;
  // Measured: 0.11 mm/s rms and 0.04 mm (a foot creeping on the ground, which leg odometry
  // cannot see, shows up here: a ground-plane bounding box that dropped hovering contact
  // points made the feet creep ~5 mm/s and the position error 1 cm).
  EXPECT_LT(member(json, "estimator", "velocity_rms_error_m_s"), 0.002) << json;
  EXPECT_LT(member(json, "estimator", "position_max_error_m"), 0.001) << json;
  // The template is rendered on the estimated state as on the ground truth (base_step_mb4:
  // 1.3 %). Where the Gen3's wrist reaches its speed limit (joint 6, 1.22 rad/s: the template
  // asks the hand for ~0.5 m/s) the estimate decides on which tick the limit binds: 2.1 %.
  EXPECT_LE(member(json, "nrmse", "base_x"), 0.03) << json;
  EXPECT_LE(member(json, "nrmse", "ee_x"), 0.03) << json;
  EXPECT_LE(member(json, "steady_state_error", "base_x"), 0.01) << json;
}

// A MEMS-class IMU (white noise 5 mrad/s and 0.04 m/s^2 per sample, turn-on biases of 10 mrad/s
// and 0.1 m/s^2 std; the simulated IMU's orientation output stays exact): the EKF (filter ekf)
// learns the biases from the raw gyro and specific force and the legs, and the step is rendered
// as on the ground truth; the complementary filter, which integrates the biased accelerometer,
// tracks the velocity several times worse.
TEST(SimEstimatedWbc, TheEkfLearnsABiasedImuAndTheStepIsRenderedAsOnTheTruth) {
  const std::string imu =
      "sim:\n  imu: {gyro_noise_rad_s: 0.005, accel_noise_m_s2: 0.04, gyro_bias_rad_s: 0.01, accel_bias_m_s2: 0.1, "
      "seed: 3}\n";
  const auto summary = [&](const std::string& name, const std::string& text) {
    const fs::path dir = scratch(name);
    std::ofstream(dir / "s.yaml") << text;
    std::string json;
    run_to_summary((dir / "s.yaml").string(), dir / "out", json);
    return json;
  };
  std::string truth = scenario("{filter: ekf}");
  truth.erase(truth.find("    estimator:"), truth.find("external_wrenches") - truth.find("    estimator:"));
  const std::string on_truth = summary("wbc_ekf_truth", truth + imu);
  const std::string ekf = summary("wbc_ekf", scenario("{filter: ekf}") + imu);
  const std::string complementary = summary("wbc_ekf_complementary", scenario("{filter: complementary, velocity_gain: 30, position_gain: 10}") + imu);
  ASSERT_FALSE(on_truth.empty() || ekf.empty() || complementary.empty());
  expect_upright_and_solved(ekf);
  EXPECT_TRUE(json_true(ekf.substr(ekf.find("\"estimator\":")), "all_ok")) << ekf;
  const double v_ekf = member(ekf, "estimator", "velocity_rms_error_m_s");
  const double v_complementary = member(complementary, "estimator", "velocity_rms_error_m_s");
  std::printf("biased IMU: velocity rms error ekf %.4f m/s, complementary %.4f m/s; position max error ekf %.5f m, "
              "complementary %.5f m; NRMSE base / hand: truth %.4f / %.4f, ekf %.4f / %.4f, complementary %.4f / %.4f\n",
              v_ekf, v_complementary, member(ekf, "estimator", "position_max_error_m"),
              member(complementary, "estimator", "position_max_error_m"), member(on_truth, "nrmse", "base_x"),
              member(on_truth, "nrmse", "ee_x"), member(ekf, "nrmse", "base_x"), member(ekf, "nrmse", "ee_x"),
              member(complementary, "nrmse", "base_x"), member(complementary, "nrmse", "ee_x"));
  EXPECT_LT(v_ekf, 0.01) << ekf;
  EXPECT_LT(v_ekf, 0.5 * v_complementary);
  EXPECT_LT(member(ekf, "estimator", "position_max_error_m"), 0.002) << ekf;
  // The targets: within 1.5x the ground truth's NRMSE (or its absolute targets' tenth,
  // where the truth's is near zero), steady state within 1 %.
  for (const char* axis : {"base_x", "ee_x"}) {
    const double truth_nrmse = member(on_truth, "nrmse", axis);
    EXPECT_LE(member(ekf, "nrmse", axis), std::max(1.5 * truth_nrmse, 0.003)) << axis << "\n" << ekf;
  }
  EXPECT_LE(member(ekf, "steady_state_error", "base_x"), 0.01) << ekf;
  EXPECT_LE(member(ekf, "steady_state_error", "ee_x"), 0.01) << ekf;
}

TEST(SimEstimatedWbc, BadEstimatorParameterIsNamed) {
  const fs::path dir = scratch("wbc_estimated_bad");
  std::ofstream(dir / "s.yaml") << scenario("{filter: complementary, velocity_gain: -3}");
  const CliResult r = run((dir / "s.yaml").string(), dir / "out");
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.err.find("controller.params.estimator.velocity_gain"), std::string::npos) << r.err;
  std::ofstream(dir / "t.yaml") << scenario("{filter: ekf, ekf: {slip_gate_chi2: -1}}");
  const CliResult e = run((dir / "t.yaml").string(), dir / "out");
  EXPECT_NE(e.exit_code, 0);
  EXPECT_NE(e.err.find("controller.params.estimator.ekf.slip_gate_chi2"), std::string::npos) << e.err;
}

}  // namespace
}  // namespace springbok::test
