// The injected clocks of the executive. Both model the same concept:
//
//   std::int64_t now_ns() noexcept;                    // monotonic time [ns]
//   void sleep_until_ns(std::int64_t t_ns) noexcept;   // absolute deadline
//
// MonotonicClock runs on hardware: CLOCK_MONOTONIC with clock_nanosleep
// (TIMER_ABSTIME), so the wake-up time does not depend on when the sleep was
// called and the schedule cannot drift. SteppedClock runs in simulation and in
// timing tests: sleeping jumps to the deadline (plus an injectable wake-up
// latency), and compute time is injected by advancing it, so every timing
// behaviour is exact and deterministic.
#pragma once

#include <concepts>
#include <cstdint>

namespace springbok::rt {

inline constexpr std::int64_t kNsPerS = 1'000'000'000;
inline constexpr std::int64_t kNsPerUs = 1'000;

template <class C>
concept Clock = requires(C& c, std::int64_t t_ns) {
  { c.now_ns() } noexcept -> std::same_as<std::int64_t>;
  { c.sleep_until_ns(t_ns) } noexcept;
};

class MonotonicClock final {
 public:
  // rt: no alloc, no block (vDSO clock_gettime)
  std::int64_t now_ns() noexcept;
  // rt: sleeps to an absolute CLOCK_MONOTONIC deadline, retrying on EINTR
  void sleep_until_ns(std::int64_t t_ns) noexcept;
};

class SteppedClock final {
 public:
  explicit SteppedClock(std::int64_t start_ns = 0) noexcept : now_ns_(start_ns) {}

  std::int64_t now_ns() noexcept { return now_ns_; }
  // Sleeping wakes exactly at the deadline plus the injected wake-up latency;
  // a deadline already past returns at once (time never goes backwards).
  void sleep_until_ns(std::int64_t t_ns) noexcept {
    if (t_ns + wake_latency_ns_ > now_ns_) now_ns_ = t_ns + wake_latency_ns_;
  }
  // Compute time: whatever runs "takes" dt_ns.
  void advance_ns(std::int64_t dt_ns) noexcept { now_ns_ += dt_ns; }
  void set_wake_latency_ns(std::int64_t latency_ns) noexcept { wake_latency_ns_ = latency_ns; }

 private:
  std::int64_t now_ns_;
  std::int64_t wake_latency_ns_ = 0;
};

static_assert(Clock<MonotonicClock>);
static_assert(Clock<SteppedClock>);

}  // namespace springbok::rt
