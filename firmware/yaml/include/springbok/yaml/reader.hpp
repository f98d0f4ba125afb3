// The one reader of springbok's YAML inputs: the robot config (springbok.yaml: the app's
// sections, `can:`, the controller's parameters), scenarios and fault scripts. Start-up code
// only: it allocates. It never throws for a bad value: every problem is collected, one line
// each, "<field path>: <what> (line N)", and the caller refuses the whole input.
//
// One set of rules everywhere:
//   map        unknown and duplicated keys are errors (allow_only); an empty section
//              (`wbc:` with nothing) is a map with every default
//   number     decimal, as strtod reads it but without nan, inf and hex floats; finite; in [lo, hi]
//   integer    decimal or 0x hexadecimal, an optional sign; no fraction ("2.0" is not one); in [lo, hi]
//   boolean    true or false (not yes/no/on/off)
//   text       a non-empty scalar
//   absent     an optional field keeps the caller's value (the default lives in the struct);
//              require() makes it an error ("missing")
//
//   yaml::Errors errors;
//   const yaml::Field root(document, "", errors);
//   const yaml::Field loop = root["loop"];
//   loop.allow_only({"rate_hz", "warmup_ticks"});
//   loop["rate_hz"].integer(c.rate_hz, 100, 4000);     // absent: c.rate_hz unchanged
//   if (root["can"].require()) read_can(root["can"], errors);
//   if (!errors.empty()) refuse(errors.lines());
#pragma once

#include <cstddef>
#include <cstdint>
#include <initializer_list>
#include <span>
#include <string>
#include <string_view>
#include <type_traits>
#include <vector>

#include <Eigen/Core>
#include <yaml-cpp/yaml.h>

namespace springbok::yaml {

class Errors {
 public:
  // "<path>: <what> (line N)"; `line` 0 = unknown (an input that is not a parsed file).
  void add(const std::string& path, int line, const std::string& what);
  // A line already collected is not added again (one field read twice fails once).
  void add_line(std::string line);
  bool empty() const noexcept { return lines_.empty(); }
  std::size_t size() const noexcept { return lines_.size(); }
  const std::vector<std::string>& lines() const noexcept { return lines_; }
  // Every line, joined by "\n".
  std::string joined() const;

 private:
  std::vector<std::string> lines_;
};

// A YAML document from text or a file, or the error (YAML syntax with its line, an unreadable file).
struct Document {
  bool ok = false;
  YAML::Node root;
  std::string error;
};
Document parse_text(std::string_view text);
Document parse_file(const std::string& path);  // errors start with the path

// A node of the document with its dotted path ("control.wbc.template.base.mass[1]").
class Field {
 public:
  // `node` may be undefined (an absent field).
  Field(const YAML::Node& node, std::string path, Errors& errors, int line_if_absent = 0);

  const std::string& path() const noexcept { return path_; }
  int line() const noexcept { return line_; }
  Errors& errors() const noexcept { return *errors_; }
  const YAML::Node& node() const noexcept { return node_; }

  bool present() const noexcept { return node_.IsDefined(); }
  bool is_map() const noexcept { return node_.IsMap(); }
  bool is_list() const noexcept { return node_.IsSequence(); }
  bool is_scalar() const noexcept { return node_.IsScalar(); }
  // "a map", "a list", "empty", "nothing" or the scalar quoted.
  std::string describe() const;

  // An error at this field.
  void fail(const std::string& what) const;
  // An error if absent; returns present().
  bool require() const;

  // A key of this map (absent when this is not a map or has no such key).
  Field operator[](std::string_view key) const;
  // An element of this list.
  Field operator[](std::size_t index) const;
  // The list's length (0 when not a list).
  std::size_t size() const noexcept { return node_.IsSequence() ? node_.size() : 0; }
  // The keys of this map, in order.
  std::vector<std::string> keys() const;

  // This must be a map (empty and absent count as one with every default): else an error.
  // Unknown and duplicated keys are errors. Returns false when this is not a map.
  bool allow_only(std::initializer_list<std::string_view> keys) const {
    return allow_only(std::span<const std::string_view>(keys.begin(), keys.size()));
  }
  bool allow_only(std::span<const std::string_view> keys) const;
  // This must be a list (of `n` elements when n > 0): else an error and false. Absent: false.
  bool expect_list(std::size_t n = 0) const;

  // Reading this field: true and `out` set when present and valid; false with `out`
  // unchanged when absent (no error) or invalid (an error).
  bool number(double& out, double lo, double hi) const;
  template <class Int>
  bool integer(Int& out, long long lo, long long hi) const {
    static_assert(std::is_integral_v<Int> && !std::is_same_v<Int, bool>);
    long long v = 0;
    if (!integer_value(v, lo, hi)) return false;
    out = static_cast<Int>(v);
    return true;
  }
  bool boolean(bool& out) const;
  bool text(std::string& out) const;
  // One of `choices` (its index), else an error naming them.
  bool choice(int& out, std::initializer_list<std::string_view> choices) const;
  // N numbers in [lo, hi]; with `scalar_fills`, a single number means all N equal.
  template <int N>
  bool vector(Eigen::Matrix<double, N, 1>& out, double lo, double hi, bool scalar_fills = false) const {
    if (!present()) return false;
    Eigen::Matrix<double, N, 1> v;
    if (scalar_fills && is_scalar()) {
      if (!number(v[0], lo, hi)) return false;
      out.setConstant(v[0]);
      return true;
    }
    if (!expect_list(static_cast<std::size_t>(N))) return false;
    bool ok = true;
    for (int i = 0; i < N; ++i) ok = (*this)[static_cast<std::size_t>(i)].number(v[i], lo, hi) && ok;
    if (ok) out = v;
    return ok;
  }

 private:
  bool integer_value(long long& out, long long lo, long long hi) const;
  bool scalar(const char* expected) const;

  YAML::Node node_;
  std::string path_;
  Errors* errors_;
  int line_ = 0;
};

// "1.5" for 1.5: numbers in messages as the config would write them.
std::string show(double v);

}  // namespace springbok::yaml
