// The flight recorder: the last `seconds` of the loop's state at full rate (a TelemetryRecord
// every tick: what telemetry carries) in a fixed RAM ring, written to a CSV file (PlotJuggler
// opens it; the columns are telemetry's fields) when a fault latches, when the program stops,
// and on the operator's `dump`. The ring is written by the RT thread (a copy per tick, no
// allocation, no lock: each slot is a seqlock), the file by the recorder's own thread, which
// copies the ring out first: a tick being written while it copies is left out, never torn.
//
// Config (`recorder:`, every key optional): enabled (true), seconds (30, 1..300), dir
// (/var/log/springbok: files flight-<UTC time>-<reason>.csv, reason fault, stop or operator).
#pragma once

#include <atomic>
#include <cstdint>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "springbok/app/telemetry.hpp"

namespace springbok::yaml {
class Field;
}

namespace springbok::app {

struct RecorderConfig {
  bool enabled = true;
  double seconds = 30.0;
  std::string dir = "/var/log/springbok";
};
// The `recorder:` section; problems go to the field's errors, naming the key.
RecorderConfig read_recorder_config(const yaml::Field& section);

enum class DumpReason : std::uint8_t { none = 0, fault = 1, stop = 2, operator_request = 3 };
const char* to_string(DumpReason reason) noexcept;

class FlightRecorder {
 public:
  // Start-up: the ring of `capacity` records and the writer's copy of it.
  explicit FlightRecorder(std::size_t capacity, std::string dir);
  ~FlightRecorder();
  FlightRecorder(const FlightRecorder&) = delete;
  FlightRecorder& operator=(const FlightRecorder&) = delete;

  // The RT thread, every tick. rt: no alloc, no block
  void record(const TelemetryRecord& r) noexcept;
  // Any thread: a file at the writer's next look (every 20 ms); a request while one is
  // pending is merged into it. rt: no alloc, no block
  void request(DumpReason reason) noexcept;

  // The writer thread (start-up, shut-down).
  void start();
  void stop();
  // Writes the ring now, in the caller's thread (the stop's file): its path, or "" and `error`.
  std::string write(DumpReason reason, std::string& error);

  // The request the writer has not taken yet (none: no file asked for).
  DumpReason pending() const noexcept { return static_cast<DumpReason>(pending_.load(std::memory_order_acquire)); }
  std::size_t capacity() const noexcept { return slots_.size(); }
  std::uint64_t recorded() const noexcept { return head_.load(std::memory_order_relaxed); }
  std::uint64_t files() const noexcept { return files_.load(std::memory_order_relaxed); }
  // The last file written ("" before the first) and the time its writing took.
  std::string last_file() const;
  double last_write_s() const noexcept { return last_write_s_.load(std::memory_order_relaxed); }

 private:
  struct Slot {
    std::atomic<std::uint64_t> sequence{0};  // 2k+1 while tick k is written, 2k+2 when it is whole
    TelemetryRecord record;
  };
  // The newest run of consecutive whole records, oldest first, into copy_ (the writer's). Returns
  // their number.
  std::size_t snapshot();
  void run();

  std::vector<Slot> slots_;
  std::vector<TelemetryRecord> copy_;
  std::string dir_;
  std::atomic<std::uint64_t> head_{0};  // records written
  std::atomic<std::uint8_t> pending_{0};  // DumpReason
  std::atomic<std::uint64_t> files_{0};
  std::atomic<double> last_write_s_{0.0};
  mutable std::mutex write_mutex_;  // one write at a time (the writer thread, write())
  std::string last_file_;
  std::thread thread_;
  std::atomic<bool> stop_{false};
};

}  // namespace springbok::app
