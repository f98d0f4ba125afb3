// The start-up recipe's observable behaviour: the thread runs its body, the
// report says what happened, and --require-rt refuses where it must.
#include <gtest/gtest.h>
#include <sched.h>

#include <atomic>

#include "springbok/rt/clock.hpp"
#include "springbok/rt/realtime.hpp"

namespace springbok::rt {
namespace {

TEST(RtThread, RunsItsBodyWithRtDisabled) {
  RtConfig config;
  config.enabled = false;
  RtReport report;
  std::atomic<int> policy{-1};
  auto body = [&] { policy = sched_getscheduler(0); };
  RtThread thread;
  ASSERT_TRUE(thread.start(config, body, report));
  thread.join();
  EXPECT_EQ(policy.load(), SCHED_OTHER);
  EXPECT_FALSE(report.fifo);
  EXPECT_TRUE(report.refusal.empty());
}

TEST(RtThread, FifoWhenPrivilegedElseAWarning) {
  RtConfig config;
  config.priority = 10;
  RtReport report;
  std::atomic<int> policy{-1};
  std::atomic<int> priority{-1};
  auto body = [&] {
    sched_param p{};
    int pol = 0;
    pthread_getschedparam(pthread_self(), &pol, &p);
    policy = pol;
    priority = p.sched_priority;
  };
  RtThread thread;
  ASSERT_TRUE(thread.start(config, body, report));
  thread.join();
  if (report.fifo) {
    EXPECT_EQ(policy.load(), SCHED_FIFO);
    EXPECT_EQ(priority.load(), 10);
  } else {
    EXPECT_EQ(policy.load(), SCHED_OTHER);
    ASSERT_FALSE(report.warnings.empty());
    EXPECT_NE(report.warnings.back().find("SCHED_FIFO 10"), std::string::npos);
  }
}

TEST(RtProcess, RequireRefusesOnANonRtKernel) {
  RtConfig config;
  config.require = true;
  config.lock_memory = false;
  config.prefault_heap_bytes = 0;
  config.hold_cpu_dma_latency = false;
  RtReport report;
  RtProcess process(config, report);
  if (preempt_rt_kernel()) {
    EXPECT_TRUE(report.refusal.empty());
  } else {
    EXPECT_EQ(report.refusal, "not a PREEMPT_RT kernel");
  }
}

TEST(RtProcess, DisabledWithRequireRefuses) {
  RtConfig config;
  config.enabled = false;
  config.require = true;
  RtReport report;
  RtProcess process(config, report);
  EXPECT_FALSE(report.refusal.empty());
}

TEST(MonotonicClock, SleepsToAnAbsoluteDeadline) {
  MonotonicClock clock;
  const std::int64_t deadline = clock.now_ns() + 2'000'000;
  clock.sleep_until_ns(deadline);
  EXPECT_GE(clock.now_ns(), deadline);  // never wakes early (the lateness is measured, not asserted)
  const std::int64_t past = clock.now_ns() - 1'000'000;
  clock.sleep_until_ns(past);  // a deadline in the past returns at once
  EXPECT_GE(clock.now_ns(), past);
}

}  // namespace
}  // namespace springbok::rt
