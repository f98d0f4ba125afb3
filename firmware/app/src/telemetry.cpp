#include "springbok/app/telemetry.hpp"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cerrno>
#include <charconv>
#include <chrono>
#include <cmath>
#include <cstring>
#include <string_view>

#include "springbok/yaml/reader.hpp"

namespace springbok::app {

TelemetryConfig read_telemetry_config(const yaml::Field& f) {
  TelemetryConfig c;
  if (!f.present() || !f.allow_only({"enabled", "rate_hz", "address", "port"})) return c;
  f["enabled"].boolean(c.enabled);
  f["rate_hz"].number(c.rate_hz, 1.0, 1000.0);
  if (f["address"].text(c.address)) {
    in_addr parsed{};
    if (inet_pton(AF_INET, c.address.c_str(), &parsed) != 1) f["address"].fail("must be an IPv4 address like 127.0.0.1");
  }
  f["port"].integer(c.port, 1, 65535);
  return c;
}

std::uint32_t telemetry_every_ticks(const TelemetryConfig& config, int loop_rate_hz) noexcept {
  const double every = std::round(static_cast<double>(loop_rate_hz) / config.rate_hz);
  return every < 1.0 ? 1u : static_cast<std::uint32_t>(every);
}

namespace {

constexpr const char* kFootNames[kFeet] = {"lf", "rf", "lh", "rh"};

// Every field of a record after its timestamp, in order: field(name, value). A drive's bus
// voltage only where it reports one (> 0), unless `every_field`.
template <class Field>
void for_each_field(const TelemetryRecord& r, bool every_field, Field&& field) {
  const auto triple = [&](std::string_view name, std::string_view unit, const Triple& v) {
    static constexpr const char* kAxes[3] = {"_x_", "_y_", "_z_"};
    for (std::size_t a = 0; a < 3; ++a) field(std::string(name) + kAxes[a] + std::string(unit), v[a]);
  };
  const auto quaternion = [&](std::string_view name, const std::array<double, 4>& q) {  // <name>_qx .. _qw
    static constexpr const char* kParts[4] = {"_qx", "_qy", "_qz", "_qw"};
    for (std::size_t i = 0; i < 4; ++i) field(std::string(name) + kParts[i], q[i]);
  };
  field("tick", static_cast<double>(r.tick));
  field("mode", r.mode);
  field("faults", r.faults);
  field("compute_us", r.compute_us);
  field("wake_latency_us", r.wake_latency_us);
  field("wbc", r.wbc ? 1.0 : 0.0);
  field("engaged", r.engaged ? 1.0 : 0.0);
  field("tick_status", r.tick_status);
  field("qp_status", r.qp_status);
  field("qp_iterations", r.qp_iterations);
  field("arm_overloaded", r.arm_overloaded ? 1.0 : 0.0);
  field("support_limited", r.support_limited ? 1.0 : 0.0);
  field("stepping_for_push", r.stepping_for_push ? 1.0 : 0.0);
  triple("base", "m", r.base_position_m);
  quaternion("base", r.base_quaternion_xyzw);
  field("base_roll_rad", r.base_rpy_rad[0]);
  field("base_pitch_rad", r.base_rpy_rad[1]);
  field("base_yaw_rad", r.base_rpy_rad[2]);
  triple("base_velocity", "m_s", r.base_velocity_m_s);
  triple("base_rate", "rad_s", r.base_rate_rad_s);
  triple("hand", "m", r.hand_position_m);
  quaternion("hand", r.hand_quaternion_xyzw);
  triple("base_rest", "m", r.base_rest_m);
  triple("hand_rest", "m", r.hand_rest_m);
  quaternion("hand_rest", r.hand_rest_quaternion_xyzw);
  triple("base_displacement", "m", r.base_displacement_m);
  triple("hand_displacement", "m", r.hand_displacement_m);
  triple("fe", "n", r.external_force_n);
  triple("unmeasured", "n", r.unmeasured_force_n);
  triple("te", "nm", r.external_torque_nm);
  for (int f = 0; f < kFeet; ++f) {
    triple(std::string(kFootNames[f]) + "_force", "n", r.foot_force_n[static_cast<std::size_t>(f)]);
    field(std::string(kFootNames[f]) + "_stance", r.stance[static_cast<std::size_t>(f)] ? 1.0 : 0.0);
  }
  for (int j = 0; j < kNj; ++j) {
    const std::string name(robot::kJoints[static_cast<std::size_t>(j)].name);
    const auto i = static_cast<std::size_t>(j);
    field("q_" + name + "_rad", r.q_rad[i]);
    field("qd_" + name + "_rad_s", r.qd_rad_s[i]);
    field("tau_" + name + "_nm", r.tau_nm[i]);
    if (every_field || r.bus_voltage_v[i] > 0.0) field("bus_voltage_" + name + "_v", r.bus_voltage_v[i]);
  }
}

// 9 significant digits.
void append_number(std::string& out, double value) {
  char buf[32];
  const auto r = std::to_chars(buf, buf + sizeof buf, value, std::chars_format::general, 9);
  out.append(buf, r.ptr);
}

// The firmware clock in microseconds, fixed notation (a plain number for PlotJuggler); beyond
// 1e12 s, where that would not fit, 17 significant digits.
void append_timestamp(std::string& out, double timestamp_s) {
  char stamp[32];
  const auto end = std::abs(timestamp_s) < 1e12
                       ? std::to_chars(stamp, stamp + sizeof stamp, timestamp_s, std::chars_format::fixed, 6)
                       : std::to_chars(stamp, stamp + sizeof stamp, timestamp_s, std::chars_format::general, 17);
  out.append(stamp, end.ptr);
}

}  // namespace

std::string telemetry_json(const TelemetryRecord& r) {
  // A datagram without a time cannot be plotted: none (the firmware clock is always finite).
  if (!std::isfinite(r.timestamp_s)) return {};
  std::string out;
  out.reserve(6000);
  out += "{\"timestamp\":";
  append_timestamp(out, r.timestamp_s);
  // JSON has no NaN or infinity: such a value is left out of its datagram.
  for_each_field(r, false, [&out](std::string_view name, double value) {
    if (!std::isfinite(value)) return;
    out += ",\"";
    out += name;
    out += "\":";
    append_number(out, value);
  });
  out += '}';
  return out;
}

std::string telemetry_csv_header() {
  std::string out = "timestamp";
  for_each_field(TelemetryRecord{}, true, [&out](std::string_view name, double) {
    out += ',';
    out += name;
  });
  return out;
}

void append_telemetry_csv_row(std::string& out, const TelemetryRecord& r) {
  append_timestamp(out, r.timestamp_s);
  for_each_field(r, true, [&out](std::string_view, double value) {
    out += ',';
    append_number(out, value);
  });
  out += '\n';
}

TelemetrySender::~TelemetrySender() {
  stop();
  if (fd_ >= 0) ::close(fd_);
}

std::string TelemetrySender::open(const TelemetryConfig& config) {
  sockaddr_in to{};
  to.sin_family = AF_INET;
  to.sin_port = htons(static_cast<std::uint16_t>(config.port));
  if (inet_pton(AF_INET, config.address.c_str(), &to.sin_addr) != 1) {
    return "telemetry.address: not an IPv4 address: " + config.address;
  }
  fd_ = ::socket(AF_INET, SOCK_DGRAM | SOCK_CLOEXEC, 0);
  if (fd_ < 0) return std::string("telemetry: socket: ") + std::strerror(errno);
  // Connected: send() goes to address:port, and nothing else is read from the socket.
  if (::connect(fd_, reinterpret_cast<const sockaddr*>(&to), sizeof to) != 0) {
    const std::string why = std::strerror(errno);
    ::close(fd_);
    fd_ = -1;
    return "telemetry: connect to " + config.address + ":" + std::to_string(config.port) + ": " + why;
  }
  return "";
}

void TelemetrySender::drain(TelemetryRing& ring) {
  TelemetryRecord record;
  while (ring.pop(record)) {
    const std::string datagram = telemetry_json(record);
    if (datagram.empty()) {  // no time to plot it at
      send_errors_.fetch_add(1, std::memory_order_relaxed);
      continue;
    }
    // A refused or full send (nobody listening yet, a full buffer) is counted, never retried.
    if (::send(fd_, datagram.data(), datagram.size(), MSG_DONTWAIT) == static_cast<ssize_t>(datagram.size())) {
      sent_.fetch_add(1, std::memory_order_relaxed);
    } else {
      send_errors_.fetch_add(1, std::memory_order_relaxed);
    }
  }
}

void TelemetrySender::start(TelemetryRing& ring) {
  ring_ = &ring;
  stop_.store(false);
  thread_ = std::thread([this] {
    while (!stop_.load(std::memory_order_relaxed)) {
      drain(*ring_);
      std::this_thread::sleep_for(std::chrono::milliseconds(2));
    }
    drain(*ring_);
  });
}

void TelemetrySender::stop() {
  stop_.store(true);
  if (thread_.joinable()) thread_.join();
}

}  // namespace springbok::app
