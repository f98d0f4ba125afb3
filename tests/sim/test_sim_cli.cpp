// springbok-sim on the shipped scenarios: stand holds, the drop rests with the
// contact forces carrying the weight, and two runs are byte-identical.
#include <gtest/gtest.h>

#include "cli_test_util.hpp"
#include "springbok/isa/isa.hpp"

namespace {
using namespace springbok::test;

TEST(SimCli, StandHoldsStillAndRunsAreByteIdentical) {
  const fs::path dir = scratch("stand");
  const CliResult a = run(kScenarios + "stand.yaml", dir / "a");
  ASSERT_EQ(a.exit_code, 0) << a.err;
  const CliResult b = run(kScenarios + "stand.yaml", dir / "b");
  ASSERT_EQ(b.exit_code, 0) << b.err;
  const std::string log_a = slurp(dir / "a" / "log.csv");
  EXPECT_EQ(log_a, slurp(dir / "b" / "log.csv")) << "two runs of stand.yaml differ";
  EXPECT_EQ(std::count(log_a.begin(), log_a.end(), '\n'), 10001);  // header + one row per tick
  const std::string summary = slurp(dir / "a" / "summary.json");
  EXPECT_FALSE(json_true(summary, "fell")) << summary;
  EXPECT_DOUBLE_EQ(json_number(summary, "sim_seconds"), 10.0);
  EXPECT_GT(json_number(summary, "realtime_factor"), 0.0);
  EXPECT_NEAR(json_number(summary, "contact_fz_over_weight"), 1.0, 1e-3) << summary;
  EXPECT_NEAR(json_number(summary, "feet_fz_over_weight"), 1.0, 1e-3) << summary;
  // The level its kernels ran at: the one this process (same binary build, same environment) picks.
  EXPECT_NE(summary.find(std::string("\"kernels\": \"") + springbok::isa::name(springbok::isa::active()) + "\""),
            std::string::npos)
      << summary;
}

// The column of a log.csv named `name`, as text, one entry per row.
std::vector<std::string> column(const std::string& log, const std::string& name) {
  std::istringstream rows(log);
  std::string line;
  std::getline(rows, line);
  std::istringstream header(line);
  std::string cell;
  int index = -1;
  for (int i = 0; std::getline(header, cell, ','); ++i)
    if (cell == name) index = i;
  std::vector<std::string> out;
  if (index < 0) return out;
  while (std::getline(rows, line)) {
    std::istringstream cells(line);
    for (int i = 0; i <= index && std::getline(cells, cell, ','); ++i) {
    }
    out.push_back(cell);
  }
  return out;
}

// --lock-memory: the RT recipe's memory steps (mlockall, prefaulted heap and stack). Locked,
// no tick takes a page fault (unlocked, the first WBC tick takes some); the run is the same
// but for its timing columns. Without the privilege: said on stderr, and the run goes on.
TEST(SimCli, LockedMemoryTakesNoPageFaultsAndChangesNothingElse) {
  const fs::path dir = scratch("lock");
  const CliResult plain = run(kScenarios + "base_step_mb92.yaml", dir / "plain");
  ASSERT_EQ(plain.exit_code, 0) << plain.err;
  const CliResult locked = run(kScenarios + "base_step_mb92.yaml", dir / "locked", "--lock-memory");
  ASSERT_EQ(locked.exit_code, 0) << locked.err;
  EXPECT_NE(slurp(dir / "plain" / "summary.json").find("\"memory_locked\": null"), std::string::npos);
  const std::string summary = slurp(dir / "locked" / "summary.json");
  const std::string log = slurp(dir / "locked" / "log.csv"), plain_log = slurp(dir / "plain" / "log.csv");
  for (const char* name : {"time_s", "base_x_m", "tau_lf_kfe_joint", "tau_arm_joint_2", "qp_iterations", "qp_from_hint"})
    EXPECT_EQ(column(log, name), column(plain_log, name)) << name;
  // The log's per-tick hint flags add up to the summary's count; the first WBC tick is cold.
  const std::vector<std::string> from_hint = column(log, "qp_from_hint");
  ASSERT_GT(from_hint.size(), 7000u);
  EXPECT_EQ(from_hint.front(), "0");
  const auto hinted = std::count(from_hint.begin(), from_hint.end(), std::string("1"));
  EXPECT_GT(hinted, 0);
  EXPECT_NE(summary.find("\"qp_from_hint_ticks\": " + std::to_string(hinted) + ","), std::string::npos) << summary;
  if (summary.find("\"memory_locked\": true") != std::string::npos) {
    EXPECT_NE(locked.err.find("memory locked"), std::string::npos) << locked.err;
    const std::vector<std::string> faults = column(log, "tick_page_faults");
    ASSERT_GT(faults.size(), 7000u);
    int with_faults = 0;
    for (const std::string& f : faults) with_faults += !f.empty() && f != "0" ? 1 : 0;
    EXPECT_EQ(with_faults, 0);
  } else {
    EXPECT_NE(summary.find("\"memory_locked\": false"), std::string::npos) << summary;
    EXPECT_NE(locked.err.find("mlockall failed"), std::string::npos) << locked.err;
  }
}

TEST(SimCli, DropLandsAndRestsOnItsWeight) {
  const fs::path dir = scratch("drop");
  std::string summary;
  ASSERT_NO_FATAL_FAILURE(run_to_summary(kScenarios + "drop.yaml", dir / "out", summary));
  EXPECT_NEAR(json_number(summary, "contact_fz_over_weight"), 1.0, 0.01) << summary;
  // At rest: the base has not moved over the last 100 ms.
  const std::string log = slurp(dir / "out" / "log.csv");
  std::istringstream rows(log);
  std::string line, previous_100;
  std::vector<std::string> lines;
  while (std::getline(rows, line)) lines.push_back(line);
  ASSERT_GT(lines.size(), 200u);
  const auto z_of = [](const std::string& row) {
    std::istringstream cells(row);
    std::string cell;
    for (int i = 0; i < 4; ++i) std::getline(cells, cell, ',');
    return std::stod(cell);
  };
  EXPECT_NEAR(z_of(lines.back()), z_of(lines[lines.size() - 101]), 1e-4);
}

}  // namespace
