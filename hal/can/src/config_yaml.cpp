#include "springbok/can/config_yaml.hpp"

#include <array>
#include <cctype>
#include <limits>
#include <optional>

#include "springbok/can/bus_load.hpp"
#include "springbok/yaml/reader.hpp"
#include "springbok/model/model.hpp"

namespace springbok::can {

namespace {

using yaml::Field;

constexpr long long kMaxU32 = std::numeric_limits<std::uint32_t>::max();

void parse_protocol(const Field& f, Protocol& out) {
  int p = 0;
  if (f.choice(p, {"mit", "cia402"})) out = p == 0 ? Protocol::mit : Protocol::cia402;
}

// A joint by name (robot::kJoints) or index.
void parse_joint(const Field& f, int& out) {
  if (!f.is_scalar()) {
    f.fail("must be a joint name or index, got " + f.describe());
    return;
  }
  for (int j = 0; j < kNj; ++j) {
    if (robot::kJoints[static_cast<std::size_t>(j)].name == f.node().Scalar()) {
      out = j;
      return;
    }
  }
  const bool digits = !f.node().Scalar().empty() && std::isdigit(static_cast<unsigned char>(f.node().Scalar()[0]));
  if (!digits) {
    f.fail("'" + f.node().Scalar() + "' is not a joint of the model");
    return;
  }
  (void)f.integer(out, 0, kNj - 1);
}

// [min, max], finite, min < max.
void parse_range(const Field& f, double& lo, double& hi) {
  if (!f.present() || !f.expect_list(2)) return;
  double a = lo, b = hi;
  const bool ok = f[std::size_t{0}].number(a, -1e9, 1e9) && f[std::size_t{1}].number(b, -1e9, 1e9);
  if (!ok) return;
  if (!(a < b)) {
    f.fail("min must be below max");
    return;
  }
  lo = a;
  hi = b;
}

// The fields given override `r`; `with_torque` false: the torque range stays per joint.
void parse_mit_ranges(const Field& f, bool with_torque, mit::Ranges& r) {
  if (with_torque) {
    f.allow_only({"p", "v", "kp", "kd", "t"});
  } else {
    f.allow_only({"p", "v", "kp", "kd"});
  }
  parse_range(f["p"], r.p_min_rad, r.p_max_rad);
  parse_range(f["v"], r.v_min_rad_s, r.v_max_rad_s);
  parse_range(f["kp"], r.kp_min, r.kp_max);
  parse_range(f["kd"], r.kd_min, r.kd_max);
  if (with_torque) parse_range(f["t"], r.t_min_nm, r.t_max_nm);
}

void parse_timing(const Field& f, Timing& t) {
  f.allow_only({"tick_us", "missed_replies_lost", "rx_deadline_us", "mit_presence_timeout_ms", "mit_presence_retries",
                "boot_timeout_ms", "sdo_timeout_ms", "sdo_retries", "state_step_timeout_ms", "heartbeat_period_ms",
                "heartbeat_lost_periods", "tx_fault_ticks", "damping_kd_nms_per_rad", "damping_time_ms",
                "damping_stop_speed_rad_s", "start_limit_margin_rad"});
  f["tick_us"].integer(t.tick_us, 0, 1000000);
  f["missed_replies_lost"].integer(t.missed_replies_lost, 0, 100000);
  f["rx_deadline_us"].integer(t.rx_deadline_us, 0, 10000000);
  f["mit_presence_timeout_ms"].integer(t.mit_presence_timeout_ms, 0, 600000);
  f["mit_presence_retries"].integer(t.mit_presence_retries, 0, 100);
  f["boot_timeout_ms"].integer(t.boot_timeout_ms, 0, 600000);
  f["sdo_timeout_ms"].integer(t.sdo_timeout_ms, 0, 600000);
  f["sdo_retries"].integer(t.sdo_retries, 0, 100);
  f["state_step_timeout_ms"].integer(t.state_step_timeout_ms, 0, 600000);
  f["heartbeat_period_ms"].integer(t.heartbeat_period_ms, 0, 65535);
  f["heartbeat_lost_periods"].integer(t.heartbeat_lost_periods, 0, 1000);
  f["tx_fault_ticks"].integer(t.tx_fault_ticks, 0, kMaxU32);
  f["damping_kd_nms_per_rad"].number(t.damping_kd_nms_per_rad, -1e9, 1e9);  // validate() judges the range
  f["damping_time_ms"].integer(t.damping_time_ms, 0, 600000);
  f["damping_stop_speed_rad_s"].number(t.damping_stop_speed_rad_s, -1e9, 1e9);
  f["start_limit_margin_rad"].number(t.start_limit_margin_rad, -1e9, 1e9);
}

// CAN.md 4.2 step 3's expected pose; validate() judges the values (finite, within the limits).
void parse_start_pose(const Field& f, StartPose& p) {
  if (!f.is_map()) {
    f.fail("must be a map {q_rad, tolerance_rad}, got " + f.describe());
    return;
  }
  f.allow_only({"q_rad", "tolerance_rad"});
  p.given = true;
  Eigen::Matrix<double, kNj, 1> q = Eigen::Matrix<double, kNj, 1>::Zero();
  if (f["q_rad"].require() && f["q_rad"].vector<kNj>(q, -1e9, 1e9)) {
    for (int j = 0; j < kNj; ++j) p.q_rad[static_cast<std::size_t>(j)] = q[j];
  }
  f["tolerance_rad"].number(p.tolerance_rad, -1e9, 1e9);
}

std::optional<DriveConfig> parse_drive(const Field& f, Protocol bus_protocol) {
  if (!f.is_map()) {
    f.fail("must be a map (a drive), got " + f.describe());
    return std::nullopt;
  }
  f.allow_only({"joint", "id", "protocol", "reply_id", "vendor_reply", "mit_ranges", "mapping", "counts_per_rad",
                "velocity_units_per_rad_s", "rated_torque_nm", "gear_ratio", "max_torque_permille"});
  int joint = -1;
  if (f["joint"].require()) parse_joint(f["joint"], joint);
  if (joint < 0) return std::nullopt;
  Protocol protocol = bus_protocol;
  parse_protocol(f["protocol"], protocol);
  // Defaults as in the built-in layouts (id = joint + 1, torque range = joint effort limit).
  DriveConfig d = default_drive(joint, protocol);
  if (f["id"].integer(d.drive_id, 1, cia402::kMaxNode)) d.mit_reply_id = static_cast<std::uint16_t>(0x100 + d.drive_id);
  f["reply_id"].integer(d.mit_reply_id, 0, kStandardIdMask);
  f["vendor_reply"].boolean(d.mit_vendor_reply);
  if (f["mit_ranges"].present()) parse_mit_ranges(f["mit_ranges"], true, d.mit_ranges);
  int mapping = 0;
  if (f["mapping"].choice(mapping, {"compact", "two_tpdo"})) {
    d.mapping = mapping == 0 ? cia402::Mapping::compact : cia402::Mapping::two_tpdo;
  }
  f["counts_per_rad"].number(d.counts_per_rad, -1e12, 1e12);  // validate() judges the ranges
  f["velocity_units_per_rad_s"].number(d.velocity_units_per_rad_s, -1e12, 1e12);
  f["rated_torque_nm"].number(d.rated_torque_nm, -1e12, 1e12);
  f["gear_ratio"].number(d.gear_ratio, -1e12, 1e12);
  f["max_torque_permille"].integer(d.max_torque_permille, 0, 32767);
  return d;
}

BusConfig parse_bus(const Field& f) {
  BusConfig b;
  if (!f.is_map()) {
    f.fail("must be a map (a bus), got " + f.describe());
    return b;
  }
  f.allow_only({"name", "interface", "fd", "bitrate", "data_bitrate", "protocol", "drives"});
  if (f["name"].require()) f["name"].text(b.name);
  if (f["interface"].require()) f["interface"].text(b.interface);
  f["fd"].boolean(b.fd);
  f["bitrate"].integer(b.bitrate, 0, 1000000);
  f["data_bitrate"].integer(b.data_bitrate, 0, 20000000);
  Protocol protocol = Protocol::mit;
  parse_protocol(f["protocol"], protocol);
  // A bus that carries only sensors (CAN.md 6.3) has no drives; validate() checks that
  // every bus carries something.
  const Field drives = f["drives"];
  if (!drives.expect_list()) return b;
  for (std::size_t i = 0; i < drives.size(); ++i) {
    if (auto d = parse_drive(drives[i], protocol)) b.drives.push_back(*d);
  }
  return b;
}

template <std::size_t N>
void parse_ids(const Field& f, std::array<std::uint32_t, N>& ids) {
  if (!f.present() || !f.expect_list(N)) return;
  for (std::size_t i = 0; i < N; ++i) f[i].integer(ids[i], 0, kStandardIdMask);
}

void parse_positive(const Field& f, double& out) {
  double v = out;
  if (!f.number(v, -1e12, 1e12)) return;
  if (!(v > 0.0)) {
    f.fail("must be > 0, got " + f.node().Scalar());
    return;
  }
  out = v;
}

void parse_triple(const Field& f, std::array<double, 3>& out) {
  Eigen::Vector3d v(out[0], out[1], out[2]);
  if (f.vector<3>(v, -1e3, 1e3)) out = {v.x(), v.y(), v.z()};
}

void parse_sensor_bus(const Field& f, std::string& bus) {
  if (!f.present()) {
    f.fail("missing (the name of the bus the sensor is on)");
    return;
  }
  f.text(bus);
}

ImuConfig parse_imu(const Field& f) {
  f.allow_only({"bus", "ids", "orientation_per_count", "rate_rad_s_per_count", "accel_m_s2_per_count", "stale_ticks",
                "clip_streak", "rate_hz"});
  ImuConfig s;
  s.enabled = true;
  parse_sensor_bus(f["bus"], s.bus);
  parse_ids(f["ids"], s.ids);
  parse_positive(f["orientation_per_count"], s.scales.orientation_per_count);
  parse_positive(f["rate_rad_s_per_count"], s.scales.rate_rad_s_per_count);
  parse_positive(f["accel_m_s2_per_count"], s.scales.accel_m_s2_per_count);
  f["stale_ticks"].integer(s.stale_ticks, 1, 127);
  f["clip_streak"].integer(s.clip_streak, 0, 1000000);
  parse_positive(f["rate_hz"], s.rate_hz);
  return s;
}

FtConfig parse_ft(const Field& f) {
  f.allow_only({"bus", "ids", "counts_per_n", "counts_per_nm", "stale_ticks", "clip_streak", "tare_samples", "offset",
                "rate_hz"});
  FtConfig s;
  s.enabled = true;
  parse_sensor_bus(f["bus"], s.bus);
  parse_ids(f["ids"], s.ids);
  parse_positive(f["counts_per_n"], s.counts_per_n);
  parse_positive(f["counts_per_nm"], s.counts_per_nm);
  f["stale_ticks"].integer(s.stale_ticks, 1, 127);
  f["clip_streak"].integer(s.clip_streak, 0, 1000000);
  f["tare_samples"].integer(s.tare_samples, 1, 1000000);
  if (const Field o = f["offset"]; o.present()) {
    o.allow_only({"xyz_m", "rpy_rad"});
    s.has_offset = true;
    parse_triple(o["xyz_m"], s.offset.xyz_m);
    parse_triple(o["rpy_rad"], s.offset.rpy_rad);
  }
  parse_positive(f["rate_hz"], s.rate_hz);
  return s;
}

SensorsConfig parse_sensors(const Field& f) {
  f.allow_only({"imu", "wrist_ft"});
  SensorsConfig s;
  if (f["imu"].present()) s.imu = parse_imu(f["imu"]);
  if (f["wrist_ft"].present()) s.wrist_ft = parse_ft(f["wrist_ft"]);
  return s;
}

CanConfig parse_can(const Field& f) {
  CanConfig c;
  if (!f.require()) return c;
  if (!f.allow_only({"layout", "protocol", "interface_prefix", "max_bus_load", "mit_velocity_observer_rad_s",
                     "mit_bus_voltage_warning_v", "mit_bus_voltage_fault_v", "mit_ranges", "timing", "buses",
                     "extra_buses", "sensors", "start_pose"})) {
    return c;
  }
  std::string prefix = "can";
  f["interface_prefix"].text(prefix);
  Protocol protocol = Protocol::mit;
  parse_protocol(f["protocol"], protocol);
  int layout = -1;
  if (f["layout"].choice(layout, {"classic7", "fd5"})) c = layout == 0 ? classic7_layout(protocol, prefix) : fd5_layout(prefix);
  if (const Field buses = f["buses"]; buses.present()) {
    c.buses.clear();
    if (buses.expect_list()) {
      for (std::size_t i = 0; i < buses.size(); ++i) c.buses.push_back(parse_bus(buses[i]));
    }
  } else if (!f["layout"].present()) {
    f.fail("needs `layout` or `buses`");
  }
  // Flash settings shared by every MIT drive (e.g. KP_MAX above the Mini Cheetah's 500 for
  // stiff leg gains): the listed fields override those of every MIT drive, its own entry's too.
  if (const Field r = f["mit_ranges"]; r.present()) {
    for (BusConfig& b : c.buses) {
      for (DriveConfig& d : b.drives) {
        if (d.protocol == Protocol::mit) parse_mit_ranges(r, false, d.mit_ranges);
      }
    }
  }
  // Buses added to the layout's (or the listed) ones, e.g. the sensors' own bus (CAN.md 6.3).
  if (const Field extra = f["extra_buses"]; extra.expect_list()) {
    for (std::size_t i = 0; i < extra.size(); ++i) c.buses.push_back(parse_bus(extra[i]));
  }
  f["max_bus_load"].number(c.max_bus_load, -1e9, 1e9);  // validate() judges the ranges
  f["mit_velocity_observer_rad_s"].number(c.mit_velocity_observer_rad_s, -1e9, 1e9);
  f["mit_bus_voltage_warning_v"].number(c.mit_bus_voltage_warning_v, -1e9, 1e9);
  f["mit_bus_voltage_fault_v"].number(c.mit_bus_voltage_fault_v, -1e9, 1e9);
  if (f["timing"].present()) parse_timing(f["timing"], c.timing);
  if (f["sensors"].present()) c.sensors = parse_sensors(f["sensors"]);
  if (f["start_pose"].present()) parse_start_pose(f["start_pose"], c.start_pose);
  return c;
}

}  // namespace

CanConfig read_can_config(const yaml::Field& can) {
  const std::size_t errors_before = can.errors().size();
  CanConfig c = parse_can(can);
  if (can.errors().size() != errors_before) return c;  // validate() would only repeat them
  if (std::string e = validate(c); !e.empty()) {
    can.errors().add_line(std::move(e));
  } else if (std::string load = check_bus_loads(c); !load.empty()) {  // every bus, its sensors included (CAN.md 3, 6.3)
    can.errors().add_line("can.buses: " + load);
  }
  return c;
}

namespace {
ConfigResult from_document(const yaml::Document& doc) {
  ConfigResult r;
  if (!doc.ok) {
    r.error = doc.error;
    return r;
  }
  yaml::Errors errors;
  const yaml::Field root(doc.root, "", errors);
  if (root.present() && !root.is_map()) {
    root.fail("must be a map with a `can:` key, got " + root.describe());
  } else {
    r.config = read_can_config(root["can"]);
  }
  r.error = errors.joined();
  r.ok = errors.empty();
  return r;
}
}  // namespace

ConfigResult load_can_config_text(std::string_view yaml_text) { return from_document(yaml::parse_text(yaml_text)); }

ConfigResult load_can_config_file(const std::string& path) {
  ConfigResult r = from_document(yaml::parse_file(path));
  if (!r.ok && r.error.rfind(path, 0) != 0) r.error = path + ": " + r.error;
  return r;
}

}  // namespace springbok::can
