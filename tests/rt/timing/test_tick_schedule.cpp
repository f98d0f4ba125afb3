// The absolute grid and the skip policy as arithmetic (no clock at all).
#include <gtest/gtest.h>

#include "springbok/rt/tick_schedule.hpp"

namespace springbok::rt {
namespace {

constexpr std::int64_t kPeriod = 1'000'000;  // 1 ms

TEST(TickSchedule, OnTimeTicksWalkTheGrid) {
  TickSchedule s(kPeriod, 5'000);
  for (int k = 0; k < 10; ++k) {
    EXPECT_EQ(s.next_ns(), 5'000 + k * kPeriod);
    EXPECT_EQ(s.next_index(), static_cast<std::uint64_t>(k));
    const TickEnd e = s.finish_tick(s.next_ns() + 400'000);
    EXPECT_FALSE(e.overrun);
    EXPECT_EQ(e.skipped_ticks, 0u);
  }
}

TEST(TickSchedule, EndingExactlyAtTheDeadlineIsNotAnOverrun) {
  TickSchedule s(kPeriod, 0);
  const TickEnd e = s.finish_tick(kPeriod);
  EXPECT_FALSE(e.overrun);
  EXPECT_EQ(s.next_ns(), kPeriod);
}

TEST(TickSchedule, OverrunSkipsToTheFirstGridPointAfterTheEnd) {
  struct Case {
    std::int64_t end_ns;
    std::uint64_t skipped;
    std::int64_t next_ns;
  };
  // tick scheduled at 0, deadline 1 ms
  const Case cases[] = {
      {kPeriod + 1, 1, 2 * kPeriod},          // just late: skip one grid point
      {1'500'000, 1, 2 * kPeriod},
      {2 * kPeriod, 1, 2 * kPeriod},          // ends on a grid point: start there
      {2 * kPeriod + 1, 2, 3 * kPeriod},
      {7'300'000, 7, 8 * kPeriod},
  };
  for (const Case& c : cases) {
    TickSchedule s(kPeriod, 0);
    const TickEnd e = s.finish_tick(c.end_ns);
    EXPECT_TRUE(e.overrun) << c.end_ns;
    EXPECT_EQ(e.late_ns, c.end_ns - kPeriod);
    EXPECT_EQ(e.skipped_ticks, c.skipped) << c.end_ns;
    EXPECT_EQ(s.next_ns(), c.next_ns) << c.end_ns;
    EXPECT_EQ(s.next_index(), c.skipped + 1) << c.end_ns;
    EXPECT_GE(s.next_ns(), c.end_ns) << "the next tick never starts before the late one ended";
  }
}

}  // namespace
}  // namespace springbok::rt
