#include "springbok/config/fields.hpp"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdlib>
#include <sstream>
#include <vector>

namespace springbok::config {

void fail(const std::string& field, const std::string& what) {
  throw ConfigError((field.empty() ? std::string("(top level)") : field) + ": " + what);
}

std::string describe(const YAML::Node& node) {
  if (!node.IsDefined()) return "nothing";
  switch (node.Type()) {
    case YAML::NodeType::Map: return "a map";
    case YAML::NodeType::Sequence: return "a list";
    case YAML::NodeType::Null: return "empty";
    default: return "'" + node.Scalar() + "'";
  }
}

namespace {
std::string show(double v) {
  std::ostringstream s;
  s << v;
  return s.str();
}
}  // namespace

double as_number(const YAML::Node& node, const std::string& field, double lo, double hi) {
  if (!node.IsScalar()) fail(field, "must be a number, got " + describe(node));
  const std::string& s = node.Scalar();
  std::string lower(s);
  std::transform(lower.begin(), lower.end(), lower.begin(), [](unsigned char c) { return std::tolower(c); });
  if (lower.find("nan") != std::string::npos || lower.find("inf") != std::string::npos) {
    fail(field, "must be a finite number, got '" + s + "'");
  }
  char* end = nullptr;
  const double v = std::strtod(s.c_str(), &end);
  if (s.empty() || end != s.c_str() + s.size()) fail(field, "must be a number, got '" + s + "'");
  if (!std::isfinite(v)) fail(field, "must be a finite number, got '" + s + "'");
  if (v < lo || v > hi) fail(field, "must be in [" + show(lo) + ", " + show(hi) + "], got " + s);
  return v;
}

YAML::Node load_file(const std::string& path) {
  try {
    return YAML::LoadFile(path);
  } catch (const YAML::BadFile&) {
    throw ConfigError(path + ": cannot read the file");
  } catch (const YAML::Exception& e) {
    throw ConfigError(path + ": line " + std::to_string(e.mark.line + 1) + ": " + e.msg);
  }
}

Fields::Fields(const YAML::Node& node, std::string path) : node_(node), path_(std::move(path)) {
  if (node_.IsDefined() && !node_.IsNull() && !node_.IsMap()) fail(path_, "must be a map, got " + describe(node_));
}

std::string Fields::field(std::string_view key) const {
  return path_.empty() ? std::string(key) : path_ + "." + std::string(key);
}

bool Fields::has(std::string_view key) const { return child(key).IsDefined(); }

YAML::Node Fields::child(std::string_view key) const {
  if (!node_.IsMap()) return YAML::Node(YAML::NodeType::Undefined);
  const YAML::Node n = node_[std::string(key)];  // a missing key gives an invalid node: never keep it
  return n.IsDefined() ? n : YAML::Node(YAML::NodeType::Undefined);
}

void Fields::allow_only(std::initializer_list<std::string_view> keys) const {
  if (!node_.IsMap()) return;
  std::vector<std::string> seen;
  for (const auto& item : node_) {
    const std::string key = item.first.Scalar();
    if (std::find(seen.begin(), seen.end(), key) != seen.end()) fail(field(key), "duplicate key");
    seen.push_back(key);
    if (std::find(keys.begin(), keys.end(), key) == keys.end()) {
      std::string known;
      for (const auto k : keys) known += (known.empty() ? "" : ", ") + std::string(k);
      fail(field(key), "unknown key (known: " + known + ")");
    }
  }
}

double Fields::number(std::string_view key, double fallback, double lo, double hi) const {
  return has(key) ? as_number(child(key), field(key), lo, hi) : fallback;
}

double Fields::required_number(std::string_view key, double lo, double hi) const {
  if (!has(key)) fail(field(key), "missing");
  return as_number(child(key), field(key), lo, hi);
}

int Fields::integer(std::string_view key, int fallback, int lo, int hi) const {
  if (!has(key)) return fallback;
  const double v = as_number(child(key), field(key), lo, hi);
  if (v != std::floor(v)) fail(field(key), "must be an integer, got " + describe(child(key)));
  return static_cast<int>(v);
}

bool Fields::boolean(std::string_view key, bool fallback) const {
  if (!has(key)) return fallback;
  const YAML::Node n = child(key);
  if (n.IsScalar() && n.Scalar() == "true") return true;
  if (n.IsScalar() && n.Scalar() == "false") return false;
  fail(field(key), "must be true or false, got " + describe(n));
}

std::string Fields::text(std::string_view key, const std::string& fallback) const {
  if (!has(key)) return fallback;
  const YAML::Node n = child(key);
  if (!n.IsScalar() || n.Scalar().empty()) fail(field(key), "must be a non-empty string, got " + describe(n));
  return n.Scalar();
}

std::string Fields::required_text(std::string_view key) const {
  if (!has(key)) fail(field(key), "missing");
  return text(key, "");
}

Fields Fields::map(std::string_view key) const { return Fields(child(key), field(key)); }

Fields Fields::required_map(std::string_view key) const {
  if (!has(key)) fail(field(key), "missing");
  return map(key);
}

}  // namespace springbok::config
