// The fixed-rate executive: sleeps to an absolute grid on an injected clock,
// runs one tick of its body, and accounts wake-up latency, compute time and
// overruns (skip policy, see tick_schedule.hpp) in fixed-size histograms.
//
// The body is any type with `void tick(const TickInfo&) noexcept` (the app's
// loop: HAL read -> controller -> safety -> HAL write); it is held by
// reference and called directly: no virtual call, no std::function.
#pragma once

#include <atomic>
#include <cstdint>

#include "springbok/rt/clock.hpp"
#include "springbok/rt/histogram.hpp"
#include "springbok/rt/log.hpp"
#include "springbok/rt/tick_schedule.hpp"

namespace springbok::rt {

struct TickInfo {
  std::uint64_t index = 0;            // grid index (skipped grid points count)
  std::int64_t scheduled_ns = 0;      // the grid point of this tick
  std::int64_t wake_ns = 0;           // when the thread woke
  std::int64_t wake_latency_ns = 0;   // wake - scheduled
  std::int64_t elapsed_ns = 0;        // scheduled time since the previous tick (true dt)
  std::uint32_t overrun_streak = 0;   // consecutive overruns ending with the previous tick
  std::uint32_t overruns_in_window = 0;  // overruns in the current 1 s window
  std::int64_t previous_compute_ns = 0;  // the previous tick's body, wake to end (telemetry)
};

template <class B>
concept TickBody = requires(B& body, const TickInfo& info) {
  { body.tick(info) } noexcept;
};

using DurationHistogram = Histogram<10'000>;  // 1 us bins up to 10 ms, then overflow

struct ExecutiveStats {
  DurationHistogram wake_latency{1'000};
  DurationHistogram compute{1'000};
  Histogram<64> skipped_per_overrun{1};  // one bin per skipped-tick count
  std::uint64_t ticks = 0;
  std::uint64_t overruns = 0;
  std::uint64_t skipped_ticks = 0;
  std::uint32_t max_overrun_streak = 0;
};

// Counters another thread may read while the loop runs (status replies).
struct PublishedStats {
  std::atomic<std::uint64_t> ticks{0};
  std::atomic<std::uint64_t> overruns{0};
  std::atomic<std::uint64_t> skipped_ticks{0};
  std::atomic<std::int64_t> max_wake_latency_ns{0};
  std::atomic<std::int64_t> max_compute_ns{0};
};

template <Clock C, TickBody B>
class Executive {
 public:
  Executive(C& clock, B& body, std::int64_t period_ns, LogRing* log = nullptr) noexcept
      : clock_(clock), body_(body), log_(log), schedule_(period_ns, 0) {}

  std::int64_t period_ns() const noexcept { return schedule_.period_ns(); }

  // Puts the first tick one period from now.
  void start() noexcept {
    const std::int64_t first_ns = clock_.now_ns() + schedule_.period_ns();
    schedule_ = TickSchedule(schedule_.period_ns(), first_ns);
    previous_scheduled_ns_ = first_ns - schedule_.period_ns();
    window_start_ns_ = first_ns;
    streak_ = 0;
    overruns_in_window_ = 0;
  }

  // One tick: sleep to the grid, run the body, account. rt: no alloc
  void run_tick() noexcept {
    const std::int64_t scheduled_ns = schedule_.next_ns();
    clock_.sleep_until_ns(scheduled_ns);
    const std::int64_t wake_ns = clock_.now_ns();

    if (scheduled_ns - window_start_ns_ >= kNsPerS) {
      window_start_ns_ = scheduled_ns;
      overruns_in_window_ = 0;
    }
    TickInfo info;
    info.index = schedule_.next_index();
    info.scheduled_ns = scheduled_ns;
    info.wake_ns = wake_ns;
    info.wake_latency_ns = wake_ns - scheduled_ns;
    info.elapsed_ns = scheduled_ns - previous_scheduled_ns_;
    info.overrun_streak = streak_;
    info.overruns_in_window = overruns_in_window_;
    info.previous_compute_ns = previous_compute_ns_;
    previous_scheduled_ns_ = scheduled_ns;

    body_.tick(info);

    const std::int64_t end_ns = clock_.now_ns();
    const TickEnd end = schedule_.finish_tick(end_ns);
    previous_compute_ns_ = end_ns - wake_ns;
    account(info, end_ns - wake_ns, end);
  }

  void run_ticks(std::uint64_t n) noexcept {
    for (std::uint64_t i = 0; i < n; ++i) run_tick();
  }

  void run_until(const std::atomic<bool>& stop) noexcept {
    while (!stop.load(std::memory_order_relaxed)) run_tick();
  }

  const ExecutiveStats& stats() const noexcept { return stats_; }
  const PublishedStats& published() const noexcept { return published_; }
  // Drops what the warm-up ticks recorded (RT.md step 8).
  void reset_stats() noexcept {
    stats_.wake_latency.reset();
    stats_.compute.reset();
    stats_.skipped_per_overrun.reset();
    stats_.ticks = stats_.overruns = stats_.skipped_ticks = 0;
    stats_.max_overrun_streak = 0;
  }

 private:
  void account(const TickInfo& info, std::int64_t compute_ns, const TickEnd& end) noexcept {
    stats_.wake_latency.add(info.wake_latency_ns);
    stats_.compute.add(compute_ns);
    ++stats_.ticks;
    if (end.overrun) {
      ++stats_.overruns;
      ++overruns_in_window_;
      stats_.skipped_ticks += end.skipped_ticks;
      stats_.skipped_per_overrun.add(static_cast<std::int64_t>(end.skipped_ticks));
      ++streak_;
      if (streak_ > stats_.max_overrun_streak) stats_.max_overrun_streak = streak_;
      if (log_ != nullptr) {
        log_->push(LogRecord{info.index, info.scheduled_ns, LogEvent::overrun,
                             static_cast<std::int64_t>(end.skipped_ticks), end.late_ns, 0.0});
      }
    } else {
      streak_ = 0;
    }
    published_.ticks.store(stats_.ticks, std::memory_order_relaxed);
    published_.overruns.store(stats_.overruns, std::memory_order_relaxed);
    published_.skipped_ticks.store(stats_.skipped_ticks, std::memory_order_relaxed);
    published_.max_wake_latency_ns.store(stats_.wake_latency.max_ns(), std::memory_order_relaxed);
    published_.max_compute_ns.store(stats_.compute.max_ns(), std::memory_order_relaxed);
  }

  C& clock_;
  B& body_;
  LogRing* log_;
  TickSchedule schedule_;
  std::int64_t previous_scheduled_ns_ = 0;
  std::int64_t previous_compute_ns_ = 0;
  std::int64_t window_start_ns_ = 0;
  std::uint32_t streak_ = 0;
  std::uint32_t overruns_in_window_ = 0;
  ExecutiveStats stats_;
  PublishedStats published_;
};

}  // namespace springbok::rt
