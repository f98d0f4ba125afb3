// Live telemetry: the controller's state as UDP datagrams that PlotJuggler's "UDP
// Server" (JSON protocol) plots directly: one flat JSON object per datagram, a
// `timestamp` in seconds (the firmware clock), numeric fields with units in their
// names. The RT thread fills a fixed-size record every `every_ticks` ticks and
// pushes it into a lock-free ring (never blocks: a full ring drops the record and
// counts it); a non-RT thread formats and sends what the ring holds.
//
// Config (`telemetry:`, every key optional): enabled (true), rate_hz (100, 1..1000:
// a divisor of the loop rate is sent exactly, other rates round to the nearest whole
// number of ticks), address (127.0.0.1, an IPv4 address), port (9870, PlotJuggler's
// default).
#pragma once

#include <array>
#include <atomic>
#include <cstdint>
#include <string>
#include <thread>

#include "springbok/model/model.hpp"
#include "springbok/rt/spsc_ring.hpp"

namespace springbok::yaml {
class Field;
}

namespace springbok::app {

struct TelemetryConfig {
  bool enabled = true;
  double rate_hz = 100.0;
  std::string address = "127.0.0.1";
  int port = 9870;
};
// The `telemetry:` section; problems go to the field's errors, naming the key.
TelemetryConfig read_telemetry_config(const yaml::Field& section);
// Ticks between two records at the loop's rate (>= 1).
std::uint32_t telemetry_every_ticks(const TelemetryConfig& config, int loop_rate_hz) noexcept;

using Triple = std::array<double, 3>;

// One sample, trivially copyable (the ring copies it by value). World axes.
struct TelemetryRecord {
  double timestamp_s = 0.0;          // firmware clock: the tick's scheduled time
  std::uint64_t tick = 0;
  std::uint8_t mode = 0;             // safety::Mode
  std::uint32_t faults = 0;          // safety::FaultMask
  double compute_us = 0.0;           // the previous tick's compute time
  double wake_latency_us = 0.0;
  // The controller's (zero where the control mode's controller is the joint PD).
  bool wbc = false;
  bool engaged = false;              // the whole-body controller runs (control mode)
  std::uint8_t tick_status = 0;      // control::TickStatus of its last tick
  std::uint8_t qp_status = 0;        // qp::Status
  std::int32_t qp_iterations = 0;
  bool arm_overloaded = false;       // the arm yields to a push it cannot hold (wbc::WbcOutput)
  bool support_limited = false;      // the base held back from its support's edge (wbc::WbcOutput)
  bool stepping_for_push = false;    // trotting to catch a push standing could not hold (control::PushStepping)
  Triple base_position_m{};          // estimated
  std::array<double, 4> base_quaternion_xyzw{0.0, 0.0, 0.0, 1.0};
  Triple base_rpy_rad{};
  Triple base_velocity_m_s{};
  Triple base_rate_rad_s{};
  Triple hand_position_m{};
  std::array<double, 4> hand_quaternion_xyzw{0.0, 0.0, 0.0, 1.0};
  Triple base_rest_m{};              // the template's rest pose (its reference)
  Triple hand_rest_m{};
  std::array<double, 4> hand_rest_quaternion_xyzw{0.0, 0.0, 0.0, 1.0};  // the rest orientation
  Triple base_displacement_m{};      // x_b, x_e: what the template renders
  Triple hand_displacement_m{};
  Triple external_force_n{};         // F_e, from the tared wrist F/T
  Triple external_torque_nm{};       // T_e (about the hand's origin)
  Triple unmeasured_force_n{};       // pushes the wrist does not measure (wbc::WbcInput)
  std::array<Triple, kFeet> foot_force_n{};  // the QP's ground forces
  std::array<bool, kFeet> stance{};
  std::array<double, kNj> q_rad{};
  std::array<double, kNj> qd_rad_s{};
  std::array<double, kNj> tau_nm{};  // measured
  std::array<double, kNj> bus_voltage_v{};  // each drive's supply where it reports it (0: it does not)
};
using TelemetryRing = rt::SpscRing<TelemetryRecord, 256>;

// The record as one flat JSON object (the datagram's payload): `timestamp` first, then
// `"name":number` pairs; a non-finite value leaves its field out, a non-finite timestamp
// the whole datagram ("": counted as a send error). Fuzzed: tests/fuzz/fuzz_telemetry.cpp.
std::string telemetry_json(const TelemetryRecord& record);

// The same fields as CSV (the flight recorder's files): a header line of their names, and
// one row per record, every field in every row (a non-finite value as "nan").
std::string telemetry_csv_header();
void append_telemetry_csv_row(std::string& out, const TelemetryRecord& record);

// The non-RT sender: drains the ring, one datagram per record.
class TelemetrySender {
 public:
  TelemetrySender() = default;
  ~TelemetrySender();
  TelemetrySender(const TelemetrySender&) = delete;
  TelemetrySender& operator=(const TelemetrySender&) = delete;

  // Opens the UDP socket to address:port; "" or why not (start-up).
  std::string open(const TelemetryConfig& config);
  void start(TelemetryRing& ring);
  // Sends what is left, then stops the thread.
  void stop();

  std::uint64_t sent() const noexcept { return sent_.load(std::memory_order_relaxed); }
  std::uint64_t send_errors() const noexcept { return send_errors_.load(std::memory_order_relaxed); }

 private:
  void drain(TelemetryRing& ring);

  int fd_ = -1;
  std::thread thread_;
  std::atomic<bool> stop_{false};
  std::atomic<std::uint64_t> sent_{0};
  std::atomic<std::uint64_t> send_errors_{0};
  TelemetryRing* ring_ = nullptr;
};

}  // namespace springbok::app
