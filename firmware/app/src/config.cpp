#include "springbok/app/config.hpp"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <initializer_list>
#include <sstream>
#include <string_view>

#include "springbok/config/fields.hpp"
#include "springbok/wbc/wbc_config.hpp"

namespace springbok::app {
namespace {

std::string join(const std::string& path, const std::string& key) { return path.empty() ? key : path + "." + key; }

const char* kind(const YAML::Node& n) {
  if (n.IsMap()) return "a map";
  if (n.IsSequence()) return "a list";
  if (n.IsNull()) return "nothing";
  return "a scalar";
}

template <class T>
std::string show(T v) {
  std::ostringstream s;
  s << v;
  return s.str();
}

// Reads typed, range-checked fields; each problem becomes one error line.
class Reader {
 public:
  explicit Reader(std::vector<std::string>& errors) : errors_(errors) {}

  void fail(const std::string& field, const std::string& what) { errors_.push_back(field + ": " + what); }
  // An error already in "field: what" form (springbok::config readers).
  void fail(const std::string& line) { errors_.push_back(line); }

  // Unknown keys of a map are errors; returns false when `map` is not a map.
  bool map(const YAML::Node& node, const std::string& path, std::initializer_list<std::string_view> known) {
    if (!node.IsMap()) {
      fail(path.empty() ? "(top level)" : path, std::string("wrong type: expected a map, got ") + kind(node));
      return false;
    }
    for (const auto& item : node) {
      const std::string key = item.first.Scalar();
      if (std::find(known.begin(), known.end(), key) == known.end()) fail(join(path, key), "unknown key");
    }
    return true;
  }

  // The child `key` of a map, or an invalid node and an error when missing.
  YAML::Node child(const YAML::Node& map, const std::string& path, const std::string& key) {
    YAML::Node n = map[key];
    if (!n.IsDefined()) fail(join(path, key), "missing");
    return n;
  }

  bool scalar(const YAML::Node& n, const std::string& field, const char* expected) {
    if (!n.IsDefined()) return false;
    if (!n.IsScalar()) {
      fail(field, std::string("wrong type: expected ") + expected + ", got " + kind(n));
      return false;
    }
    return true;
  }

  void integer(const YAML::Node& map, const std::string& path, const std::string& key, long lo, long hi, int& out) {
    const std::string field = join(path, key);
    const YAML::Node n = child(map, path, key);
    if (!scalar(n, field, "an integer")) return;
    const std::string& s = n.Scalar();
    long v = 0;
    const auto [end, ec] = std::from_chars(s.data(), s.data() + s.size(), v);
    if (ec != std::errc() || end != s.data() + s.size()) {
      fail(field, "wrong type: expected an integer, got '" + s + "'");
    } else if (v < lo || v > hi) {
      fail(field, "out of range [" + show(lo) + ", " + show(hi) + "]: " + s);
    } else {
      out = static_cast<int>(v);
    }
  }

  void number(const YAML::Node& n, const std::string& field, double lo, double hi, double& out) {
    if (!scalar(n, field, "a number")) return;
    const std::string& s = n.Scalar();
    std::string lower(s);
    std::transform(lower.begin(), lower.end(), lower.begin(), [](unsigned char c) { return std::tolower(c); });
    if (lower.find("nan") != std::string::npos || lower.find("inf") != std::string::npos) {
      fail(field, "not a finite number: " + s);
      return;
    }
    char* end = nullptr;
    const double v = std::strtod(s.c_str(), &end);
    if (s.empty() || end != s.c_str() + s.size()) {
      fail(field, "wrong type: expected a number, got '" + s + "'");
    } else if (!std::isfinite(v)) {
      fail(field, "not a finite number: " + s);
    } else if (v < lo || v > hi) {
      fail(field, "out of range [" + show(lo) + ", " + show(hi) + "]: " + s);
    } else {
      out = v;
    }
  }

  void number(const YAML::Node& map, const std::string& path, const std::string& key, double lo, double hi,
              double& out) {
    number(child(map, path, key), join(path, key), lo, hi, out);
  }

  void boolean(const YAML::Node& map, const std::string& path, const std::string& key, bool& out) {
    const std::string field = join(path, key);
    const YAML::Node n = child(map, path, key);
    if (!scalar(n, field, "true or false")) return;
    const std::string& s = n.Scalar();
    if (s == "true") {
      out = true;
    } else if (s == "false") {
      out = false;
    } else {
      fail(field, "wrong type: expected true or false, got '" + s + "'");
    }
  }

  void text(const YAML::Node& map, const std::string& path, const std::string& key, std::string& out) {
    const std::string field = join(path, key);
    const YAML::Node n = child(map, path, key);
    if (!scalar(n, field, "a string")) return;
    if (n.Scalar().empty()) {
      fail(field, "empty");
    } else {
      out = n.Scalar();
    }
  }

  void joint_vector(const YAML::Node& map, const std::string& path, const std::string& key, double lo, double hi,
                    VecNj& out) {
    const std::string field = join(path, key);
    const YAML::Node n = child(map, path, key);
    if (!n.IsDefined()) return;
    if (!n.IsSequence()) {
      fail(field, std::string("wrong type: expected a list of ") + show(kNj) + " numbers, got " + kind(n));
      return;
    }
    if (n.size() != static_cast<std::size_t>(kNj)) {
      fail(field, "expected " + show(kNj) + " values (one per joint), got " + show(n.size()));
      return;
    }
    for (int j = 0; j < kNj; ++j) {
      number(n[static_cast<std::size_t>(j)], field + "[" + show(j) + "]", lo, hi, out[j]);
    }
  }

  // {legs: x, arm: y} -> per joint
  void legs_arm(const YAML::Node& map, const std::string& path, const std::string& key, double lo, double hi,
                VecNj& out) {
    const std::string field = join(path, key);
    const YAML::Node n = child(map, path, key);
    if (!n.IsDefined() || !this->map(n, field, {"legs", "arm"})) return;
    double legs = 0, arm = 0;
    number(n, field, "legs", lo, hi, legs);
    number(n, field, "arm", lo, hi, arm);
    out.head<kFirstArmJoint>().setConstant(legs);
    out.tail<kArmJoints>().setConstant(arm);
  }

  void gains(const YAML::Node& map, const std::string& path, const std::string& key, JointGains& out) {
    const std::string field = join(path, key);
    const YAML::Node n = child(map, path, key);
    if (!n.IsDefined() || !this->map(n, field, {"kp_legs", "kd_legs", "kp_arm", "kd_arm"})) return;
    double kp_legs = 0, kd_legs = 0, kp_arm = 0, kd_arm = 0;
    number(n, field, "kp_legs", 0.0, 5000.0, kp_legs);
    number(n, field, "kd_legs", 0.0, 500.0, kd_legs);
    number(n, field, "kp_arm", 0.0, 1000.0, kp_arm);
    number(n, field, "kd_arm", 0.0, 100.0, kd_arm);
    out.kp_nm_per_rad.head<kFirstArmJoint>().setConstant(kp_legs);
    out.kd_nms_per_rad.head<kFirstArmJoint>().setConstant(kd_legs);
    out.kp_nm_per_rad.tail<kArmJoints>().setConstant(kp_arm);
    out.kd_nms_per_rad.tail<kArmJoints>().setConstant(kd_arm);
  }

 private:
  std::vector<std::string>& errors_;
};

void read_config(const YAML::Node& root, Reader& r, AppConfig& c) {
  if (!r.map(root, "", {"loop", "rt", "safety", "gains", "control", "operator", "log", "can"})) return;
  c.has_can_section = root["can"].IsDefined();

  if (const YAML::Node n = r.child(root, "", "loop"); n.IsDefined() && r.map(n, "loop", {"rate_hz", "warmup_ticks"})) {
    r.integer(n, "loop", "rate_hz", 100, 4000, c.rate_hz);
    r.integer(n, "loop", "warmup_ticks", 0, 100000, c.warmup_ticks);
  }
  if (const YAML::Node n = r.child(root, "", "rt");
      n.IsDefined() && r.map(n, "rt", {"enabled", "require", "priority", "cpu", "lock_memory", "prefault_heap_mib",
                                       "cpu_dma_latency"})) {
    r.boolean(n, "rt", "enabled", c.rt.enabled);
    r.boolean(n, "rt", "require", c.rt.require);
    r.integer(n, "rt", "priority", 1, 98, c.rt.priority);
    r.integer(n, "rt", "cpu", -1, 1023, c.rt.cpu);
    r.boolean(n, "rt", "lock_memory", c.rt.lock_memory);
    int heap_mib = 0;
    r.integer(n, "rt", "prefault_heap_mib", 0, 4096, heap_mib);
    c.rt.prefault_heap_bytes = static_cast<std::size_t>(heap_mib) << 20;
    r.boolean(n, "rt", "cpu_dma_latency", c.rt.hold_cpu_dma_latency);
  }
  if (const YAML::Node n = r.child(root, "", "safety");
      n.IsDefined() && r.map(n, "safety", {"overrun_streak", "overrun_rate_per_s", "hal_watchdog_ticks",
                                           "qp_failure_streak", "limit_margin_rad", "reset_max_speed_rad_s",
                                           "damping_nms_per_rad", "idle_damping_nms_per_rad"})) {
    int v = 0;
    r.integer(n, "safety", "overrun_streak", 1, 1000, v);
    c.safety.overrun_streak_limit = static_cast<std::uint32_t>(v);
    r.integer(n, "safety", "overrun_rate_per_s", 1, 4000, v);
    c.safety.overrun_rate_limit = static_cast<std::uint32_t>(v);
    r.integer(n, "safety", "hal_watchdog_ticks", 1, 1000, v);
    c.safety.hal_watchdog_ticks = static_cast<std::uint32_t>(v);
    r.integer(n, "safety", "qp_failure_streak", 1, 1000, v);
    c.safety.qp_failure_streak_limit = static_cast<std::uint32_t>(v);
    r.number(n, "safety", "limit_margin_rad", 0.0, 0.5, c.safety.limit_margin_rad);
    r.number(n, "safety", "reset_max_speed_rad_s", 0.0, 1.0, c.safety.reset_max_speed_rad_s);
    r.legs_arm(n, "safety", "damping_nms_per_rad", 0.0, 200.0, c.safety.damping_nms_per_rad);
    // D_start (CAN.md 4.2 step 5), > 0: without it the powered robot drops while idle.
    r.legs_arm(n, "safety", "idle_damping_nms_per_rad", 0.1, 200.0, c.safety.idle_damping_nms_per_rad);
  }
  if (const YAML::Node n = r.child(root, "", "gains");
      n.IsDefined() && r.map(n, "gains", {"stand", "control", "stand_up_duration_s", "stand_tolerance_rad",
                                          "stand_posture_rad"})) {
    r.gains(n, "gains", "stand", c.stand_gains);
    r.gains(n, "gains", "control", c.control_gains);
    r.number(n, "gains", "stand_up_duration_s", 0.1, 60.0, c.stand_up_duration_s);
    r.number(n, "gains", "stand_tolerance_rad", 0.001, 0.5, c.stand_tolerance_rad);
    r.joint_vector(n, "gains", "stand_posture_rad", -6.3, 6.3, c.stand_posture_rad);
    const safety::JointLimits limits = safety::joint_limits_from_model();
    for (int j = 0; j < kNj; ++j) {
      const double q = c.stand_posture_rad[j];
      if (limits.bounded[static_cast<std::size_t>(j)] && (q < limits.lower_rad[j] || q > limits.upper_rad[j])) {
        r.fail("gains.stand_posture_rad[" + show(j) + "]",
               "outside the joint limits of " + std::string(robot::kJoints[static_cast<std::size_t>(j)].name) +
                   " [" + show(limits.lower_rad[j]) + ", " + show(limits.upper_rad[j]) + "]: " + show(q));
      }
    }
  }
  if (const YAML::Node n = r.child(root, "", "control");
      n.IsDefined() && r.map(n, "control", {"controller", "wbc", "estimator", "gait"})) {
    std::string kind_name;
    r.text(n, "control", "controller", kind_name);
    if (kind_name == "wbc") {
      c.control_mode = ControlModeKind::wbc;
      c.safety.control_needs_imu = true;  // the estimator's orientation and rate
      c.safety.control_needs_wrist_ft = true;  // F_e, what the template renders
      if (!n["wbc"].IsDefined()) r.fail("control.wbc", "missing (control.controller is wbc)");
    } else if (kind_name == "joint_pd") {
      c.control_mode = ControlModeKind::joint_pd;
    } else if (!kind_name.empty()) {
      r.fail("control.controller", "expected wbc or joint_pd, got '" + kind_name + "'");
    }
    try {
      if (n["wbc"].IsDefined()) c.wbc = wbc::read_wbc_params(config::Fields(n["wbc"], "control.wbc"));
    } catch (const config::ConfigError& e) {
      r.fail(e.what());
    }
    try {  // optional: a missing map keeps every default (a const lookup of a missing key is not a node)
      if (n["estimator"].IsDefined()) {
        c.estimator = est::read_estimator_params(config::Fields(n["estimator"], "control.estimator"));
      }
    } catch (const config::ConfigError& e) {
      r.fail(e.what());
    }
    try {  // optional: the trot the control mode engages with (the scenario's gait: map); absent: stand
      if (n["gait"].IsDefined()) {
        c.gait.kind = control::GaitKind::trot;
        c.gait.trot = gait::read_trot_params(config::Fields(n["gait"], "control.gait"));
      }
    } catch (const config::ConfigError& e) {
      r.fail(e.what());
    }
  }
  if (const YAML::Node n = r.child(root, "", "operator"); n.IsDefined() && r.map(n, "operator", {"socket"})) {
    r.text(n, "operator", "socket", c.operator_socket);
  }
  if (const YAML::Node n = r.child(root, "", "log"); n.IsDefined() && r.map(n, "log", {"path"})) {
    r.text(n, "log", "path", c.log_path);
  }
}

}  // namespace

ConfigResult load_config_text(const std::string& yaml_text) {
  ConfigResult result;
  YAML::Node root;
  try {
    root = YAML::Load(yaml_text);
  } catch (const YAML::Exception& e) {
    result.errors.push_back("yaml: line " + show(e.mark.line + 1) + ", column " + show(e.mark.column + 1) + ": " +
                            e.msg);
    return result;
  }
  Reader reader(result.errors);
  try {
    read_config(root, reader, result.config);
  } catch (const YAML::Exception& e) {  // yaml-cpp on a malformed document
    result.errors.push_back(std::string("yaml: ") + e.what());
  }
  result.ok = result.errors.empty();
  return result;
}

ConfigResult load_config_file(const std::string& path) {
  std::ifstream in(path);
  if (!in) {
    ConfigResult result;
    result.errors.push_back(path + ": cannot open");
    return result;
  }
  std::stringstream text;
  text << in.rdbuf();
  ConfigResult result = load_config_text(text.str());
  for (auto& e : result.errors) e = path + ": " + e;
  return result;
}

}  // namespace springbok::app
