#include "springbok/yaml/reader.hpp"

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <sstream>

namespace springbok::yaml {

void Errors::add(const std::string& path, int line, const std::string& what) {
  std::string s = (path.empty() ? std::string("(top level)") : path) + ": " + what;
  if (line > 0) s += " (line " + std::to_string(line) + ")";
  add_line(std::move(s));
}

void Errors::add_line(std::string line) {
  // A field read more than once (e.g. can.mit_ranges, applied to every MIT drive) fails the
  // same way each time: said once.
  if (std::find(lines_.begin(), lines_.end(), line) == lines_.end()) lines_.push_back(std::move(line));
}

std::string Errors::joined() const {
  std::string s;
  for (const std::string& l : lines_) s += (s.empty() ? "" : "\n") + l;
  return s;
}

std::string show(double v) {
  std::ostringstream s;
  s << v;
  return s.str();
}

Document parse_text(std::string_view text) {
  Document d;
  try {
    d.root = YAML::Load(std::string(text));
    d.ok = true;
  } catch (const YAML::Exception& e) {
    d.error = "YAML syntax: " + e.msg + " (line " + std::to_string(e.mark.line + 1) + ", column " +
              std::to_string(e.mark.column + 1) + ")";
  }
  return d;
}

Document parse_file(const std::string& path) {
  std::ifstream in(path);
  if (!in) {
    Document d;
    d.error = path + ": cannot open";
    return d;
  }
  std::stringstream text;
  text << in.rdbuf();
  Document d = parse_text(text.str());
  if (!d.ok) d.error = path + ": " + d.error;
  return d;
}

namespace {
int line_of(const YAML::Node& n, int fallback) {
  if (!n.IsDefined()) return fallback;
  const YAML::Mark m = n.Mark();
  return m.is_null() ? fallback : m.line + 1;
}
}  // namespace

Field::Field(const YAML::Node& node, std::string path, Errors& errors, int line_if_absent)
    : node_(node), path_(std::move(path)), errors_(&errors), line_(line_of(node, line_if_absent)) {}

std::string Field::describe() const {
  if (!node_.IsDefined()) return "nothing";
  switch (node_.Type()) {
    case YAML::NodeType::Map: return "a map";
    case YAML::NodeType::Sequence: return "a list";
    case YAML::NodeType::Null: return "empty";
    default: return "'" + node_.Scalar() + "'";
  }
}

void Field::fail(const std::string& what) const { errors_->add(path_, line_, what); }

bool Field::require() const {
  if (!present()) fail("missing");
  return present();
}

Field Field::operator[](std::string_view key) const {
  const std::string path = path_.empty() ? std::string(key) : path_ + "." + std::string(key);
  if (!node_.IsMap()) return Field(YAML::Node(YAML::NodeType::Undefined), path, *errors_, line_);
  const YAML::Node n = node_[std::string(key)];  // const: a missing key inserts nothing
  return Field(n.IsDefined() ? n : YAML::Node(YAML::NodeType::Undefined), path, *errors_, line_);
}

Field Field::operator[](std::size_t index) const {
  const std::string path = path_ + "[" + std::to_string(index) + "]";
  if (!node_.IsSequence() || index >= node_.size()) {
    return Field(YAML::Node(YAML::NodeType::Undefined), path, *errors_, line_);
  }
  return Field(node_[index], path, *errors_, line_);
}

std::vector<std::string> Field::keys() const {
  std::vector<std::string> out;
  if (!node_.IsMap()) return out;
  for (const auto& item : node_) out.push_back(item.first.IsScalar() ? item.first.Scalar() : std::string());
  return out;
}

bool Field::allow_only(std::span<const std::string_view> keys) const {
  if (!node_.IsDefined() || node_.IsNull()) return true;
  if (!node_.IsMap()) {
    fail("must be a map, got " + describe());
    return false;
  }
  std::vector<std::string> seen;
  for (const auto& item : node_) {
    const int line = line_of(item.first, line_);
    const std::string key = item.first.IsScalar() ? item.first.Scalar() : std::string();
    const std::string path = path_.empty() ? key : path_ + "." + key;
    if (!item.first.IsScalar()) {
      errors_->add(path_, line, "keys must be plain names");
      continue;
    }
    if (std::find(seen.begin(), seen.end(), key) != seen.end()) {
      errors_->add(path, line, "duplicate key");
      continue;
    }
    seen.push_back(key);
    if (std::find(keys.begin(), keys.end(), key) == keys.end()) {
      std::string known;
      for (const auto k : keys) known += (known.empty() ? "" : ", ") + std::string(k);
      errors_->add(path, line, "unknown key (known: " + known + ")");
    }
  }
  return true;
}

bool Field::expect_list(std::size_t n) const {
  if (!present()) return false;
  if (!is_list()) {
    fail(n > 0 ? "must be a list of " + std::to_string(n) + ", got " + describe() : "must be a list, got " + describe());
    return false;
  }
  if (n > 0 && node_.size() != n) {
    fail("must be a list of " + std::to_string(n) + ", got " + std::to_string(node_.size()) + " elements");
    return false;
  }
  return true;
}

bool Field::scalar(const char* expected) const {
  if (!present()) return false;
  if (!is_scalar()) {
    fail(std::string("must be ") + expected + ", got " + describe());
    return false;
  }
  return true;
}

bool Field::number(double& out, double lo, double hi) const {
  if (!scalar("a number")) return false;
  const std::string& s = node_.Scalar();
  std::string lower(s);
  std::transform(lower.begin(), lower.end(), lower.begin(), [](unsigned char c) { return std::tolower(c); });
  if (lower.find("nan") != std::string::npos || lower.find("inf") != std::string::npos) {
    fail("must be a finite number, got '" + s + "'");
    return false;
  }
  const char* first = s.data();
  if (!s.empty() && s.front() == '+') ++first;
  double v = 0.0;
  const auto [end, ec] = std::from_chars(first, s.data() + s.size(), v, std::chars_format::general);
  if (s.empty() || ec != std::errc{} || end != s.data() + s.size()) {
    fail("must be a number, got '" + s + "'");
    return false;
  }
  if (!std::isfinite(v)) {
    fail("must be a finite number, got '" + s + "'");
    return false;
  }
  if (v < lo || v > hi) {
    fail("must be in [" + show(lo) + ", " + show(hi) + "], got " + s);
    return false;
  }
  out = v;
  return true;
}

bool Field::integer_value(long long& out, long long lo, long long hi) const {
  if (!scalar("an integer")) return false;
  const std::string& s = node_.Scalar();
  std::string_view v = s;
  bool negative = false;
  if (!v.empty() && (v.front() == '-' || v.front() == '+')) {
    negative = v.front() == '-';
    v.remove_prefix(1);
  }
  int base = 10;
  if (v.size() > 2 && v[0] == '0' && (v[1] == 'x' || v[1] == 'X')) {
    base = 16;
    v.remove_prefix(2);
  }
  unsigned long long magnitude = 0;
  const auto [end, ec] = std::from_chars(v.data(), v.data() + v.size(), magnitude, base);
  if (v.empty() || ec != std::errc{} || end != v.data() + v.size() ||
      magnitude > static_cast<unsigned long long>(std::numeric_limits<long long>::max())) {
    fail("must be an integer (decimal or 0x hex), got '" + s + "'");
    return false;
  }
  const long long value = negative ? -static_cast<long long>(magnitude) : static_cast<long long>(magnitude);
  if (value < lo || value > hi) {
    fail("must be in [" + std::to_string(lo) + ", " + std::to_string(hi) + "], got " + s);
    return false;
  }
  out = value;
  return true;
}

bool Field::boolean(bool& out) const {
  if (!scalar("true or false")) return false;
  const std::string& s = node_.Scalar();
  if (s == "true" || s == "false") {
    out = s == "true";
    return true;
  }
  fail("must be true or false, got '" + s + "'");
  return false;
}

bool Field::text(std::string& out) const {
  if (!scalar("a string")) return false;
  if (node_.Scalar().empty()) {
    fail("must be a non-empty string");
    return false;
  }
  out = node_.Scalar();
  return true;
}

bool Field::choice(int& out, std::initializer_list<std::string_view> choices) const {
  std::string s;
  if (!text(s)) return false;
  int i = 0;
  std::string names;
  for (const auto c : choices) {
    if (c == s) {
      out = i;
      return true;
    }
    names += (names.empty() ? "" : ", ") + std::string(c);
    ++i;
  }
  fail("must be one of " + names + ", got '" + s + "'");
  return false;
}

}  // namespace springbok::yaml
