#include "springbok/can/config_yaml.hpp"

#include <array>

#include <charconv>
#include <cmath>
#include <fstream>
#include <initializer_list>
#include <limits>
#include <sstream>
#include <stdexcept>

#include <yaml-cpp/yaml.h>

#include <Eigen/Geometry>  // model.hpp uses Eigen::Quaterniond without including it

#include "springbok/can/bus_load.hpp"
#include "springbok/model/model.hpp"

namespace springbok::can {

namespace {

// Thrown only inside the loader, caught at its boundary.
struct ConfigError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

[[noreturn]] void fail(const std::string& path, const std::string& what) { throw ConfigError(path + ": " + what); }

void check_keys(const YAML::Node& map, const std::string& path, std::initializer_list<const char*> allowed) {
  if (!map.IsMap()) fail(path, "expected a mapping");
  for (const auto& kv : map) {
    if (!kv.first.IsScalar()) fail(path, "keys must be plain names");
    const std::string key = kv.first.Scalar();
    bool known = false;
    for (const char* a : allowed) known = known || key == a;
    if (!known) fail(path + "." + key, "unknown key");
  }
}

std::string scalar(const YAML::Node& n, const std::string& path) {
  if (!n.IsScalar()) fail(path, "expected a scalar value");
  return n.Scalar();
}

long long parse_integer(const YAML::Node& n, const std::string& path, long long lo, long long hi) {
  const std::string s = scalar(n, path);
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
  long long value = 0;
  const auto [end, ec] = std::from_chars(v.data(), v.data() + v.size(), value, base);
  if (v.empty() || ec != std::errc{} || end != v.data() + v.size()) fail(path, "expected an integer, got '" + s + "'");
  if (negative) value = -value;
  if (value < lo || value > hi) {
    fail(path, "must be in " + std::to_string(lo) + ".." + std::to_string(hi) + ", got " + s);
  }
  return value;
}

double parse_double(const YAML::Node& n, const std::string& path) {
  const std::string s = scalar(n, path);
  double value = 0.0;
  const char* first = s.data();
  if (!s.empty() && s.front() == '+') ++first;
  const auto [end, ec] = std::from_chars(first, s.data() + s.size(), value);
  if (s.empty() || ec != std::errc{} || end != s.data() + s.size() || !std::isfinite(value)) {
    fail(path, "expected a finite number, got '" + s + "'");
  }
  return value;
}

bool parse_bool(const YAML::Node& n, const std::string& path) {
  const std::string s = scalar(n, path);
  if (s == "true") return true;
  if (s == "false") return false;
  fail(path, "expected true or false, got '" + s + "'");
}

template <class T>
void read_uint(const YAML::Node& map, const char* key, const std::string& path, T& out, long long hi) {
  if (const YAML::Node n = map[key]) out = static_cast<T>(parse_integer(n, path + "." + key, 0, hi));
}
void read_double(const YAML::Node& map, const char* key, const std::string& path, double& out) {
  if (const YAML::Node n = map[key]) out = parse_double(n, path + "." + key);
}

Protocol parse_protocol(const YAML::Node& n, const std::string& path) {
  const std::string s = scalar(n, path);
  if (s == "mit") return Protocol::mit;
  if (s == "cia402") return Protocol::cia402;
  fail(path, "expected mit or cia402, got '" + s + "'");
}

int parse_joint(const YAML::Node& n, const std::string& path) {
  const std::string s = scalar(n, path);
  for (int j = 0; j < kNj; ++j) {
    if (robot::kJoints[static_cast<std::size_t>(j)].name == s) return j;
  }
  return static_cast<int>(parse_integer(n, path, 0, kNj - 1));
}

void parse_range(const YAML::Node& map, const char* key, const std::string& path, double& lo, double& hi) {
  const YAML::Node n = map[key];
  if (!n) return;
  const std::string p = path + "." + key;
  if (!n.IsSequence() || n.size() != 2) fail(p, "expected [min, max]");
  lo = parse_double(n[0], p + "[0]");
  hi = parse_double(n[1], p + "[1]");
  if (!(lo < hi)) fail(p, "min must be below max");
}

// The fields given override `r`; `with_torque` false: the torque range stays per joint.
void parse_mit_ranges(const YAML::Node& n, const std::string& path, bool with_torque, mit::Ranges& r) {
  if (with_torque) {
    check_keys(n, path, {"p", "v", "kp", "kd", "t"});
  } else {
    check_keys(n, path, {"p", "v", "kp", "kd"});
  }
  parse_range(n, "p", path, r.p_min_rad, r.p_max_rad);
  parse_range(n, "v", path, r.v_min_rad_s, r.v_max_rad_s);
  parse_range(n, "kp", path, r.kp_min, r.kp_max);
  parse_range(n, "kd", path, r.kd_min, r.kd_max);
  if (with_torque) parse_range(n, "t", path, r.t_min_nm, r.t_max_nm);
}

void parse_timing(const YAML::Node& n, const std::string& path, Timing& t) {
  check_keys(n, path,
             {"tick_us", "missed_replies_lost", "rx_deadline_us", "mit_presence_timeout_ms", "mit_presence_retries",
              "boot_timeout_ms", "sdo_timeout_ms", "sdo_retries", "state_step_timeout_ms", "heartbeat_period_ms",
              "heartbeat_lost_periods", "tx_fault_ticks", "damping_kd_nms_per_rad", "damping_time_ms",
              "damping_stop_speed_rad_s", "start_limit_margin_rad"});
  constexpr long long kMaxU32 = std::numeric_limits<std::uint32_t>::max();
  read_uint(n, "tick_us", path, t.tick_us, 1000000);
  read_uint(n, "missed_replies_lost", path, t.missed_replies_lost, 100000);
  read_uint(n, "rx_deadline_us", path, t.rx_deadline_us, 10000000);
  read_uint(n, "mit_presence_timeout_ms", path, t.mit_presence_timeout_ms, 600000);
  read_uint(n, "mit_presence_retries", path, t.mit_presence_retries, 100);
  read_uint(n, "boot_timeout_ms", path, t.boot_timeout_ms, 600000);
  read_uint(n, "sdo_timeout_ms", path, t.sdo_timeout_ms, 600000);
  read_uint(n, "sdo_retries", path, t.sdo_retries, 100);
  read_uint(n, "state_step_timeout_ms", path, t.state_step_timeout_ms, 600000);
  read_uint(n, "heartbeat_period_ms", path, t.heartbeat_period_ms, 65535);
  read_uint(n, "heartbeat_lost_periods", path, t.heartbeat_lost_periods, 1000);
  read_uint(n, "tx_fault_ticks", path, t.tx_fault_ticks, kMaxU32);
  read_double(n, "damping_kd_nms_per_rad", path, t.damping_kd_nms_per_rad);
  read_uint(n, "damping_time_ms", path, t.damping_time_ms, 600000);
  read_double(n, "damping_stop_speed_rad_s", path, t.damping_stop_speed_rad_s);
  read_double(n, "start_limit_margin_rad", path, t.start_limit_margin_rad);
}

DriveConfig parse_drive(const YAML::Node& n, const std::string& path, Protocol bus_protocol) {
  check_keys(n, path,
             {"joint", "id", "protocol", "reply_id", "vendor_reply", "mit_ranges", "mapping", "counts_per_rad",
              "velocity_units_per_rad_s", "rated_torque_nm", "gear_ratio", "max_torque_permille"});
  if (!n["joint"]) fail(path + ".joint", "missing");
  const int joint = parse_joint(n["joint"], path + ".joint");
  const Protocol protocol = n["protocol"] ? parse_protocol(n["protocol"], path + ".protocol") : bus_protocol;
  // Defaults as in the built-in layouts (id = joint + 1, torque range = joint effort limit).
  DriveConfig d = default_drive(joint, protocol);
  if (n["id"]) {
    d.drive_id = static_cast<std::uint8_t>(parse_integer(n["id"], path + ".id", 1, cia402::kMaxNode));
    d.mit_reply_id = static_cast<std::uint16_t>(0x100 + d.drive_id);
  }
  read_uint(n, "reply_id", path, d.mit_reply_id, kStandardIdMask);
  if (n["vendor_reply"]) d.mit_vendor_reply = parse_bool(n["vendor_reply"], path + ".vendor_reply");
  if (const YAML::Node r = n["mit_ranges"]) parse_mit_ranges(r, path + ".mit_ranges", true, d.mit_ranges);
  if (const YAML::Node m = n["mapping"]) {
    const std::string s = scalar(m, path + ".mapping");
    if (s == "compact") d.mapping = cia402::Mapping::compact;
    else if (s == "two_tpdo") d.mapping = cia402::Mapping::two_tpdo;
    else fail(path + ".mapping", "expected compact or two_tpdo, got '" + s + "'");
  }
  read_double(n, "counts_per_rad", path, d.counts_per_rad);
  read_double(n, "velocity_units_per_rad_s", path, d.velocity_units_per_rad_s);
  read_double(n, "rated_torque_nm", path, d.rated_torque_nm);
  read_double(n, "gear_ratio", path, d.gear_ratio);
  if (n["max_torque_permille"]) {
    d.max_torque_permille =
        static_cast<std::uint16_t>(parse_integer(n["max_torque_permille"], path + ".max_torque_permille", 1, 32767));
  }
  return d;
}

BusConfig parse_bus(const YAML::Node& n, const std::string& path) {
  check_keys(n, path, {"name", "interface", "fd", "bitrate", "data_bitrate", "protocol", "drives"});
  BusConfig b;
  if (!n["name"]) fail(path + ".name", "missing");
  if (!n["interface"]) fail(path + ".interface", "missing");
  b.name = scalar(n["name"], path + ".name");
  b.interface = scalar(n["interface"], path + ".interface");
  if (n["fd"]) b.fd = parse_bool(n["fd"], path + ".fd");
  read_uint(n, "bitrate", path, b.bitrate, 1000000);
  read_uint(n, "data_bitrate", path, b.data_bitrate, 20000000);
  const Protocol protocol = n["protocol"] ? parse_protocol(n["protocol"], path + ".protocol") : Protocol::mit;
  // A bus that carries only sensors (CAN.md 6.3) has no drives; validate() checks that
  // every bus carries something.
  const YAML::Node drives = n["drives"];
  if (!drives) return b;
  if (!drives.IsSequence()) fail(path + ".drives", "expected a list of drives");
  for (std::size_t i = 0; i < drives.size(); ++i) {
    b.drives.push_back(parse_drive(drives[i], path + ".drives[" + std::to_string(i) + "]", protocol));
  }
  return b;
}

std::uint32_t parse_id(const YAML::Node& n, const std::string& path) {
  return static_cast<std::uint32_t>(parse_integer(n, path, 0, kStandardIdMask));
}

template <std::size_t N>
void parse_ids(const YAML::Node& map, const std::string& path, std::array<std::uint32_t, N>& ids) {
  const YAML::Node n = map["ids"];
  if (!n) return;
  const std::string p = path + ".ids";
  if (!n.IsSequence() || n.size() != N) fail(p, "expected a list of " + std::to_string(N) + " CAN ids");
  for (std::size_t i = 0; i < N; ++i) ids[i] = parse_id(n[i], p + "[" + std::to_string(i) + "]");
}

void parse_positive(const YAML::Node& map, const char* key, const std::string& path, double& out) {
  if (const YAML::Node n = map[key]) {
    out = parse_double(n, path + "." + key);
    if (!(out > 0.0)) fail(path + "." + key, "must be > 0");
  }
}

void parse_triple(const YAML::Node& map, const char* key, const std::string& path, std::array<double, 3>& out) {
  const YAML::Node n = map[key];
  if (!n) return;
  const std::string p = path + "." + key;
  if (!n.IsSequence() || n.size() != 3) fail(p, "expected [x, y, z]");
  for (std::size_t i = 0; i < 3; ++i) out[i] = parse_double(n[i], p + "[" + std::to_string(i) + "]");
}

std::string parse_sensor_bus(const YAML::Node& n, const std::string& path) {
  if (!n["bus"]) fail(path + ".bus", "missing (the name of the bus the sensor is on)");
  return scalar(n["bus"], path + ".bus");
}

ImuConfig parse_imu(const YAML::Node& n, const std::string& path) {
  check_keys(n, path,
             {"bus", "ids", "orientation_per_count", "rate_rad_s_per_count", "accel_m_s2_per_count", "stale_ticks",
              "clip_streak", "rate_hz"});
  ImuConfig s;
  s.enabled = true;
  s.bus = parse_sensor_bus(n, path);
  parse_ids(n, path, s.ids);
  parse_positive(n, "orientation_per_count", path, s.scales.orientation_per_count);
  parse_positive(n, "rate_rad_s_per_count", path, s.scales.rate_rad_s_per_count);
  parse_positive(n, "accel_m_s2_per_count", path, s.scales.accel_m_s2_per_count);
  if (n["stale_ticks"]) s.stale_ticks = static_cast<std::uint32_t>(parse_integer(n["stale_ticks"], path + ".stale_ticks", 1, 127));
  read_uint(n, "clip_streak", path, s.clip_streak, 1000000);
  parse_positive(n, "rate_hz", path, s.rate_hz);
  return s;
}

FtConfig parse_ft(const YAML::Node& n, const std::string& path) {
  check_keys(n, path,
             {"bus", "ids", "counts_per_n", "counts_per_nm", "stale_ticks", "clip_streak", "tare_samples", "offset",
              "rate_hz"});
  FtConfig s;
  s.enabled = true;
  s.bus = parse_sensor_bus(n, path);
  parse_ids(n, path, s.ids);
  parse_positive(n, "counts_per_n", path, s.counts_per_n);
  parse_positive(n, "counts_per_nm", path, s.counts_per_nm);
  if (n["stale_ticks"]) s.stale_ticks = static_cast<std::uint32_t>(parse_integer(n["stale_ticks"], path + ".stale_ticks", 1, 127));
  read_uint(n, "clip_streak", path, s.clip_streak, 1000000);
  if (n["tare_samples"]) {
    s.tare_samples = static_cast<std::uint32_t>(parse_integer(n["tare_samples"], path + ".tare_samples", 1, 1000000));
  }
  if (const YAML::Node o = n["offset"]) {
    const std::string op = path + ".offset";
    check_keys(o, op, {"xyz_m", "rpy_rad"});
    s.has_offset = true;
    parse_triple(o, "xyz_m", op, s.offset.xyz_m);
    parse_triple(o, "rpy_rad", op, s.offset.rpy_rad);
  }
  parse_positive(n, "rate_hz", path, s.rate_hz);
  return s;
}

SensorsConfig parse_sensors(const YAML::Node& n, const std::string& path) {
  check_keys(n, path, {"imu", "wrist_ft"});
  SensorsConfig s;
  if (const YAML::Node imu = n["imu"]) s.imu = parse_imu(imu, path + ".imu");
  if (const YAML::Node ft = n["wrist_ft"]) s.wrist_ft = parse_ft(ft, path + ".wrist_ft");
  return s;
}

CanConfig parse_can(const YAML::Node& n) {
  const std::string path = "can";
  if (!n) fail(path, "missing section");
  check_keys(n, path,
             {"layout", "protocol", "interface_prefix", "max_bus_load", "mit_velocity_observer_rad_s", "mit_ranges",
              "timing", "buses", "extra_buses", "sensors"});
  const std::string prefix = n["interface_prefix"] ? scalar(n["interface_prefix"], path + ".interface_prefix") : "can";
  const Protocol protocol = n["protocol"] ? parse_protocol(n["protocol"], path + ".protocol") : Protocol::mit;
  CanConfig c;
  if (const YAML::Node layout = n["layout"]) {
    const std::string s = scalar(layout, path + ".layout");
    if (s == "classic7") c = classic7_layout(protocol, prefix);
    else if (s == "fd5") c = fd5_layout(prefix);
    else fail(path + ".layout", "expected classic7 or fd5, got '" + s + "'");
  }
  if (const YAML::Node buses = n["buses"]) {
    if (!buses.IsSequence()) fail(path + ".buses", "expected a list of buses");
    c.buses.clear();
    for (std::size_t i = 0; i < buses.size(); ++i) {
      c.buses.push_back(parse_bus(buses[i], path + ".buses[" + std::to_string(i) + "]"));
    }
  } else if (!n["layout"]) {
    fail(path, "needs `layout` or `buses`");
  }
  // Flash settings shared by every MIT drive (e.g. KP_MAX above the Mini Cheetah's 500 for
  // stiff leg gains): the listed fields override those of every MIT drive, its own entry's too.
  if (const YAML::Node r = n["mit_ranges"]) {
    for (BusConfig& b : c.buses) {
      for (DriveConfig& d : b.drives) {
        if (d.protocol == Protocol::mit) parse_mit_ranges(r, path + ".mit_ranges", false, d.mit_ranges);
      }
    }
  }
  // Buses added to the layout's (or the listed) ones, e.g. the sensors' own bus (CAN.md 6.3).
  if (const YAML::Node extra = n["extra_buses"]) {
    if (!extra.IsSequence()) fail(path + ".extra_buses", "expected a list of buses");
    for (std::size_t i = 0; i < extra.size(); ++i) {
      c.buses.push_back(parse_bus(extra[i], path + ".extra_buses[" + std::to_string(i) + "]"));
    }
  }
  read_double(n, "max_bus_load", path, c.max_bus_load);
  read_double(n, "mit_velocity_observer_rad_s", path, c.mit_velocity_observer_rad_s);
  if (const YAML::Node t = n["timing"]) parse_timing(t, path + ".timing", c.timing);
  if (const YAML::Node s = n["sensors"]) c.sensors = parse_sensors(s, path + ".sensors");
  return c;
}

}  // namespace

ConfigResult load_can_config(const YAML::Node& can) {
  ConfigResult r;
  try {
    r.config = parse_can(can);
  } catch (const ConfigError& e) {
    r.error = e.what();
    return r;
  } catch (const YAML::Exception& e) {
    r.error = std::string("can: ") + e.what();
    return r;
  }
  r.error = validate(r.config);
  // Every bus's worst-case load, its sensors included (CAN.md 3, 6.3).
  if (r.error.empty()) {
    if (const std::string load = check_bus_loads(r.config); !load.empty()) r.error = "can.buses: " + load;
  }
  r.ok = r.error.empty();
  return r;
}

ConfigResult load_can_config_text(std::string_view yaml_text) {
  YAML::Node root;
  try {
    root = YAML::Load(std::string(yaml_text));
  } catch (const YAML::Exception& e) {
    ConfigResult r;
    r.error = std::string("YAML: ") + e.what();
    return r;
  }
  if (!root.IsMap()) {
    ConfigResult r;
    r.error = "top level: expected a mapping with a `can:` key";
    return r;
  }
  return load_can_config(root["can"]);
}

ConfigResult load_can_config_file(const std::string& path) {
  std::ifstream in(path);
  if (!in) {
    ConfigResult r;
    r.error = path + ": cannot open";
    return r;
  }
  std::stringstream ss;
  ss << in.rdbuf();
  ConfigResult r = load_can_config_text(ss.str());
  if (!r.ok) r.error = path + ": " + r.error;
  return r;
}

}  // namespace springbok::can
