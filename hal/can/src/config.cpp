#include "springbok/can/config.hpp"

#include <array>
#include <cmath>
#include <cstdio>
#include <utility>
#include <vector>
#include <numbers>
#include <set>
#include <string>

#include "springbok/model/model.hpp"

namespace springbok::can {

const char* to_string(Protocol p) noexcept { return p == Protocol::mit ? "mit" : "cia402"; }

bool at_start_pose(const StartPose& pose, int joint, double q_rad) noexcept {
  return std::isfinite(q_rad) && std::abs(q_rad - pose.q_rad[static_cast<std::size_t>(joint)]) <= pose.tolerance_rad;
}

DriveConfig default_drive(int joint, Protocol p) {
  DriveConfig d;
  d.joint = joint;
  d.drive_id = static_cast<std::uint8_t>(joint + 1);
  d.protocol = p;
  d.mit_reply_id = static_cast<std::uint16_t>(0x100 + d.drive_id);
  // The torque range: the most the joint gives anywhere in its range (the supervisor bounds the
  // command by the limit at the angle).
  const double peak_nm = torque_limit_peak_nm(joint);
  d.mit_ranges.t_min_nm = -peak_nm;
  d.mit_ranges.t_max_nm = peak_nm;
  d.counts_per_rad = 524288.0 / (2.0 * std::numbers::pi);  // 19-bit joint-side encoder
  d.velocity_units_per_rad_s = 1000.0;           // mrad/s
  d.rated_torque_nm = 0.0;  // not given: the drive's 0x6076 scales the torques
  d.gear_ratio = 1.0;
  d.max_torque_permille = 0;  // 0x6072 = the joint's peak torque limit
  return d;
}

namespace {

BusConfig make_bus(const std::string& name, const std::string& iface, int first, int count, Protocol p) {
  BusConfig b;
  b.name = name;
  b.interface = iface;
  for (int j = first; j < first + count; ++j) b.drives.push_back(default_drive(j, p));
  return b;
}

bool ordered_finite(double lo, double hi) { return std::isfinite(lo) && std::isfinite(hi) && lo < hi; }

}  // namespace

CanConfig classic7_layout(Protocol p, const std::string& prefix) {
  CanConfig c;
  const std::array<const char*, kFeet> legs{"lf", "rf", "lh", "rh"};
  for (int leg = 0; leg < kFeet; ++leg) {
    c.buses.push_back(make_bus(legs[leg], prefix + std::to_string(leg), leg_first_joint(leg), kLegJoints, p));
  }
  // The arm's joints over three buses, the first ones taking one more where they do not divide
  // (7: 3 2 2, as CAN.md 3.2; 6: 2 2 2); an arm of fewer than three joints uses fewer buses.
  int first = kFirstArmJoint;
  for (int b = 0; b < 3; ++b) {
    const int count = kArmJoints / 3 + (b < kArmJoints % 3 ? 1 : 0);
    if (count == 0) continue;
    c.buses.push_back(make_bus("arm" + std::to_string(b), prefix + std::to_string(kFeet + b), first, count, p));
    first += count;
  }
  return c;
}

CanConfig fd5_layout(const std::string& prefix) {
  CanConfig c;
  const std::array<const char*, kFeet> legs{"lf", "rf", "lh", "rh"};
  for (int leg = 0; leg < kFeet; ++leg) {
    c.buses.push_back(make_bus(legs[leg], prefix + std::to_string(leg), leg_first_joint(leg), kLegJoints, Protocol::mit));
  }
  BusConfig arm = make_bus("arm", prefix + std::to_string(kFeet), kFirstArmJoint, kArmJoints, Protocol::mit);
  arm.fd = true;
  arm.data_bitrate = 5000000;
  c.buses.push_back(arm);
  return c;
}

namespace {
// Whether `id` is a frame of the bus's drives: their MIT command and reply ids (unless
// only the CANopen ones are asked for) and their CiA 301 / 402 ids.
bool bus_id_collides(const BusConfig& bus, std::uint32_t id, std::string& why, bool with_mit) {
  for (const DriveConfig& d : bus.drives) {
    if (d.protocol == Protocol::mit) {
      if (!with_mit) continue;
      if (id == d.drive_id) {
        why = "the MIT command id of drive " + std::to_string(d.drive_id);
        return true;
      }
      if (id == d.mit_reply_id) {
        why = "the MIT reply id of drive " + std::to_string(d.drive_id);
        return true;
      }
      continue;
    }
    // CiA 301 pre-defined connection set of node n (CAN.md 2.1), plus NMT and SYNC.
    if (id == cia402::cob::nmt || id == cia402::cob::sync) {
      why = id == cia402::cob::nmt ? "the CANopen NMT id" : "the CANopen SYNC id";
      return true;
    }
    static constexpr std::array<std::pair<std::uint32_t, const char*>, 12> kCobs{{
        {0x080, "EMCY"}, {0x180, "TPDO1"}, {0x200, "RPDO1"}, {0x280, "TPDO2"}, {0x300, "RPDO2"},
        {0x380, "TPDO3"}, {0x400, "RPDO3"}, {0x480, "TPDO4"}, {0x500, "RPDO4"}, {0x580, "SDO response"},
        {0x600, "SDO request"}, {0x700, "heartbeat"}}};
    for (const auto& [base, name] : kCobs) {
      if (id == base + d.drive_id) {
        why = std::string("the CANopen ") + name + " COB-ID of node " + std::to_string(d.drive_id);
        return true;
      }
    }
  }
  return false;
}
}  // namespace

bool sensor_id_collides(const BusConfig& bus, std::uint32_t id, std::string& why) {
  return bus_id_collides(bus, id, why, true);
}

namespace {

std::string hex_id(std::uint32_t id) {
  char buf[16];
  std::snprintf(buf, sizeof buf, "0x%03X", id);
  return buf;
}

bool positive_finite(double x) { return std::isfinite(x) && x > 0.0; }

// Common checks of one sensor: its bus exists, ids 11-bit, unique and free on that bus.
template <std::size_t N>
std::string check_sensor(const CanConfig& c, const std::string& where, const std::string& bus_name,
                         const std::array<std::uint32_t, N>& ids, std::uint32_t stale_ticks, double rate_hz,
                         std::vector<std::pair<std::string, std::uint32_t>>& used) {
  const BusConfig* bus = nullptr;
  for (const BusConfig& b : c.buses) {
    if (b.name == bus_name) bus = &b;
  }
  if (bus == nullptr) return where + ".bus: no bus named '" + bus_name + "'";
  for (std::size_t i = 0; i < N; ++i) {
    const std::string iw = where + ".ids[" + std::to_string(i) + "]";
    if (ids[i] > kStandardIdMask) return iw + ": must be an 11-bit id";
    std::string why;
    if (sensor_id_collides(*bus, ids[i], why)) {
      return iw + ": " + hex_id(ids[i]) + " collides with " + why + " on bus '" + bus_name + "'";
    }
    for (const auto& [other_bus, other_id] : used) {
      if (other_bus == bus_name && other_id == ids[i]) {
        return iw + ": " + hex_id(ids[i]) + " used twice on bus '" + bus_name + "'";
      }
    }
    used.emplace_back(bus_name, ids[i]);
  }
  if (stale_ticks == 0) return where + ".stale_ticks: must be >= 1";
  if (stale_ticks >= 128) return where + ".stale_ticks: must be below 128 (half the counter's range)";
  if (!(positive_finite(rate_hz) && rate_hz <= 10000.0)) return where + ".rate_hz: must be in (0, 10000]";
  return {};
}

// The kernel's dev_valid_name(): not "." or "..", no '/', ':' or white space; printable
// ASCII besides (the name also goes to ip(8) and the log).
bool valid_interface_name(const std::string& name) {
  if (name == "." || name == "..") return false;
  for (const char ch : name) {
    if (ch <= ' ' || ch > '~' || ch == '/' || ch == ':') return false;
  }
  return true;
}

std::string validate_sensors(const CanConfig& c) {
  std::vector<std::pair<std::string, std::uint32_t>> used;
  if (const ImuConfig& s = c.sensors.imu; s.enabled) {
    const std::string w = "can.sensors.imu";
    if (std::string e = check_sensor(c, w, s.bus, s.ids, s.stale_ticks, s.rate_hz, used); !e.empty()) return e;
    if (!positive_finite(s.scales.orientation_per_count)) return w + ".orientation_per_count: must be finite and > 0";
    if (!positive_finite(s.scales.rate_rad_s_per_count)) return w + ".rate_rad_s_per_count: must be finite and > 0";
    if (!positive_finite(s.scales.accel_m_s2_per_count)) return w + ".accel_m_s2_per_count: must be finite and > 0";
  }
  if (const FtConfig& s = c.sensors.wrist_ft; s.enabled) {
    const std::string w = "can.sensors.wrist_ft";
    if (std::string e = check_sensor(c, w, s.bus, s.ids, s.stale_ticks, s.rate_hz, used); !e.empty()) return e;
    if (!positive_finite(s.counts_per_n)) return w + ".counts_per_n: must be finite and > 0";
    if (!positive_finite(s.counts_per_nm)) return w + ".counts_per_nm: must be finite and > 0";
    for (double x : s.offset.xyz_m) {
      if (!std::isfinite(x)) return w + ".offset.xyz_m: must be finite";
    }
    for (double x : s.offset.rpy_rad) {
      if (!std::isfinite(x)) return w + ".offset.rpy_rad: must be finite";
    }
  }
  return {};
}

std::string validate_start_pose(const CanConfig& c) {
  const StartPose& p = c.start_pose;
  if (!p.given) return {};  // optional: MIT start-up then checks the joint limits alone
  for (int j = 0; j < kNj; ++j) {
    const double q = p.q_rad[static_cast<std::size_t>(j)];
    const auto& lim = robot::kJoints[static_cast<std::size_t>(j)].limits;
    const std::string where = "can.start_pose.q_rad[" + std::to_string(j) + "]";
    if (!std::isfinite(q)) return where + ": must be finite";
    if (lim.bounded && (q < lim.lower_rad || q > lim.upper_rad)) {
      return where + ": " + std::to_string(q) + " rad is outside the limits of joint '" +
             std::string(robot::kJoints[static_cast<std::size_t>(j)].name) + "' [" + std::to_string(lim.lower_rad) +
             ", " + std::to_string(lim.upper_rad) + "]";
    }
  }
  if (!(std::isfinite(p.tolerance_rad) && p.tolerance_rad > 0.0 && p.tolerance_rad <= kMaxStartPoseToleranceRad)) {
    return "can.start_pose.tolerance_rad: must be in (0, " + std::to_string(kMaxStartPoseToleranceRad) + "] rad";
  }
  return {};
}

}  // namespace

std::string validate(const CanConfig& c) {
  if (c.buses.empty()) return "can.buses: no bus configured";
  if (static_cast<int>(c.buses.size()) > kMaxBuses) return "can.buses: more than " + std::to_string(kMaxBuses) + " buses";
  if (!(c.max_bus_load > 0.0 && c.max_bus_load <= 1.0)) return "can.max_bus_load: must be in (0, 1]";
  // The discrete observer needs 1.4 w dt < 1 with margin at the tick: 200 rad/s at 1 kHz.
  if (!(c.mit_velocity_observer_rad_s >= 0.0 && c.mit_velocity_observer_rad_s <= 200.0e3 / c.timing.tick_us)) {
    return "can.mit_velocity_observer_rad_s: must be in [0, 200 x 1000 / timing.tick_us] rad/s (0: off)";
  }
  for (const auto& [name, v] : {std::pair{"mit_bus_voltage_warning_v", c.mit_bus_voltage_warning_v},
                                std::pair{"mit_bus_voltage_fault_v", c.mit_bus_voltage_fault_v}}) {
    if (!(v >= 0.0 && v <= mit::kBusVoltageMaxV)) {
      return std::string("can.") + name + ": must be in [0, " + std::to_string(static_cast<int>(mit::kBusVoltageMaxV)) +
             "] V (0: off)";
    }
  }
  if (c.mit_bus_voltage_warning_v > 0.0 && c.mit_bus_voltage_fault_v >= c.mit_bus_voltage_warning_v) {
    return "can.mit_bus_voltage_fault_v: must be below can.mit_bus_voltage_warning_v";
  }
  const Timing& t = c.timing;
  if (t.tick_us == 0) return "can.timing.tick_us: must be > 0";
  if (t.missed_replies_lost == 0) return "can.timing.missed_replies_lost: must be >= 1";
  if (t.rx_deadline_us == 0) return "can.timing.rx_deadline_us: must be > 0";
  if (t.mit_presence_timeout_ms == 0) return "can.timing.mit_presence_timeout_ms: must be > 0";
  if (t.boot_timeout_ms == 0) return "can.timing.boot_timeout_ms: must be > 0";
  if (t.sdo_timeout_ms == 0) return "can.timing.sdo_timeout_ms: must be > 0";
  if (t.state_step_timeout_ms == 0) return "can.timing.state_step_timeout_ms: must be > 0";
  if (t.heartbeat_period_ms == 0 || t.heartbeat_period_ms > 65535) return "can.timing.heartbeat_period_ms: must be 1..65535";
  if (t.heartbeat_lost_periods == 0) return "can.timing.heartbeat_lost_periods: must be >= 1";
  if (t.tx_fault_ticks == 0) return "can.timing.tx_fault_ticks: must be >= 1";
  if (!(std::isfinite(t.damping_kd_nms_per_rad) && t.damping_kd_nms_per_rad >= 0.0)) {
    return "can.timing.damping_kd_nms_per_rad: must be finite and >= 0";
  }
  if (!(std::isfinite(t.damping_stop_speed_rad_s) && t.damping_stop_speed_rad_s >= 0.0)) {
    return "can.timing.damping_stop_speed_rad_s: must be finite and >= 0";
  }
  if (!(std::isfinite(t.start_limit_margin_rad) && t.start_limit_margin_rad >= 0.0)) {
    return "can.timing.start_limit_margin_rad: must be finite and >= 0";
  }

  std::array<bool, kNj> joint_seen{};
  std::set<int> drive_ids;
  std::set<std::string> names, interfaces;
  for (std::size_t bi = 0; bi < c.buses.size(); ++bi) {
    const BusConfig& b = c.buses[bi];
    const std::string where = "can.buses[" + std::to_string(bi) + "]";
    if (b.name.empty()) return where + ".name: empty";
    if (!names.insert(b.name).second) return where + ".name: '" + b.name + "' used twice";
    if (b.interface.empty() || b.interface.size() >= 16) return where + ".interface: must be 1..15 characters";
    if (!valid_interface_name(b.interface)) {
      return where + ".interface: '" + b.interface + "' is not a Linux interface name (printable, no '/', ':' or space)";
    }
    if (!interfaces.insert(b.interface).second) return where + ".interface: '" + b.interface + "' used twice";
    if (b.bitrate == 0) return where + ".bitrate: must be > 0";
    if (b.fd && b.data_bitrate < b.bitrate) return where + ".data_bitrate: an FD bus needs data_bitrate >= bitrate";
    const bool carries_sensor = (c.sensors.imu.enabled && c.sensors.imu.bus == b.name) ||
                                (c.sensors.wrist_ft.enabled && c.sensors.wrist_ft.bus == b.name);
    if (b.drives.empty() && !carries_sensor) return where + ".drives: no drive or sensor on bus '" + b.name + "'";
    if (static_cast<int>(b.drives.size()) > kMaxDrivesPerBus) {
      return where + ".drives: more than " + std::to_string(kMaxDrivesPerBus) + " drives on bus '" + b.name + "'";
    }
    std::set<std::uint32_t> rx_ids;
    for (std::size_t di = 0; di < b.drives.size(); ++di) {
      const DriveConfig& d = b.drives[di];
      const std::string dw = where + ".drives[" + std::to_string(di) + "]";
      if (d.joint < 0 || d.joint >= kNj) return dw + ".joint: must name one of the " + std::to_string(kNj) + " joints";
      if (joint_seen[static_cast<std::size_t>(d.joint)]) {
        return dw + ".joint: '" + std::string(robot::kJoints[static_cast<std::size_t>(d.joint)].name) +
               "' is on more than one drive";
      }
      joint_seen[static_cast<std::size_t>(d.joint)] = true;
      if (d.drive_id < 1 || d.drive_id > cia402::kMaxNode) return dw + ".id: must be 1..127";
      if (!drive_ids.insert(d.drive_id).second) return dw + ".id: " + std::to_string(d.drive_id) + " used twice";
      if (d.protocol == Protocol::mit) {
        const mit::Ranges& r = d.mit_ranges;
        if (!ordered_finite(r.p_min_rad, r.p_max_rad)) return dw + ".mit_ranges.p: need finite min < max";
        if (!ordered_finite(r.v_min_rad_s, r.v_max_rad_s)) return dw + ".mit_ranges.v: need finite min < max";
        if (!ordered_finite(r.kp_min, r.kp_max)) return dw + ".mit_ranges.kp: need finite min < max";
        if (!ordered_finite(r.kd_min, r.kd_max)) return dw + ".mit_ranges.kd: need finite min < max";
        if (!ordered_finite(r.t_min_nm, r.t_max_nm)) return dw + ".mit_ranges.t: need finite min < max";
        if (d.mit_reply_id > kStandardIdMask) return dw + ".reply_id: must be an 11-bit id";
        // Several drives may reply on one id (CAN_MASTER's default is 0 on every drive):
        // the host matches replies on byte 0 (CAN.md 1.4). The id must not be one the
        // bus's other frames use (checked below, once every drive of the bus is known).
      } else {
        if (b.fd) return dw + ".protocol: CiA 402 on a CAN FD bus is not supported";
        if (!(std::isfinite(d.counts_per_rad) && d.counts_per_rad > 0.0)) return dw + ".counts_per_rad: must be > 0";
        if (!(std::isfinite(d.velocity_units_per_rad_s) && d.velocity_units_per_rad_s > 0.0)) {
          return dw + ".velocity_units_per_rad_s: must be > 0";
        }
        if (!(std::isfinite(d.rated_torque_nm) && d.rated_torque_nm >= 0.0)) {
          return dw + ".rated_torque_nm: must be finite and >= 0 (0 or absent: not given, the drive's 0x6076 is used)";
        }
        if (!(std::isfinite(d.gear_ratio) && d.gear_ratio > 0.0)) return dw + ".gear_ratio: must be > 0";
        if (d.max_torque_permille > 32767) return dw + ".max_torque_permille: must be 0..32767 (0: no cap)";
        for (std::uint32_t base : {cia402::cob::tpdo1, cia402::cob::tpdo2}) {
          if (!rx_ids.insert(base + d.drive_id).second) return dw + ".id: its PDO id collides on bus '" + b.name + "'";
        }
      }
    }
    // A reply id must not be a frame the bus's drives take or send otherwise: an MIT
    // drive's command id (that drive would take the reply as a command), or, on a bus
    // with CiA 402 nodes, a CANopen id (id 0 is NMT: a reply there commands every node).
    for (std::size_t di = 0; di < b.drives.size(); ++di) {
      const DriveConfig& d = b.drives[di];
      if (d.protocol != Protocol::mit) continue;
      const std::string dw = where + ".drives[" + std::to_string(di) + "]";
      for (const DriveConfig& other : b.drives) {
        if (other.protocol == Protocol::mit && d.mit_reply_id == other.drive_id) {
          return dw + ".reply_id: " + std::to_string(d.mit_reply_id) + " is the command id of drive " +
                 std::to_string(other.drive_id) + " on bus '" + b.name + "'";
        }
      }
      std::string why;
      if (bus_id_collides(b, d.mit_reply_id, why, false)) {
        return dw + ".reply_id: " + std::to_string(d.mit_reply_id) + " collides with " + why + " on bus '" + b.name + "'";
      }
    }
  }
  for (int j = 0; j < kNj; ++j) {
    if (!joint_seen[static_cast<std::size_t>(j)]) {
      return "can.buses: joint '" + std::string(robot::kJoints[static_cast<std::size_t>(j)].name) + "' has no drive";
    }
  }
  if (std::string e = validate_sensors(c); !e.empty()) return e;
  return validate_start_pose(c);
}

}  // namespace springbok::can
