#include <charconv>
#include <fstream>
#include <sstream>

#include <yaml-cpp/yaml.h>

#include "springbok/drive_emulator/drives.hpp"

namespace springbok::emu {

namespace {

bool parse_uint(const YAML::Node& n, std::uint64_t& out) {
  if (!n.IsScalar()) return false;
  std::string_view s = n.Scalar();
  int base = 10;
  if (s.size() > 2 && s[0] == '0' && (s[1] == 'x' || s[1] == 'X')) {
    base = 16;
    s.remove_prefix(2);
  }
  const auto [end, ec] = std::from_chars(s.data(), s.data() + s.size(), out, base);
  return !s.empty() && ec == std::errc{} && end == s.data() + s.size();
}

}  // namespace

FaultResult load_faults_text(const std::string& text) {
  FaultResult r;
  YAML::Node root;
  try {
    root = YAML::Load(text);
  } catch (const YAML::Exception& e) {
    r.error = std::string("YAML: ") + e.what();
    return r;
  }
  if (!root.IsMap() || !root["faults"] || !root["faults"].IsSequence()) {
    r.error = "faults: expected a list under `faults:`";
    return r;
  }
  const YAML::Node list = root["faults"];
  for (std::size_t i = 0; i < list.size(); ++i) {
    const std::string where = "faults[" + std::to_string(i) + "]";
    const YAML::Node n = list[i];
    if (!n.IsMap()) {
      r.error = where + ": expected a mapping";
      return r;
    }
    for (const auto& kv : n) {
      const std::string key = kv.first.Scalar();
      if (key != "kind" && key != "drive" && key != "sensor" && key != "at" && key != "count" && key != "param") {
        r.error = where + "." + key + ": unknown key";
        return r;
      }
    }
    Fault f;
    const std::string kind = n["kind"] && n["kind"].IsScalar() ? n["kind"].Scalar() : "";
    bool known = false;
    for (int k = 0; k <= static_cast<int>(FaultKind::not_ready); ++k) {
      if (kind == to_string(static_cast<FaultKind>(k))) {
        f.kind = static_cast<FaultKind>(k);
        known = true;
      }
    }
    if (!known) {
      r.error = where + ".kind: '" + kind + "' is not a fault kind";
      return r;
    }
    std::uint64_t v = 0;
    const bool sensor_kind = f.kind >= FaultKind::stale_counter;
    if (n["sensor"]) {
      const std::string s = n["sensor"].IsScalar() ? n["sensor"].Scalar() : "";
      if (s == "imu") f.sensor = SensorId::imu;
      else if (s == "wrist_ft") f.sensor = SensorId::wrist_ft;
      else {
        r.error = where + ".sensor: expected imu or wrist_ft";
        return r;
      }
      if (n["drive"]) {
        r.error = where + ": give either `drive` or `sensor`";
        return r;
      }
      const bool shared = f.kind == FaultKind::silent || f.kind == FaultKind::drop || f.kind == FaultKind::wrong_dlc;
      if (!sensor_kind && !shared) {
        r.error = where + ".kind: '" + kind + "' is not a sensor fault";
        return r;
      }
      if (f.kind == FaultKind::corrupt_quaternion && f.sensor != SensorId::imu) {
        r.error = where + ".kind: corrupt_quaternion is an IMU fault";
        return r;
      }
    } else {
      if (sensor_kind) {
        r.error = where + ".sensor: '" + kind + "' needs `sensor: imu` or `sensor: wrist_ft`";
        return r;
      }
      if (!n["drive"] || !parse_uint(n["drive"], v) || v < 1 || v > 127) {
        r.error = where + ".drive: expected a drive id 1..127";
        return r;
      }
      f.drive_id = static_cast<int>(v);
    }
    if (!n["at"] || !parse_uint(n["at"], f.at_tick) || f.at_tick < 1) {
      r.error = where + ".at: expected a tick >= 1";
      return r;
    }
    if (n["count"] && (!parse_uint(n["count"], f.count) || f.count < 1)) {
      r.error = where + ".count: expected an integer >= 1";
      return r;
    }
    if (n["param"]) {
      if (!parse_uint(n["param"], v) || v > 0xFFFFFFFFu) {
        r.error = where + ".param: expected an unsigned integer";
        return r;
      }
      f.param = static_cast<std::uint32_t>(v);
    }
    r.faults.push_back(f);
  }
  r.ok = true;
  return r;
}

FaultResult load_faults_file(const std::string& path) {
  std::ifstream in(path);
  if (!in) {
    FaultResult r;
    r.error = path + ": cannot open";
    return r;
  }
  std::stringstream ss;
  ss << in.rdbuf();
  FaultResult r = load_faults_text(ss.str());
  if (!r.ok) r.error = path + ": " + r.error;
  return r;
}

}  // namespace springbok::emu
