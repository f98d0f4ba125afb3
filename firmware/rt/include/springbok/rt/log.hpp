// Logging from the RT thread: fixed-size records pushed into a lock-free
// ring, drained by a normal-priority thread that formats and writes them.
// The RT side never blocks; a full ring drops the record and counts it (gaps
// show as missing tick indexes).
#pragma once

#include <atomic>
#include <cstdint>
#include <cstdio>
#include <memory>
#include <string>
#include <thread>

#include "springbok/rt/spsc_ring.hpp"

namespace springbok::rt {

enum class LogEvent : std::uint16_t {
  overrun = 1,           // a: skipped ticks, b: late [ns]
  mode_change = 2,       // a: old mode, b: new mode
  fault_latched = 3,     // a: new fault bits, b: all latched bits
  command_accepted = 4,  // a: command kind, b: request id
  command_rejected = 5,  // a: command kind, b: reason code
  hal_io = 6,            // a: IoStatus, b: consecutive stale ticks
  stats = 7,             // a: ticks, b: overruns, x: max wake latency [us]
  joint_limit = 8,       // a: joint index, b: mode when latched, x: joint position [rad]
  sensors_lost = 9,      // a: the needed sensors lost now (fault bits imu_lost, wrist_ft_lost; 0: back), b: mode
  controller_request = 10,          // a: request kind (0 gait, 1 tare), b: gait (0 stand, 1 trot), x: f_s [Hz]
  controller_request_refused = 11,  // as controller_request
  buses_degraded = 12,   // a: the buses degraded now (bit b: the HAL's bus b; 0: none), b: those before
  bus_voltage_low = 13,  // a: the drives whose supply is below the warning now (bit j: joint j), b: those
                         // before, x: the lowest reported supply [V]
};

const char* to_string(LogEvent event) noexcept;

struct LogRecord {
  std::uint64_t tick = 0;
  std::int64_t stamp_ns = 0;
  LogEvent event = LogEvent::stats;
  std::int64_t a = 0;
  std::int64_t b = 0;
  double x = 0.0;
};

// 1 s at 1 kHz with up to 4 records per tick: the drainer's worst stall.
using LogRing = SpscRing<LogRecord, 4096>;

// The non-RT thread that empties a LogRing into a FILE every period and
// reports drops. Start-up code (allocates); never runs on the tick path.
class LogDrainer {
 public:
  // `describe` (may be null) gives a record's words ("imu_lost") appended to its line.
  using Describe = std::string (*)(const LogRecord&);
  LogDrainer(LogRing& ring, std::FILE* out, std::int64_t period_ms = 10, Describe describe = nullptr);
  ~LogDrainer();
  LogDrainer(const LogDrainer&) = delete;
  LogDrainer& operator=(const LogDrainer&) = delete;

  // Stops the thread after a final drain. Safe to call more than once.
  void stop();
  std::uint64_t written() const noexcept { return written_.load(std::memory_order_relaxed); }

 private:
  void run();
  std::size_t drain_once();

  LogRing& ring_;
  std::FILE* out_;
  std::int64_t period_ms_;
  Describe describe_;
  std::uint64_t reported_drops_ = 0;
  std::atomic<bool> stop_{false};
  std::atomic<std::uint64_t> written_{0};
  std::thread thread_;
};

}  // namespace springbok::rt
