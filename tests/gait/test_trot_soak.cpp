// The soaks (ctest label `soak`, not in CI's default run; `ctest --preset debug -L soak`): ten
// minutes of the operator's trot, walks and stand on the estimated state; every shipped trot in place (M_e 0.4 / 4 / 10 x GP1-GP4)
// for 60 s with its 50 N step at the hand and horizontal pushes of up to 80 N for 0.2 s on
// the trunk or the hand every 2-4 s. Each run prints its figures. Measured: all 12 hold, 0 QP
// failures (release build; 21 more runs of three of them with seeds 1-5, 11, 13 too).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <string>

#include "../sim/cli_test_util.hpp"

namespace springbok::test {
namespace {

// The shipped scenario with its duration set to `duration_s` and random pushes added.
std::string with_pushes(const std::string& name, double duration_s, int seed) {
  std::string yaml = slurp(kScenarios + name + ".yaml");
  const auto at = yaml.find("duration_s: ");
  const auto end = yaml.find('\n', at);
  yaml.replace(at, end - at, "duration_s: " + std::to_string(duration_s));
  yaml += "random_pushes: {seed: " + std::to_string(seed) + ", start_s: 3.0, every_s: [2.0, 4.0], duration_s: 0.2, "
          "max_force_n: 80, frames: [trunk, arm_end_effector_link]}\n";
  return yaml;
}

class TrotSoak : public ::testing::TestWithParam<std::string> {};

TEST_P(TrotSoak, StandsSixtySecondsOfRandomPushes) {
  const std::string name = GetParam();
  const fs::path dir = scratch("soak_" + name);
  std::ofstream(dir / "s.yaml") << with_pushes(name, 60.0, 7);
  std::string json;
  ASSERT_NO_FATAL_FAILURE(run_to_summary((dir / "s.yaml").string(), dir / "out", json));
  std::printf("soak %s: fell %s at %g s, qp_failures %g, max tau/limit %g\n", name.c_str(),
              json_true(json, "fell") ? "yes" : "no", json_number(json, "fell_time_s"), json_number(json, "qp_failures"),
              json_number(json, "max_torque_ratio"));
  EXPECT_FALSE(json_true(json, "fell")) << json;
}

// Issue 47's soak: ten minutes on the estimated state with the MEMS preset (the firmware's
// estimator from sim_hal's BMI088-class IMU, encoders through the gear), the trot of walk_forward
// (GP2, M_e 10) on the operator's commands, twice over: trotting in place, forward at 0.5 m/s,
// turning at +-0.5 rad/s (as much each way: the gyro's scale error cancels over the pair),
// sideways at +-0.2 m/s, back at 0.3 m/s, standing a minute, trotting again; and pushes of up to
// 80 N for 0.2 s on the trunk or the hand every 9-12 s throughout (the simulator holds 64 pushes
// and wrenches in all; walk_forward's 30 N step at the hand is one). The robot stands to the end,
// every request is taken, and the estimator's errors against the truth meet issue 47's targets
// (the yaw's while not turning).
TEST(EstimatedSoak, TenMinutesOfTrottingWalkingStandingAndPushesOnTheEstimatedState) {
  std::string yaml = slurp(kScenarios + std::string("walk_forward.yaml"));
  const auto at = yaml.find("duration_s: ");
  yaml.replace(at, yaml.find('\n', at) - at, "duration_s: 600.0");
  const auto velocity = yaml.find(", velocity: [0.5, 0.0, 0.0]}");
  ASSERT_NE(velocity, std::string::npos);
  std::string schedule = ", velocity: [0.0, 0.0, 0.0], velocity_schedule: [";
  const char* cycle[][2] = {{"20", "velocity: [0.5, 0.0, 0.0]"},  {"50", "velocity: [0.0, 0.0, 0.0]"},
                            {"60", "velocity: [0.0, 0.0, 0.5]"},  {"80", "velocity: [0.0, 0.0, -0.5]"},
                            {"100", "velocity: [0.0, 0.0, 0.0]"}, {"110", "velocity: [0.0, 0.2, 0.0]"},
                            {"135", "velocity: [0.0, -0.2, 0.0]"}, {"160", "velocity: [-0.3, 0.0, 0.0]"},
                            {"200", "velocity: [0.0, 0.0, 0.0]"}, {"210", "gait: stand"},
                            {"270", "gait: trot"}};
  for (int c = 0; c < 2; ++c) {
    for (const auto& [t, what] : cycle) {
      schedule += (schedule.back() == '[' ? "{at_s: " : ", {at_s: ") + std::to_string(300 * c + std::stoi(t)) + ", " +
                  what + "}";
    }
  }
  yaml.replace(velocity, std::string(", velocity: [0.5, 0.0, 0.0]}").size(), schedule + "]}");
  yaml += "random_pushes: {seed: 7, start_s: 3.0, every_s: [9.0, 12.0], duration_s: 0.2, max_force_n: 80, "
          "frames: [trunk, arm_end_effector_link]}\n";
  const fs::path dir = scratch("soak_estimated");
  std::ofstream(dir / "s.yaml") << yaml;
  const CliResult r = run((dir / "s.yaml").string(), dir / "out", "--state-source estimated --sensors mems");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const std::string json = slurp(dir / "out" / "summary.json");
  const double tilt = member(json, "estimator", "tilt_rms_error_mrad"),
               velocity_error = member(json, "estimator", "velocity_rms_error_m_s"),
               yaw_drift = member(json, "estimator", "yaw_drift_deg_per_min"),
               yaw_in_place = member(json, "estimator", "yaw_drift_in_place_deg_per_min"),
               turned = member(json, "estimator", "turned_rad"),
               per_turn = member(json, "estimator", "yaw_error_per_turn_percent"),
               walked = member(json, "estimator", "distance_walked_m"),
               drift = member(json, "estimator", "position_drift_percent");
  std::printf("estimated soak, 600 s: fell %s, qp_failures %g; estimator: tilt %.3f mrad rms, velocity %.4f m/s rms, "
              "yaw drift %.3f deg/min (not turning %.3f deg/min; %.3f %% of the %.1f rad turned), position drift "
              "%.3f %% of %.1f m walked\n",
              json_true(json, "fell") ? "yes" : "no", json_number(json, "qp_failures"), tilt, velocity_error, yaw_drift,
              yaw_in_place, per_turn, turned, drift, walked);
  EXPECT_FALSE(json_true(json, "fell")) << json;
  EXPECT_NE(json.find("\"operator_refusals\": []"), std::string::npos) << json;
  EXPECT_NE(json.find("\"state_source\": \"estimated\""), std::string::npos) << json;
  EXPECT_LE(tilt, 2.0);
  EXPECT_LE(velocity_error, 0.03);
  // The yaw target (1 deg/min) is for standing and trotting in place; the turns' heading error
  // is the gyro's scale error's kind (the MEMS preset's: 1 % at 3 sigma). Not met yet: -1.49
  // deg/min not turning (-0.10 without the turns; -1.98 with an ideal IMU). The turns leave the
  // heading at 0.3-0.8 rad, and there the simulated robot creeps: standing at heading 1.2 rad it
  // turns -1.39 deg/min and slides 14 mm a minute, feet and all (at heading 0: 0.01 deg/min),
  // which the estimator's anchored feet (foot_anchored_walk 1e-4) read as gyro bias.
  EXPECT_LE(std::abs(yaw_in_place), 1.0);
  EXPECT_GT(turned, 35.0);
  EXPECT_LE(std::abs(per_turn), 2.0);
  EXPECT_GT(walked, 50.0);
  EXPECT_LE(drift, 2.0);
}

INSTANTIATE_TEST_SUITE_P(EveryTrot, TrotSoak,
                         ::testing::Values("trot_me0p4_gp1", "trot_me0p4_gp2", "trot_me0p4_gp3", "trot_me0p4_gp4",
                                           "trot_me4_gp1", "trot_me4_gp2", "trot_me4_gp3", "trot_me4_gp4",
                                           "trot_me10_gp1", "trot_me10_gp2", "trot_me10_gp3", "trot_me10_gp4"));

}  // namespace
}  // namespace springbok::test
