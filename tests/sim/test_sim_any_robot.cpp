// The robot-neutral base step (tools/scenarios/any_robot/base_step.yaml) on the robot this build
// is for, whichever it is: the stance, the template, the feet and the hand all come from the
// robot file, the push is 5 % of the robot's weight. A robot folder of your own passes this with
// no code change, or says why not.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdlib>
#include <sstream>

#include "cli_test_util.hpp"
#include "springbok/model/model.hpp"

namespace {
using namespace springbok::test;

TEST(SimAnyRobot, RendersTheBaseStepOfItsRobotFile) {
  const fs::path dir = scratch("any_robot_base_step");
  std::string json;
  ASSERT_NO_FATAL_FAILURE(run_to_summary(kScenarios + "any_robot/base_step.yaml", dir / "out", json));
  expect_upright_and_solved(json);
  EXPECT_LE(json_number(json, "max_torque_ratio"), 1.0);
  EXPECT_LE(member(json, "nrmse", "base_x"), 0.08);
  EXPECT_LE(member(json, "nrmse", "ee_x"), 0.03);
  // At rest the template's closed form: the base F / K_b forward, F = 0.05 m g.
  const double force_n = 0.05 * springbok::total_mass_kg() * springbok::kGravity_m_s2;
  const double rest_m = force_n / springbok::robot::kTemplate.base.stiffness;
  const std::vector<double> t = log_column(dir / "out" / "log.csv", "time_s");
  const std::vector<double> x = log_column(dir / "out" / "log.csv", "base_x_m");
  ASSERT_EQ(t.size(), x.size());
  const auto before_push = static_cast<std::size_t>(std::lower_bound(t.begin(), t.end(), 0.999) - t.begin());
  ASSERT_LT(before_push, x.size());
  EXPECT_NEAR(x.back() - x[before_push], rest_m, 0.01 * rest_m);
}

// tools/experiments/run_all --quick on this build: its robot's scenarios (tools/scenarios/<robot>/,
// or any_robot/), the report, and every quick target met.
TEST(SimAnyRobot, TheQuickExperimentsMeetTheirTargets) {
  const fs::path dir = scratch("any_robot_run_all");
  const std::string cmd = "'" + std::string(SPRINGBOK_SOURCE_DIR) + "/tools/experiments/run_all' --quick --jobs 1 --robot " +
                          SPRINGBOK_ROBOT_NAME + " '" + SPRINGBOK_BIN_DIR + "' '" + dir.string() + "' > '" +
                          (dir / "run_all.txt").string() + "' 2>&1";
  EXPECT_EQ(std::system(cmd.c_str()), 0) << slurp(dir / "run_all.txt");
  const std::string out = slurp(dir / "run_all.txt");
  EXPECT_EQ(out.find("MISS"), std::string::npos) << out;
  EXPECT_NE(out.find("PASS"), std::string::npos) << out;
  const std::string report = slurp(dir / "report.md");
  EXPECT_NE(report.find("## Targets"), std::string::npos);
  // The tick's timing: three runs of each (memory locked), one line per tick (0 before the WBC
  // starts), the report's table.
  int timed = 0;
  for (const auto& run : fs::directory_iterator(dir)) {
    if (!fs::exists(run.path() / "summary.json")) continue;
    ++timed;
    std::istringstream ticks(slurp(run.path() / "tick_us.txt"));
    std::string line;
    std::size_t lines = 0, wbc_ticks = 0;
    while (std::getline(ticks, line)) {
      std::istringstream cells(line);
      double us = 0.0, sum_us = 0.0;
      int columns = 0;
      while (cells >> us) {
        ASSERT_GE(us, 0.0) << run.path();
        sum_us += us;
        ++columns;
      }
      ASSERT_EQ(columns, 3) << run.path() << ": " << line;
      ++lines;
      wbc_ticks += sum_us > 0.0 ? 1 : 0;
    }
    EXPECT_EQ(static_cast<double>(lines), json_number(slurp(run.path() / "summary.json"), "ticks")) << run.path();
    EXPECT_GT(wbc_ticks, lines / 2) << run.path();
  }
  EXPECT_GT(timed, 0);
  EXPECT_NE(report.find("## Tick time: the worst case"), std::string::npos);
  EXPECT_NE(report.find("minimum over 3 runs"), std::string::npos);
}

}  // namespace
