#include <gtest/gtest.h>

#include <array>
#include <atomic>
#include <cstdint>
#include <thread>

#include "springbok/rt/latest_value.hpp"

namespace springbok::rt {
namespace {

TEST(LatestValue, NothingBeforeTheFirstPublishThenTheNewest) {
  LatestValue<int> value;
  int out = -1;
  EXPECT_FALSE(value.read(out));
  EXPECT_EQ(out, -1);
  value.publish(1);
  value.publish(2);
  ASSERT_TRUE(value.read(out));
  EXPECT_EQ(out, 2);
  ASSERT_TRUE(value.read(out));  // nothing new: the same value again
  EXPECT_EQ(out, 2);
  value.publish(3);
  ASSERT_TRUE(value.read(out));
  EXPECT_EQ(out, 3);
}

// A record whose every word is the same number: a read that mixed two publishes shows it.
struct Wide {
  std::array<std::uint64_t, 32> words{};
};

TEST(LatestValue, TwoThreadsNeverTearARecordAndNeverGoBack) {
  auto value = std::make_unique<LatestValue<Wide>>();
  // The writer publishes at least kN records and goes on until the reader has read kReads of
  // them while it wrote (on a loaded machine the reader may not run at all for a while).
  constexpr std::uint64_t kN = 300'000, kReads = 10'000;
  std::atomic<bool> done{false};
  std::atomic<std::uint64_t> reads_so_far{0};
  std::uint64_t torn = 0, backwards = 0, reads = 0, last = 0;
  std::thread reader([&] {
    Wide w;
    while (!done.load(std::memory_order_acquire)) {
      if (!value->read(w)) continue;
      reads_so_far.store(++reads, std::memory_order_relaxed);
      for (const std::uint64_t x : w.words) torn += x != w.words[0] ? 1 : 0;
      backwards += w.words[0] < last ? 1 : 0;
      last = w.words[0];
    }
  });
  Wide w;
  std::uint64_t published = 0;
  while (published < kN || reads_so_far.load(std::memory_order_relaxed) < kReads) {
    w.words.fill(++published);
    value->publish(w);
  }
  done.store(true, std::memory_order_release);
  reader.join();
  Wide final_value;
  ASSERT_TRUE(value->read(final_value));
  EXPECT_EQ(final_value.words[0], published);
  EXPECT_EQ(torn, 0u);
  EXPECT_EQ(backwards, 0u);
  EXPECT_GE(reads, kReads);
}

}  // namespace
}  // namespace springbok::rt
