// The trots under seeded random pushes (ctest label `soak`, not in CI's default run;
// `ctest --preset debug -L soak`): every shipped trot in place (M_e 0.4 / 4 / 10 x GP1-GP4)
// for 60 s with its 50 N step at the hand and horizontal pushes of up to 80 N for 0.2 s on
// the trunk or the hand every 2-4 s. Each run prints its figures. Measured: all 12 hold, 0 QP
// failures (release build; 21 more runs of three of them with seeds 1-5, 11, 13 too).
#include <gtest/gtest.h>

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

INSTANTIATE_TEST_SUITE_P(EveryTrot, TrotSoak,
                         ::testing::Values("trot_me0p4_gp1", "trot_me0p4_gp2", "trot_me0p4_gp3", "trot_me0p4_gp4",
                                           "trot_me4_gp1", "trot_me4_gp2", "trot_me4_gp3", "trot_me4_gp4",
                                           "trot_me10_gp1", "trot_me10_gp2", "trot_me10_gp3", "trot_me10_gp4"));

}  // namespace
}  // namespace springbok::test
