// The executive's clock of the deployed binary: CLOCK_MONOTONIC slowed down by an
// integer factor (--time-scale N). Firmware time runs N times slower than wall time,
// so each tick gets N periods of wall time while every firmware quantity (the tick
// period, dt, durations, ramps, --duration) keeps its nominal value. N = 1 is the
// monotonic clock itself. For hardware-in-the-loop against a simulated robot that a
// slow host (e.g. an emulated CPU) cannot step in real time; never on a robot.
#pragma once

#include <cstdint>

#include "springbok/rt/clock.hpp"

namespace springbok::app {

inline constexpr std::int64_t kMaxTimeScale = 1000;

class SlowedClock final {
 public:
  explicit SlowedClock(std::int64_t scale) noexcept : scale_(scale < 1 ? 1 : scale), origin_ns_(wall_.now_ns()) {}

  // rt: no alloc, no block
  std::int64_t now_ns() noexcept { return origin_ns_ + (wall_.now_ns() - origin_ns_) / scale_; }
  // rt: sleeps to the wall time of the firmware deadline t_ns
  void sleep_until_ns(std::int64_t t_ns) noexcept { wall_.sleep_until_ns(origin_ns_ + (t_ns - origin_ns_) * scale_); }
  std::int64_t scale() const noexcept { return scale_; }

 private:
  rt::MonotonicClock wall_;
  std::int64_t scale_;
  std::int64_t origin_ns_;
};

static_assert(rt::Clock<SlowedClock>);

}  // namespace springbok::app
