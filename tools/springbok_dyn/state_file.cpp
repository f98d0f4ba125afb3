#include "state_file.hpp"

#include <unistd.h>

#include <cctype>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <memory>
#include <sstream>

#include "springbok/dynamics/dynamics.hpp"

namespace springbok::state_file {
namespace {

// line 0: the whole file (e.g. a missing block).
[[noreturn]] void fail(const std::string& source, int line, const std::string& what) {
  throw StateFileError(source + (line > 0 ? ":" + std::to_string(line) : std::string()) + ": " + what);
}

std::vector<std::string> split(const std::string& line) {
  std::vector<std::string> tokens;
  std::istringstream in(line);
  for (std::string t; in >> t;) tokens.push_back(t);
  return tokens;
}

bool is_name(const std::string& s) {
  if (s.empty() || !(std::isalpha(static_cast<unsigned char>(s[0])) || s[0] == '_')) return false;
  for (char c : s)
    if (!(std::isalnum(static_cast<unsigned char>(c)) || c == '_')) return false;
  return true;
}

// A dimension 1..1000, or -1.
int parse_dimension(const std::string& s) {
  int value = 0;
  const auto [end, ec] = std::from_chars(s.data(), s.data() + s.size(), value);
  if (ec != std::errc() || end != s.data() + s.size() || value < 1 || value > 1000) return -1;
  return value;
}

double parse_number(const std::string& s, const std::string& source, int line, int column) {
  double value = 0.0;
  const char* first = s.data();
  if (!s.empty() && s[0] == '+') ++first;
  const auto [end, ec] = std::from_chars(first, s.data() + s.size(), value);
  const std::string where = "number " + std::to_string(column + 1) + " '" + s + "'";
  if (ec == std::errc::result_out_of_range) fail(source, line, where + " is out of range");
  if (ec != std::errc() || end != s.data() + s.size()) fail(source, line, where + " is not a number");
  if (!std::isfinite(value)) fail(source, line, where + " is not finite");
  return value;
}

void copy_row(const Block& b, Eigen::Ref<Eigen::VectorXd> out) {
  for (int k = 0; k < b.cols; ++k) out[k] = b.values[static_cast<std::size_t>(k)];
}

template <class Derived>
Block make_block(const std::string& name, const Eigen::MatrixBase<Derived>& m) {
  Block b{name, static_cast<int>(m.rows()), static_cast<int>(m.cols()), {}, 0};
  for (int r = 0; r < b.rows; ++r)
    for (int c = 0; c < b.cols; ++c) b.values.push_back(m(r, c));
  return b;
}

}  // namespace

const Block* StateFile::find(const std::string& name) const {
  for (const Block& b : blocks)
    if (b.name == name) return &b;
  return nullptr;
}

const Block& StateFile::require(const std::string& name, int rows, int cols) const {
  const Block* b = find(name);
  if (b == nullptr) fail(source, 0, "missing block '" + name + "'");
  if (b->rows != rows || b->cols != cols)
    fail(source, b->header_line,
         "block '" + name + "' is " + std::to_string(b->rows) + "x" + std::to_string(b->cols) +
             ", expected " + std::to_string(rows) + "x" + std::to_string(cols));
  return *b;
}

StateFile parse(const std::string& text, const std::string& source) {
  StateFile file{source, {}, {}};
  std::istringstream in(text);
  std::string line;
  int line_no = 0;
  Block* open = nullptr;  // block still expecting rows
  int rows_read = 0;
  while (std::getline(in, line)) {
    ++line_no;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    const auto tokens = split(line);
    if (tokens.empty() || tokens[0][0] == '#') continue;
    if (open == nullptr) {
      const int rows = tokens.size() == 3 ? parse_dimension(tokens[1]) : -1;
      const int cols = tokens.size() == 3 ? parse_dimension(tokens[2]) : -1;
      if (tokens.size() != 3 || !is_name(tokens[0]) || rows < 0 || cols < 0)
        fail(source, line_no, "expected a block header '<name> <rows> <cols>' (rows, cols in 1..1000), got '" + line + "'");
      if (file.find(tokens[0]) != nullptr) fail(source, line_no, "duplicate block '" + tokens[0] + "'");
      file.blocks.push_back(Block{tokens[0], rows, cols, {}, line_no});
      open = &file.blocks.back();
      rows_read = 0;
      continue;
    }
    if (static_cast<int>(tokens.size()) != open->cols)
      fail(source, line_no,
           "block '" + open->name + "' row " + std::to_string(rows_read + 1) + " has " +
               std::to_string(tokens.size()) + " numbers, expected " + std::to_string(open->cols));
    if (open->name == "joints") {  // format v2: the joints' names, in the order of q[7:] and v[6:]
      if (open->rows != 1) fail(source, open->header_line, "block 'joints' must have 1 row");
      file.joint_names = tokens;
      open = nullptr;
      continue;
    }
    for (int k = 0; k < open->cols; ++k)
      open->values.push_back(parse_number(tokens[static_cast<std::size_t>(k)], source, line_no, k));
    if (++rows_read == open->rows) open = nullptr;
  }
  if (open != nullptr)
    fail(source, line_no,
         "end of file inside block '" + open->name + "' (declared at line " +
             std::to_string(open->header_line) + "): " + std::to_string(rows_read) + " of " +
             std::to_string(open->rows) + " rows");
  return file;
}

StateFile read(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw StateFileError(path + ": cannot open for reading");
  std::ostringstream text;
  text << in.rdbuf();
  return parse(text.str(), path);
}

DynamicsInput dynamics_input(const StateFile& file) {
  // Format v2 names its joints: they must be this model's, in its order.
  if (const Block* names = file.find("joints")) {
    if (static_cast<int>(file.joint_names.size()) != kNj)
      fail(file.source, names->header_line,
           "the file has " + std::to_string(file.joint_names.size()) + " joints, the model " + std::to_string(kNj));
    for (int j = 0; j < kNj; ++j) {
      const std::string_view mine = robot::kJoints[static_cast<std::size_t>(j)].name;
      if (file.joint_names[static_cast<std::size_t>(j)] != mine)
        fail(file.source, names->header_line + 1,
             "joint " + std::to_string(j) + " is '" + file.joint_names[static_cast<std::size_t>(j)] + "', the model's '" +
                 std::string(mine) + "' (a file of another robot, or another order)");
    }
  }
  DynamicsInput in;
  const Block& q = file.require("q", 1, kNq);
  copy_row(q, in.q);
  copy_row(file.require("v", 1, kNv), in.v);
  copy_row(file.require("vdot", 1, kNv), in.vdot);
  copy_row(file.require("tau_aba", 1, kNv), in.tau_aba);
  const double norm = in.q.segment<4>(3).norm();
  if (!(norm >= kMinQuaternionNorm))
    fail(file.source, q.header_line + 1,
         "base quaternion q[3..6] has norm " + std::to_string(norm) + ": no orientation to normalise");
  return in;
}

std::vector<Block> compute_blocks(const DynamicsInput& in) {
  const dyn::Model model(Rotors::none);  // the reference states' robot: the URDF alone
  const auto data = std::make_unique<dyn::Data>();
  std::vector<Block> out;
  out.push_back(make_block("q", in.q.transpose()));
  out.push_back(make_block("v", in.v.transpose()));
  out.push_back(make_block("vdot", in.vdot.transpose()));
  out.push_back(make_block("tau", dyn::rnea(model, *data, in.q, in.v, in.vdot).transpose()));
  out.push_back(make_block("M", dyn::crba(model, *data, in.q)));
  out.push_back(make_block("h", dyn::nonlinear_effects(model, *data, in.q, in.v).transpose()));
  out.push_back(make_block("g", dyn::gravity(model, *data, in.q).transpose()));
  out.push_back(make_block("tau_aba", in.tau_aba.transpose()));
  out.push_back(make_block("vdot_aba", dyn::aba(model, *data, in.q, in.v, in.tau_aba).transpose()));
  dyn::point_jacobians(model, *data, in.q);
  dyn::point_jacobians_dot_times_v(model, *data, in.q, in.v);
  const char* feet[kFeet] = {"lf_foot", "rf_foot", "lh_foot", "rh_foot"};
  for (int f = 0; f < kFeet; ++f) {
    const std::string name = feet[f];
    out.push_back(make_block("p_" + name, data->frames[kFootFrames[f]].translation.transpose()));
    out.push_back(make_block("J_" + name, data->J_feet[f]));
    out.push_back(make_block("dJv_" + name, data->dJv_feet[f].transpose()));
  }
  out.push_back(make_block("p_ee", data->frames[kEeFrame].translation.transpose()));
  out.push_back(make_block("R_ee", data->frames[kEeFrame].rotation));
  out.push_back(make_block("J_ee", data->J_ee));
  out.push_back(make_block("dJv_ee", data->dJv_ee.transpose()));
  return out;
}

std::string format(const std::vector<Block>& blocks, const std::string& comment) {
  std::string text = "# " + comment + "\n";
  char number[40];
  for (const Block& b : blocks) {
    text += b.name + " " + std::to_string(b.rows) + " " + std::to_string(b.cols) + "\n";
    for (int r = 0; r < b.rows; ++r) {
      for (int c = 0; c < b.cols; ++c) {
        std::snprintf(number, sizeof number, "%.17g", b.values[static_cast<std::size_t>(r * b.cols + c)]);
        if (c > 0) text += ' ';
        text += number;
      }
      text += '\n';
    }
  }
  return text;
}

void write_atomically(const std::string& path, const std::string& text) {
  std::string tmp = path + ".tmp-XXXXXX";
  const int fd = ::mkstemp(tmp.data());
  if (fd < 0) throw StateFileError(path + ": cannot create a temporary file: " + std::strerror(errno));
  std::FILE* f = ::fdopen(fd, "w");
  if (f == nullptr) {
    ::close(fd);
    ::unlink(tmp.c_str());
    throw StateFileError(path + ": cannot open the temporary file");
  }
  const bool written = std::fwrite(text.data(), 1, text.size(), f) == text.size();
  const bool closed = std::fclose(f) == 0;
  if (!written || !closed || std::rename(tmp.c_str(), path.c_str()) != 0) {
    const std::string why = std::strerror(errno);
    ::unlink(tmp.c_str());
    throw StateFileError(path + ": cannot write: " + why);
  }
}

}  // namespace springbok::state_file
