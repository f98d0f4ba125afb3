// The absolute tick grid and the overrun (skip) policy, as pure arithmetic.
//
// Tick k is scheduled at start_ns + k * period_ns. Its deadline is the next
// grid point. A tick that ends past its deadline is an overrun: the ticks
// whose grid points it ran over are skipped (never run back to back) and the
// next tick starts on the first grid point at or after the end.
#pragma once

#include <cstdint>

namespace springbok::rt {

struct TickEnd {
  bool overrun = false;           // ended past its deadline
  std::int64_t late_ns = 0;       // end - deadline when overrun, else 0
  std::uint64_t skipped_ticks = 0;  // grid points skipped because of it
};

class TickSchedule {
 public:
  TickSchedule(std::int64_t period_ns, std::int64_t start_ns) noexcept
      : period_ns_(period_ns), next_ns_(start_ns) {}

  std::int64_t period_ns() const noexcept { return period_ns_; }
  // The grid point the coming tick is scheduled at.
  std::int64_t next_ns() const noexcept { return next_ns_; }
  // Grid index of the coming tick (counts skipped grid points too).
  std::uint64_t next_index() const noexcept { return next_index_; }

  // Accounts the tick scheduled at next_ns() that ended at end_ns and moves
  // to the next tick's grid point. rt: no alloc
  TickEnd finish_tick(std::int64_t end_ns) noexcept {
    TickEnd result;
    const std::int64_t deadline_ns = next_ns_ + period_ns_;
    std::uint64_t advance = 1;
    if (end_ns > deadline_ns) {
      // first grid point at or after end_ns: ceil((end - next) / period) periods on
      const std::int64_t span_ns = end_ns - next_ns_;
      advance = static_cast<std::uint64_t>((span_ns + period_ns_ - 1) / period_ns_);
      result.overrun = true;
      result.late_ns = end_ns - deadline_ns;
      result.skipped_ticks = advance - 1;
    }
    next_ns_ += static_cast<std::int64_t>(advance) * period_ns_;
    next_index_ += advance;
    return result;
  }

 private:
  std::int64_t period_ns_;
  std::int64_t next_ns_;
  std::uint64_t next_index_ = 0;
};

}  // namespace springbok::rt
