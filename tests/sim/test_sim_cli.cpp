// springbok-sim on the shipped scenarios: stand holds, the drop rests with the
// contact forces carrying the weight, and two runs are byte-identical.
#include <gtest/gtest.h>

#include "cli_test_util.hpp"

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
}

TEST(SimCli, DropLandsAndRestsOnItsWeight) {
  const fs::path dir = scratch("drop");
  const CliResult r = run(kScenarios + "drop.yaml", dir / "out");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const std::string summary = slurp(dir / "out" / "summary.json");
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
