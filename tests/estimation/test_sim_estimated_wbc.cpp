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
  std::ofstream(dir / "s.yaml") << scenario("{velocity_gain: 30, position_gain: 10}");
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

TEST(SimEstimatedWbc, BadEstimatorParameterIsNamed) {
  const fs::path dir = scratch("wbc_estimated_bad");
  std::ofstream(dir / "s.yaml") << scenario("{velocity_gain: -3}");
  const CliResult r = run((dir / "s.yaml").string(), dir / "out");
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.err.find("controller.params.estimator.velocity_gain"), std::string::npos) << r.err;
}

}  // namespace
}  // namespace springbok::test
