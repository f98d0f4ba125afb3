// The executive on the stepped clock: exact, deterministic timing (no sleeps).
#include <gtest/gtest.h>

#include <array>
#include <memory>
#include <utility>
#include <vector>

#include "alloc_trap.hpp"
#include "springbok/rt/executive.hpp"

namespace springbok::rt {
namespace {

constexpr std::int64_t kPeriod = 1'000'000;  // 1 kHz

// A body whose compute time follows a script: tick i takes compute_ns[i % n].
struct ScriptedBody {
  ScriptedBody(SteppedClock& c, std::vector<std::int64_t> script) : clock(c), compute_ns(std::move(script)) {}
  SteppedClock& clock;
  std::vector<std::int64_t> compute_ns;
  std::vector<TickInfo> seen;
  std::uint64_t calls = 0;
  std::int64_t last_wake_ns = 0;
  bool record = true;

  void tick(const TickInfo& info) noexcept {
    if (record) seen.push_back(info);  // only outside the allocation trap
    last_wake_ns = info.wake_ns;
    clock.advance_ns(compute_ns[calls % compute_ns.size()]);
    ++calls;
  }
};

TEST(Executive, NoDriftOverAMillionTicks) {
  SteppedClock clock(123'456);
  clock.set_wake_latency_ns(17'000);
  ScriptedBody body{clock, {300'000, 650'000, 10'000}};
  body.record = false;
  auto exec = std::make_unique<Executive<SteppedClock, ScriptedBody>>(clock, body, kPeriod);
  exec->start();
  const std::int64_t first_ns = 123'456 + kPeriod;
  constexpr std::uint64_t kTicks = 1'000'000;
  exec->run_ticks(kTicks);

  // Oracle: the k-th tick wakes at first + k * period + latency, exactly.
  EXPECT_EQ(body.last_wake_ns, first_ns + static_cast<std::int64_t>(kTicks - 1) * kPeriod + 17'000);
  EXPECT_EQ(exec->stats().ticks, kTicks);
  EXPECT_EQ(exec->stats().overruns, 0u);
  EXPECT_EQ(exec->stats().wake_latency.min_ns(), 17'000);
  EXPECT_EQ(exec->stats().wake_latency.max_ns(), 17'000);
  EXPECT_EQ(exec->stats().compute.max_ns(), 650'000);
  EXPECT_EQ(exec->stats().compute.min_ns(), 10'000);
  EXPECT_NEAR(exec->stats().compute.mean_ns(), (300'000 + 650'000 + 10'000) / 3.0, 1.0);
}

TEST(Executive, OverrunsAreCountedAndSkippedNeverBurst) {
  SteppedClock clock(0);
  //             tick0   tick1      tick(3)    tick(5)  tick(6)  tick(7)
  ScriptedBody body{clock, {200'000, 1'500'000, 2'000'000, 300'000, 999'999, 100'000}};
  LogRing log;
  auto exec = std::make_unique<Executive<SteppedClock, ScriptedBody>>(clock, body, kPeriod, &log);
  exec->start();
  exec->run_ticks(6);

  const std::array<std::uint64_t, 6> want_index{0, 1, 3, 5, 6, 7};
  const std::array<std::uint32_t, 6> want_streak{0, 0, 1, 2, 0, 0};
  ASSERT_EQ(body.seen.size(), 6u);
  for (std::size_t i = 0; i < 6; ++i) {
    const TickInfo& t = body.seen[i];
    EXPECT_EQ(t.index, want_index[i]) << i;
    EXPECT_EQ(t.scheduled_ns, kPeriod + static_cast<std::int64_t>(want_index[i]) * kPeriod) << "on the grid";
    EXPECT_EQ(t.overrun_streak, want_streak[i]) << i;
    if (i > 0) {
      const TickInfo& prev = body.seen[i - 1];
      EXPECT_EQ(t.elapsed_ns, t.scheduled_ns - prev.scheduled_ns) << "true elapsed time";
      EXPECT_GE(t.scheduled_ns - prev.scheduled_ns, kPeriod) << "never a burst of catch-up ticks";
      EXPECT_GE(t.wake_ns, prev.wake_ns + body.compute_ns[i - 1]) << "starts after the late tick ended";
    }
  }
  EXPECT_EQ(exec->stats().overruns, 2u);
  EXPECT_EQ(exec->stats().skipped_ticks, 2u);
  EXPECT_EQ(exec->stats().max_overrun_streak, 2u);
  EXPECT_EQ(exec->stats().skipped_per_overrun.bin_count(1), 2u);
  EXPECT_EQ(exec->published().overruns.load(), 2u);

  // Each overrun went to the log ring with its skipped ticks and lateness.
  LogRecord r;
  ASSERT_TRUE(log.pop(r));
  EXPECT_EQ(r.event, LogEvent::overrun);
  EXPECT_EQ(r.tick, 1u);
  EXPECT_EQ(r.a, 1);
  EXPECT_EQ(r.b, 500'000);
  ASSERT_TRUE(log.pop(r));
  EXPECT_EQ(r.tick, 3u);
  EXPECT_EQ(r.b, 1'000'000);
  EXPECT_FALSE(log.pop(r));
}

TEST(Executive, WakeLatencyAndComputeGoToTheHistograms) {
  SteppedClock clock(0);
  clock.set_wake_latency_ns(42'500);
  ScriptedBody body{clock, {100'000, 300'000}};
  body.record = false;
  auto exec = std::make_unique<Executive<SteppedClock, ScriptedBody>>(clock, body, kPeriod);
  exec->start();
  exec->run_ticks(1000);
  const auto& s = exec->stats();
  EXPECT_EQ(s.wake_latency.count(), 1000u);
  EXPECT_EQ(s.wake_latency.bin_count(42), 1000u);  // 1 us bins: 42.5 us lands in bin 42
  EXPECT_EQ(s.compute.bin_count(100), 500u);
  EXPECT_EQ(s.compute.bin_count(300), 500u);
  EXPECT_EQ(s.compute.quantile_ns(0.5), 101'000);
  EXPECT_EQ(s.compute.quantile_ns(0.99), 300'000);  // capped at the exact max
  exec->reset_stats();
  EXPECT_EQ(exec->stats().ticks, 0u);
  EXPECT_EQ(exec->stats().wake_latency.count(), 0u);
}

TEST(Executive, OverrunWindowCountsPerSecond) {
  SteppedClock clock(0);
  // every other tick overruns by a little: 1.2 ms compute then 0.1 ms
  ScriptedBody body{clock, {1'200'000, 100'000}};
  body.record = true;
  auto exec = std::make_unique<Executive<SteppedClock, ScriptedBody>>(clock, body, kPeriod);
  exec->start();
  exec->run_ticks(10);
  // ticks at grid 0,2,3,5,6,8,... each overrun skips one; streak never exceeds 1
  std::uint32_t max_window = 0;
  for (const auto& t : body.seen) {
    EXPECT_LE(t.overrun_streak, 1u);
    max_window = std::max(max_window, t.overruns_in_window);
  }
  EXPECT_EQ(max_window, 5u);  // calls 0,2,4,6,8 overran before the 10th call
  EXPECT_EQ(exec->stats().overruns, 5u);
}

TEST(Executive, ATickAllocatesNothing) {
  SteppedClock clock(0);
  ScriptedBody body{clock, {250'000, 1'700'000}};
  body.record = false;
  LogRing log;
  auto exec = std::make_unique<Executive<SteppedClock, ScriptedBody>>(clock, body, kPeriod, &log);
  exec->start();
  exec->run_ticks(10);
  test::AllocationTrap trap;
  exec->run_ticks(1000);
  EXPECT_EQ(trap.disarm(), 0u);
  EXPECT_EQ(exec->stats().ticks, 1010u);
}

}  // namespace
}  // namespace springbok::rt
