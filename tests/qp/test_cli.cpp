// Runs the springbok-qp command line: good files give one line each in the
// documented format; a malformed file gets an error naming line and token and a
// non-zero exit status while the other files are still solved; --solution files
// parse back and hold the right x; --bench adds two timing fields.
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "qp_file.hpp"
#include "test_data.hpp"

namespace {

namespace fs = std::filesystem;

struct CliRun {
  int exit_code;
  std::vector<std::vector<std::string>> lines;  // stdout, split in fields
  std::string err;
};

std::string read_all(const fs::path& p) {
  std::ifstream f(p);
  return std::string(std::istreambuf_iterator<char>(f), {});
}

CliRun run_cli(const std::string& args, const fs::path& work) {
  const fs::path out = work / "stdout.txt", err = work / "stderr.txt";
  const std::string cmd = std::string(SPRINGBOK_BIN_DIR) + "/springbok-qp " + args + " >" + out.string() + " 2>" + err.string();
  const int status = std::system(cmd.c_str());
  CliRun r{WIFEXITED(status) ? WEXITSTATUS(status) : -1, {}, read_all(err)};
  std::istringstream lines(read_all(out));
  std::string line;
  while (std::getline(lines, line)) {
    std::istringstream words(line);
    std::vector<std::string> fields;
    std::string w;
    while (words >> w) fields.push_back(w);
    r.lines.push_back(fields);
  }
  return r;
}

class QpCli : public ::testing::Test {
 protected:
  fs::path work = fs::temp_directory_path() / ("springbok_qp_cli_" + std::to_string(::getpid()));
  std::string inst(const std::string& name) { return springbok::test::qp_instance(name); }
  void SetUp() override {
    fs::remove_all(work);
    fs::create_directories(work / "sol");
  }
  void TearDown() override { fs::remove_all(work); }
};

TEST_F(QpCli, SolvesWritesSolutionsAndReportsMalformedFiles) {
  // A malformed copy of a good file: one H entry replaced by a word.
  std::string text = read_all(inst("HS21.qp"));
  std::istringstream in(text);
  std::string line, broken;
  int line_no = 0, bad_line = 0;
  while (std::getline(in, line)) {
    ++line_no;
    if (bad_line == 0 && line.rfind("H", 0) == 0 && line.size() == 1) {  // the "H" keyword line; next line holds numbers
      broken += line + "\n";
      std::getline(in, line);
      ++line_no;
      bad_line = line_no;
      line = "1.0 bogus\n";
      broken += line;
      continue;
    }
    broken += line + "\n";
  }
  ASSERT_GT(bad_line, 0);
  std::ofstream(work / "broken.qp") << broken;

  const std::vector<std::string> good = {"HS21.qp", "wbc_trot_02.qp", "wbc_infeas_lb_gt_ub_0.qp", "patho_nan_H.qp",
                                         "CVXQP3_S_reg.qp"};
  const CliRun r = run_cli("--solution " + (work / "sol").string() + " " + inst(good[0]) + " " + inst(good[1]) + " " +
                            (work / "broken.qp").string() + " " + inst(good[2]) + " " + inst(good[3]) + " " +
                            inst(good[4]),
                        work);
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.err.find("broken.qp:" + std::to_string(bad_line) + ":"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("'bogus'"), std::string::npos) << r.err;
  ASSERT_EQ(r.lines.size(), 6u);
  const std::vector<std::string> names = {"HS21", "wbc_trot_02", "broken", "wbc_infeas_lb_gt_ub_0", "patho_nan_H",
                                          "CVXQP3_S_reg"};
  const std::vector<std::string> status = {"optimal", "optimal", "error", "infeasible", "error", "optimal"};
  for (std::size_t i = 0; i < names.size(); ++i) {
    ASSERT_EQ(r.lines[i].size(), 4u);
    EXPECT_EQ(r.lines[i][0], names[i]);
    EXPECT_EQ(r.lines[i][1], status[i]);
  }
  // Solution files parse back; x matches x*, objective on the line matches obj.
  for (const std::size_t i : {0u, 1u, 5u}) {
    std::string error;
    const auto q = springbok::qpfile::read_instance(inst(good[i < 2 ? i : 4]), error);
    ASSERT_TRUE(q.has_value()) << error;
    const auto sol = springbok::qpfile::read_solution((work / "sol" / (q->name + ".sol")).string(), q->n, q->meq, q->mi, error);
    ASSERT_TRUE(sol.has_value()) << error;
    EXPECT_EQ(sol->status, "optimal");
    double xs = 0.0;
    for (double v : q->xstar) xs = std::max(xs, std::abs(v));
    for (int k = 0; k < q->n; ++k)
      EXPECT_NEAR(sol->x[static_cast<std::size_t>(k)], q->xstar[static_cast<std::size_t>(k)], 1e-6 * std::max(1.0, xs));
    EXPECT_NEAR(std::stod(r.lines[i][2]), q->obj, 1e-6 * std::max(1.0, std::abs(q->obj)));
  }
  std::string error;
  const auto infeasible = springbok::qpfile::read_solution((work / "sol" / "wbc_infeas_lb_gt_ub_0.sol").string(), 0, 0, 0, error);
  ASSERT_TRUE(infeasible.has_value()) << error;
  EXPECT_EQ(infeasible->status, "infeasible");
  EXPECT_TRUE(infeasible->x.empty());
}

// Sizes come from the file: `dims` far beyond what its blocks hold is a parse error naming
// the block (before, H's n * n numbers were allocated first: std::bad_alloc ended the run
// and the files after it were never solved).
TEST_F(QpCli, HugeDimsAreAnErrorNotACrash) {
  std::string text = read_all(inst("HS21.qp"));
  const std::size_t at = text.find("dims ");
  ASSERT_NE(at, std::string::npos);
  text.replace(at, text.find('\n', at) - at, "dims 1000000 0 0");
  std::ofstream(work / "huge.qp") << text;
  const CliRun r = run_cli((work / "huge.qp").string() + " " + inst("HS21.qp"), work);
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.err.find("huge.qp:"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("dims ask for 1000000000000 numbers in H"), std::string::npos) << r.err;
  ASSERT_EQ(r.lines.size(), 2u);
  EXPECT_EQ(r.lines[0][1], "error");
  EXPECT_EQ(r.lines[1][0], "HS21");
  EXPECT_EQ(r.lines[1][1], "optimal");
}

TEST_F(QpCli, BenchAddsMedianAndP99) {
  std::string error;
  const auto q = springbok::qpfile::read_instance(inst("wbc_stance4_19.qp"), error);
  ASSERT_TRUE(q.has_value()) << error;
  for (const std::string flags : {"--bench 5", "--bench 5 --warm", "--bench 5 --warm-factor"}) {
    const CliRun r = run_cli(flags + " " + inst("wbc_stance4_19.qp"), work);
    EXPECT_EQ(r.exit_code, 0) << r.err;
    ASSERT_EQ(r.lines.size(), 1u);
    ASSERT_EQ(r.lines[0].size(), 6u);
    EXPECT_EQ(r.lines[0][1], "optimal");
    // The line reports the last timed solve: warm and reused-factor ones solve it too.
    EXPECT_NEAR(std::stod(r.lines[0][2]), q->obj, 1e-6 * std::max(1.0, std::abs(q->obj))) << flags;
    const double median = std::stod(r.lines[0][4]), p99 = std::stod(r.lines[0][5]);
    EXPECT_GT(median, 0.0);
    EXPECT_GE(p99, median);
    // The run's summary on stderr: one instance, so its median is the median of medians.
    const std::size_t at = r.err.find("summary: 1 instances x 5 solves");
    ASSERT_NE(at, std::string::npos) << r.err;
    double summary_median = 0.0, summary_p99 = 0.0, llt_median = 0.0, llt_p99 = 0.0;
    ASSERT_EQ(std::sscanf(r.err.c_str() + r.err.find("median of medians", at),
                          "median of medians %lf us, pooled p99 %lf us; eigen LLT+L^-1 same run: median of medians %lf "
                          "us, pooled p99 %lf us",
                          &summary_median, &summary_p99, &llt_median, &llt_p99),
              4)
        << r.err;
    EXPECT_NEAR(summary_median, median, 1e-3);
    EXPECT_NEAR(summary_p99, p99, 1e-3);
    EXPECT_GT(llt_median, 0.0);
    EXPECT_GE(llt_p99, llt_median);
  }
}

// --warm hints the previous solve's active set only when that solve was optimal, as the
// WBC does: an infeasible instance is then timed cold each time (its iterations those of
// a cold solve), not from an empty hinted set (whose repairs and the full method after
// them took wbc_sat_torque_03 42 iterations against a cold start's 34).
TEST_F(QpCli, WarmBenchStartsColdAfterANonOptimalSolve) {
  const CliRun cold = run_cli("--bench 3 " + inst("wbc_sat_torque_03.qp"), work);
  ASSERT_EQ(cold.exit_code, 0) << cold.err;
  ASSERT_EQ(cold.lines.size(), 1u);
  ASSERT_EQ(cold.lines[0].size(), 6u);
  EXPECT_EQ(cold.lines[0][1], "infeasible");
  EXPECT_GT(std::stoi(cold.lines[0][3]), 0);
  for (const std::string flags : {"--bench 3 --warm", "--bench 3 --warm-factor"}) {
    const CliRun warm = run_cli(flags + " " + inst("wbc_sat_torque_03.qp"), work);
    ASSERT_EQ(warm.exit_code, 0) << warm.err;
    ASSERT_EQ(warm.lines.size(), 1u);
    ASSERT_EQ(warm.lines[0].size(), 6u);
    EXPECT_EQ(warm.lines[0][1], "infeasible") << flags;
    EXPECT_EQ(warm.lines[0][3], cold.lines[0][3]) << flags;  // the same iterations: no hinted set
  }
}

TEST_F(QpCli, BadArgumentsAreRejected) {
  EXPECT_EQ(run_cli("", work).exit_code, 2);
  EXPECT_EQ(run_cli("--bench zero " + inst("HS21.qp"), work).exit_code, 2);
  EXPECT_EQ(run_cli("--frobnicate " + inst("HS21.qp"), work).exit_code, 2);
  const CliRun missing = run_cli((work / "does_not_exist.qp").string(), work);
  EXPECT_NE(missing.exit_code, 0);
  EXPECT_NE(missing.err.find("cannot open"), std::string::npos);
}

}  // namespace
