// Validated reading of YAML configuration, for start-up code only (it
// allocates and throws). Every error names the full dotted path of the field
// ("wbc.template.base.mass[1]") and what is wrong with it: unknown key,
// missing field, wrong type, out of range, not finite.
//
//   config::Fields f(root["wbc"], "wbc");
//   f.allow_only({"template", "weights"});
//   const double mu = f.number("friction_mu", 0.6, 0.0, 2.0);      // optional, default 0.6
//   const double k = f.required_number("stiffness", 1e-9, 1e6);     // must be there
//   config::Fields t = f.map("template");                          // a sub-map (may be absent)
#pragma once

#include <initializer_list>
#include <stdexcept>
#include <string>
#include <string_view>

#include <Eigen/Core>
#include <yaml-cpp/yaml.h>

namespace springbok::config {

struct ConfigError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

[[noreturn]] void fail(const std::string& field, const std::string& what);

// "a map", "a list", "empty", or the scalar quoted.
std::string describe(const YAML::Node& node);

// A finite number in [lo, hi] (YAML scalar); `field` names it in errors.
double as_number(const YAML::Node& node, const std::string& field, double lo, double hi);

// Loads a YAML file; errors name the file and the line.
YAML::Node load_file(const std::string& path);

class Fields {
 public:
  // `node` may be undefined or null (an absent section: every optional field takes its default).
  Fields(const YAML::Node& node, std::string path);

  const std::string& path() const noexcept { return path_; }
  std::string field(std::string_view key) const;
  bool has(std::string_view key) const;
  YAML::Node child(std::string_view key) const;

  // Unknown and duplicated keys are errors.
  void allow_only(std::initializer_list<std::string_view> keys) const;

  double number(std::string_view key, double fallback, double lo, double hi) const;
  double required_number(std::string_view key, double lo, double hi) const;
  int integer(std::string_view key, int fallback, int lo, int hi) const;
  bool boolean(std::string_view key, bool fallback) const;
  std::string text(std::string_view key, const std::string& fallback) const;
  std::string required_text(std::string_view key) const;
  Fields map(std::string_view key) const;
  Fields required_map(std::string_view key) const;

  // A vector of N numbers, each in [lo, hi]; a single number means all N equal.
  template <int N>
  Eigen::Matrix<double, N, 1> vector(std::string_view key, const Eigen::Matrix<double, N, 1>& fallback, double lo,
                                     double hi) const {
    if (!has(key)) return fallback;
    return read_vector<N>(key, lo, hi);
  }
  template <int N>
  Eigen::Matrix<double, N, 1> required_vector(std::string_view key, double lo, double hi) const {
    if (!has(key)) fail(field(key), "missing");
    return read_vector<N>(key, lo, hi);
  }

 private:
  template <int N>
  Eigen::Matrix<double, N, 1> read_vector(std::string_view key, double lo, double hi) const {
    const YAML::Node n = child(key);
    Eigen::Matrix<double, N, 1> v;
    if (n.IsScalar()) {
      v.setConstant(as_number(n, field(key), lo, hi));
      return v;
    }
    if (!n.IsSequence() || static_cast<int>(n.size()) != N) {
      fail(field(key), "must be a number or a list of " + std::to_string(N) + " numbers, got " + describe(n));
    }
    for (int i = 0; i < N; ++i) v[i] = as_number(n[i], field(key) + "[" + std::to_string(i) + "]", lo, hi);
    return v;
  }

  YAML::Node node_;
  std::string path_;
};

}  // namespace springbok::config
