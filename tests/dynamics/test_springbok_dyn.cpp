// Runs the springbok-dyn tool: on a reference state (its output must match every
// block of the file) and on broken files (each class of error: message naming
// the line, non-zero exit, no output file).
#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include "reference_states.hpp"
#include "run_command.hpp"
#include "springbok/model/model.hpp"

namespace {
namespace fs = std::filesystem;
using springbok::test::block_error;
using springbok::test::kReferenceTolerance;
using springbok::test::to_matrix;

springbok::test::CommandRun run_tool(const std::string& in, const std::string& out) {
  return springbok::test::run_program("", "springbok-dyn", "'" + in + "' '" + out + "'");
}

std::string slurp(const std::string& path) {
  std::ifstream in(path);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

class SpringbokDyn : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("springbok_dyn_test_" + std::to_string(::getpid()));
    fs::create_directories(dir_);
    const auto files = springbok::test::reference_state_files(springbok::robot::kRobotName);
    ASSERT_FALSE(files.empty());
    reference_ = files.front();
  }
  void TearDown() override { fs::remove_all(dir_); }

  // Writes `text` as a broken input, runs the tool, expects failure naming `line`.
  void expect_rejected(const std::string& text, const std::string& needle) {
    const std::string in = (dir_ / "broken.txt").string(), out = (dir_ / "out.txt").string();
    std::ofstream(in) << text;
    const springbok::test::CommandRun r = run_tool(in, out);
    EXPECT_NE(r.exit_code, 0) << r.out;
    EXPECT_NE(r.out.find(needle), std::string::npos) << "message: " << r.out << "expected: " << needle;
    EXPECT_FALSE(fs::exists(out));
    for (const auto& e : fs::directory_iterator(dir_))  // no temporary left behind
      EXPECT_EQ(e.path().filename().string().find("out.txt.tmp"), std::string::npos) << e.path();
  }

  // The reference text with line `line_no` (1-based) replaced.
  std::string with_line(int line_no, const std::string& replacement) const {
    std::istringstream in(slurp(reference_));
    std::string line, text;
    for (int n = 1; std::getline(in, line); ++n) text += (n == line_no ? replacement : line) + "\n";
    return text;
  }
  std::string line_of_reference(int line_no) const {
    std::istringstream in(slurp(reference_));
    std::string line;
    for (int n = 1; std::getline(in, line) && n < line_no; ++n) {
    }
    return line;
  }

  fs::path dir_;
  std::string reference_;
};

// The tool's output for `in` against the reference state, block by block: the computed ones
// within the reference tolerance; the inputs (q, v, vdot, tau_aba) copied exactly, unless
// `inputs_as_given` (then not compared: the input file differs from the reference).
void expect_reference_blocks(const std::string& in, const std::string& out, const std::string& reference,
                             bool inputs_as_given = false) {
  const springbok::test::CommandRun r = run_tool(in, out);
  ASSERT_EQ(r.exit_code, 0) << r.out;
  const auto mine = springbok::state_file::read(out);
  const auto ref = springbok::state_file::read(reference);
  ASSERT_EQ(mine.blocks.size(), ref.blocks.size());
  for (std::size_t k = 0; k < ref.blocks.size(); ++k) {
    const auto& a = mine.blocks[k];
    const auto& b = ref.blocks[k];
    ASSERT_EQ(a.name, b.name) << "block order";
    ASSERT_EQ(a.rows, b.rows) << a.name;
    ASSERT_EQ(a.cols, b.cols) << a.name;
    if (a.name == "q" || a.name == "v" || a.name == "vdot" || a.name == "tau_aba") {
      if (!inputs_as_given) {
        EXPECT_EQ(a.values, b.values) << a.name << " (inputs are copied exactly)";
      }
    } else {
      EXPECT_LE(block_error(a.name, to_matrix(a), to_matrix(b)), kReferenceTolerance) << a.name;
    }
  }
}

TEST_F(SpringbokDyn, ReproducesEveryBlockOfAReferenceState) {
  expect_reference_blocks(reference_, (dir_ / "out.txt").string(), reference_);
}

// Line numbers of state_*.txt: 1 comment, 2 "q 1 26", 3 q, 4 "v 1 25", 5 v,
// 6 "vdot 1 25", 7 vdot, 10 "M 25 25".
TEST_F(SpringbokDyn, RejectsMissingBlock) {
  std::string text = with_line(6, "# vdot removed");
  text = [&] {
    std::istringstream in(text);
    std::string line, t;
    for (int n = 1; std::getline(in, line); ++n) t += (n == 7 ? "# row removed" : line) + "\n";
    return t;
  }();
  expect_rejected(text, "missing block 'vdot'");
}

TEST_F(SpringbokDyn, RejectsWrongShape) {
  expect_rejected(with_line(4, "v 1 24"), ":5: block 'v' row 1 has 25 numbers, expected 24");
  std::string row = line_of_reference(5);
  row = row.substr(0, row.rfind(' '));  // drop the last number: consistent 1x24 block
  std::string text = with_line(4, "v 1 24");
  text = [&] {
    std::istringstream in(text);
    std::string line, t;
    for (int n = 1; std::getline(in, line); ++n) t += (n == 5 ? row : line) + "\n";
    return t;
  }();
  expect_rejected(text, ":4: block 'v' is 1x24, expected 1x25");
  expect_rejected(with_line(2, "q 1 x"), ":2: expected a block header");
}

TEST_F(SpringbokDyn, RejectsBadAndNonFiniteNumbers) {
  const std::string vdot = line_of_reference(7);
  const std::string rest = vdot.substr(vdot.find(' '));
  expect_rejected(with_line(7, "abc" + rest), ":7: number 1 'abc' is not a number");
  expect_rejected(with_line(7, "nan" + rest), ":7: number 1 'nan' is not finite");
  expect_rejected(with_line(7, "inf" + rest), ":7: number 1 'inf' is not finite");
  expect_rejected(with_line(7, "1e999" + rest), ":7: number 1 '1e999' is out of range");
  expect_rejected(with_line(7, "0.5x" + rest), ":7: number 1 '0.5x' is not a number");
}

// CONVENTIONS.md: R_WB from the quaternion, "normalise first". A quaternion of norm 1.01 is
// the same state: every computed block as the reference's (q is echoed as given); a zero one
// has no orientation and is rejected.
TEST_F(SpringbokDyn, NormalisesTheBaseQuaternionAndRejectsAZeroOne) {
  const auto scaled_row = [&](double factor) {
    std::istringstream in(line_of_reference(3));
    std::string row;
    for (int k = 0; k < 26; ++k) {
      double x;
      in >> x;
      if (k >= 3 && k < 7) x *= factor;
      char buf[40];
      std::snprintf(buf, sizeof buf, "%.17g", x);
      row += (k ? " " : "") + std::string(buf);
    }
    return row;
  };
  const fs::path in = dir_ / "scaled.txt";
  std::ofstream(in) << with_line(3, scaled_row(1.01));
  const std::string out = (dir_ / "out.txt").string();
  expect_reference_blocks(in.string(), out, reference_, true);
  fs::remove(out);
  expect_rejected(with_line(3, scaled_row(0.0)), ":3: base quaternion q[3..6] has norm 0.000000: no orientation");
}

TEST_F(SpringbokDyn, RejectsTruncatedAndMissingFiles) {
  std::istringstream in(slurp(reference_));
  std::string line, text;
  for (int n = 1; std::getline(in, line) && n <= 20; ++n) text += line + "\n";
  expect_rejected(text, ":20: end of file inside block 'M' (declared at line 10)");
  const springbok::test::CommandRun r = run_tool((dir_ / "does_not_exist.txt").string(), (dir_ / "out.txt").string());
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.out.find("cannot open"), std::string::npos) << r.out;
  EXPECT_FALSE(fs::exists(dir_ / "out.txt"));
}

}  // namespace
