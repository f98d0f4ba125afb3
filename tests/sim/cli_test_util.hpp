// Running springbok-sim from a test: a scratch directory, the exit code and stderr, summary fields.
#pragma once
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "sim_scenario_text.hpp"

namespace springbok::test {
namespace fs = std::filesystem;

inline const std::string kBin = std::string(SPRINGBOK_BIN_DIR) + "/springbok-sim";
inline const std::string kScenarios = std::string(SPRINGBOK_SOURCE_DIR) + "/tools/scenarios/";

// Where this test process writes its runs (scratch()).
inline fs::path scratch_root() { return fs::temp_directory_path() / ("springbok_sim_cli_" + std::to_string(getpid())); }

// After the last test of the process: its runs (logs of tens of MB) are removed when every test
// passed, and kept for a look when one failed.
class ScratchCleanup : public ::testing::Environment {
 public:
  void TearDown() override {
    if (::testing::UnitTest::GetInstance()->Failed()) {
      std::fprintf(stderr, "the runs are kept in %s\n", scratch_root().c_str());
      return;
    }
    std::error_code ec;
    fs::remove_all(scratch_root(), ec);
  }
};
inline ::testing::Environment* const kScratchCleanup = ::testing::AddGlobalTestEnvironment(new ScratchCleanup);

inline fs::path scratch(const std::string& name) {
  const fs::path dir = scratch_root() / name;
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir;
}

inline std::string slurp(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

struct CliResult {
  int exit_code = -1;
  std::string err;
};

inline CliResult run(const std::string& scenario, const fs::path& out, const std::string& extra_args = "") {
  const fs::path err = out.parent_path() / (out.filename().string() + ".stderr");
  const std::string cmd = "'" + kBin + "' '" + scenario + "' --out '" + out.string() + "' " + extra_args +
                          " >/dev/null 2>'" + err.string() + "'";
  const int status = std::system(cmd.c_str());
  return {WIFEXITED(status) ? WEXITSTATUS(status) : -1, slurp(err)};
}

// springbok-sim on `scenario` into `out`, which must exit 0 (a fatal failure showing its stderr
// otherwise); `json`: the run's summary.json.
inline void run_to_summary(const std::string& scenario, const fs::path& out, std::string& json) {
  const CliResult r = run(scenario, out);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  json = slurp(out / "summary.json");
}

inline double json_number(const std::string& json, const std::string& key) {
  const auto at = json.find("\"" + key + "\":");
  if (at == std::string::npos) return std::nan("");
  return std::strtod(json.c_str() + at + key.size() + 3, nullptr);
}

inline bool json_true(const std::string& json, const std::string& key) {
  return json.find("\"" + key + "\": true") != std::string::npos;
}

// A run's summary: the robot did not fall and every QP was solved.
inline void expect_upright_and_solved(const std::string& json) {
  EXPECT_FALSE(json_true(json, "fell")) << json;
  EXPECT_EQ(json_number(json, "qp_failures"), 0.0) << json;
}

// The number at `key` inside the JSON object member `object`.
inline double member(const std::string& json, const std::string& object, const std::string& key) {
  const auto at = json.find("\"" + object + "\":");
  return at == std::string::npos ? std::nan("") : json_number(json.substr(at), key);
}

// A column of springbok-sim's log.csv by its header's name (empty: no such column).
inline std::vector<double> log_column(const fs::path& log_csv, const std::string& name) {
  const std::string log = slurp(log_csv);
  const auto header_end = log.find('\n');
  std::vector<std::string> header;
  {
    std::stringstream h(log.substr(0, header_end));
    for (std::string c; std::getline(h, c, ',');) header.push_back(c);
  }
  const auto column = static_cast<std::size_t>(std::find(header.begin(), header.end(), name) - header.begin());
  std::vector<double> values;
  if (column >= header.size()) return values;
  std::stringstream rows(log.substr(header_end + 1));
  for (std::string row; std::getline(rows, row);) {
    std::stringstream cells(row);
    std::string cell;
    for (std::size_t i = 0; i <= column && std::getline(cells, cell, ','); ++i) {
    }
    values.push_back(std::strtod(cell.c_str(), nullptr));
  }
  return values;
}

}  // namespace springbok::test
