#include "springbok/rt/log.hpp"

#include <chrono>

namespace springbok::rt {

const char* to_string(LogEvent event) noexcept {
  switch (event) {
    case LogEvent::overrun: return "overrun";
    case LogEvent::mode_change: return "mode_change";
    case LogEvent::fault_latched: return "fault_latched";
    case LogEvent::command_accepted: return "command_accepted";
    case LogEvent::command_rejected: return "command_rejected";
    case LogEvent::hal_io: return "hal_io";
    case LogEvent::stats: return "stats";
    case LogEvent::joint_limit: return "joint_limit";
    case LogEvent::sensors_lost: return "sensors_lost";
    case LogEvent::controller_request: return "controller_request";
    case LogEvent::controller_request_refused: return "controller_request_refused";
    case LogEvent::buses_degraded: return "buses_degraded";
    case LogEvent::bus_voltage_low: return "bus_voltage_low";
  }
  return "unknown";
}

LogDrainer::LogDrainer(LogRing& ring, std::FILE* out, std::int64_t period_ms, Describe describe)
    : ring_(ring), out_(out), period_ms_(period_ms), describe_(describe), thread_([this] { run(); }) {}

LogDrainer::~LogDrainer() { stop(); }

void LogDrainer::stop() {
  stop_.store(true, std::memory_order_relaxed);
  if (thread_.joinable()) thread_.join();
}

std::size_t LogDrainer::drain_once() {
  std::size_t n = 0;
  LogRecord r;
  while (ring_.pop(r)) {
    std::fprintf(out_, "tick=%llu t_ns=%lld %s a=%lld b=%lld x=%.6g", static_cast<unsigned long long>(r.tick),
                 static_cast<long long>(r.stamp_ns), to_string(r.event), static_cast<long long>(r.a),
                 static_cast<long long>(r.b), r.x);
    const std::string words = describe_ != nullptr ? describe_(r) : std::string();
    if (words.empty()) {
      std::fputc('\n', out_);
    } else {
      std::fprintf(out_, " (%s)\n", words.c_str());
    }
    ++n;
  }
  const std::uint64_t drops = ring_.dropped();
  if (drops != reported_drops_) {
    std::fprintf(out_, "log: %llu records dropped so far (ring full)\n",
                 static_cast<unsigned long long>(drops));
    reported_drops_ = drops;
  }
  if (n > 0) std::fflush(out_);
  written_.fetch_add(n, std::memory_order_relaxed);
  return n;
}

void LogDrainer::run() {
  while (!stop_.load(std::memory_order_relaxed)) {
    drain_once();
    std::this_thread::sleep_for(std::chrono::milliseconds(period_ms_));
  }
  drain_once();
}

}  // namespace springbok::rt
