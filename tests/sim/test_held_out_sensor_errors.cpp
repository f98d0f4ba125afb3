// The paper's base step (base_step_mb92.yaml) on the estimated state with sensor errors the shipped
// runs do not use, each within a preset's range (sim_hal/sensor_models.hpp's table): other draws,
// the delays a bus adds, turn-on biases at the MEMS datasheet's 3-sigma bound, a slower
// accelerometer, full-scale scale errors, the tactical preset. Each is run again on the
// simulator's ground truth with the same sensors; the estimated run must meet the stance targets
// (issue 47): NRMSE base <= 8 % and EE <= 3 %, each at most 1.5x the truth run's (a floor of
// 0.2 %: below it the ratio is the noise's), steady state <= 1 %, and the estimator's errors
// within their targets (tilt <= 2 mrad rms, velocity <= 0.03 m/s rms).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <ostream>
#include <string>

#include "cli_test_util.hpp"

namespace springbok::test {
namespace {

struct SensorCase {
  const char* name;
  const char* sensors;  // the scenario's sim.sensors, flow style
};

void PrintTo(const SensorCase& c, std::ostream* os) { *os << c.name; }

class HeldOutSensorErrors : public ::testing::TestWithParam<SensorCase> {};

std::string scenario_with(const std::string& sensors) {
  return slurp(kScenarios + "base_step_mb92.yaml") + "\nsim:\n  sensors: " + sensors + "\n";
}

TEST_P(HeldOutSensorErrors, TheBaseStepOnTheEstimatedStateMeetsTheStanceTargets) {
  const SensorCase& c = GetParam();
  const fs::path dir = scratch(std::string("held_out_") + c.name);
  std::ofstream(dir / "s.yaml") << scenario_with(c.sensors);
  std::string estimated, truth;
  {
    const CliResult r = run((dir / "s.yaml").string(), dir / "est", "--state-source estimated");
    ASSERT_EQ(r.exit_code, 0) << r.err;
    estimated = slurp(dir / "est" / "summary.json");
  }
  {
    const CliResult r = run((dir / "s.yaml").string(), dir / "truth", "--state-source truth");
    ASSERT_EQ(r.exit_code, 0) << r.err;
    truth = slurp(dir / "truth" / "summary.json");
  }
  expect_upright_and_solved(estimated);
  const double nb = member(estimated, "nrmse", "base_x"), ne = member(estimated, "nrmse", "ee_x");
  const double sb = std::abs(member(estimated, "steady_state_error", "base_x"));
  const double se = std::abs(member(estimated, "steady_state_error", "ee_x"));
  const double tb = member(truth, "nrmse", "base_x"), te = member(truth, "nrmse", "ee_x");
  const double tsb = std::abs(member(truth, "steady_state_error", "base_x"));
  const double tse = std::abs(member(truth, "steady_state_error", "ee_x"));
  const double tilt = member(estimated, "estimator", "tilt_rms_error_mrad");
  const double speed = member(estimated, "estimator", "velocity_rms_error_m_s");
  std::printf("%s: NRMSE base %.2f %% (truth %.2f %%), EE %.2f %% (%.2f %%); steady state base %.2f %% (%.2f %%), EE "
              "%.2f %% (%.2f %%); tilt %.3f mrad rms, velocity %.4f m/s rms\n",
              c.name, 100 * nb, 100 * tb, 100 * ne, 100 * te, 100 * sb, 100 * tsb, 100 * se, 100 * tse, tilt, speed);
  EXPECT_LE(nb, 0.08);
  EXPECT_LE(ne, 0.03);
  EXPECT_LE(sb, 0.01);
  EXPECT_LE(se, 0.01);
  EXPECT_LE(nb, 1.5 * std::max(tb, 0.002));
  EXPECT_LE(ne, 1.5 * std::max(te, 0.002));
  EXPECT_LE(tilt, 2.0);
  EXPECT_LE(speed, 0.03);
}

INSTANTIATE_TEST_SUITE_P(
    WithinThePresetsRanges, HeldOutSensorErrors,
    ::testing::Values(
        SensorCase{"other_draws", "{preset: mems, seed: 7}"},
        SensorCase{"bus_delays", "{preset: mems, seed: 11, imu: {preset: mems, gyro: {delay_ticks: 3}, accel: {delay_ticks: 2}}}"},
        // The BMI088's turn-on bounds: 1 deg/s and 20 mg on every axis, on top of the draw.
        SensorCase{"turn_on_bounds", "{preset: mems, seed: 13, imu: {preset: mems, gyro: {bias_offset_rad_s: [0.01745, -0.01745, "
                                     "0.01745]}, accel: {bias_offset_m_s2: [0.196, -0.196, 0.196]}}}"},
        SensorCase{"slow_accel_full_scale", "{preset: mems, seed: 17, imu: {preset: mems, gyro: {scale_factor_std: 0.01}, "
                                            "accel: {scale_factor_std: 0.01, sample_rate_hz: 400}}}"},
        SensorCase{"tactical", "{preset: tactical, seed: 19}"}),
    [](const ::testing::TestParamInfo<SensorCase>& info) { return std::string(info.param.name); });

}  // namespace
}  // namespace springbok::test
