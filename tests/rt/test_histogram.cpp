#include <gtest/gtest.h>

#include <memory>

#include "springbok/rt/histogram.hpp"

namespace springbok::rt {
namespace {

TEST(Histogram, QuantilesOfAUniformRamp) {
  auto h = std::make_unique<Histogram<1000>>(1'000);
  for (int us = 0; us < 1000; ++us) h->add(us * 1'000 + 500);  // one sample per 1 us bin
  EXPECT_EQ(h->count(), 1000u);
  // Oracle: the q-quantile of one sample per bin is the upper edge of bin ceil(q n) - 1.
  EXPECT_EQ(h->quantile_ns(0.5), 500'000);
  EXPECT_EQ(h->quantile_ns(0.99), 990'000);
  EXPECT_EQ(h->quantile_ns(0.999), 999'000);
  EXPECT_EQ(h->quantile_ns(1.0), 999'500);  // capped at the exact maximum
  EXPECT_EQ(h->min_ns(), 500);
  EXPECT_NEAR(h->mean_ns(), 500'000.0, 1e-6);
}

TEST(Histogram, OverflowKeepsTheExactMaximum) {
  Histogram<10> h(1'000);
  for (int i = 0; i < 98; ++i) h.add(5'000);
  h.add(50'000);
  h.add(70'000);
  EXPECT_EQ(h.overflow(), 2u);
  EXPECT_EQ(h.max_ns(), 70'000);
  EXPECT_EQ(h.quantile_ns(0.98), 6'000);
  EXPECT_EQ(h.quantile_ns(0.99), 70'000);  // in the overflow: reported as the max
  h.add(-3);                               // negative durations clamp to 0
  EXPECT_EQ(h.min_ns(), 0);
  EXPECT_EQ(h.bin_count(0), 1u);
}

TEST(Histogram, EmptyIsZero) {
  Histogram<4> h;
  EXPECT_EQ(h.quantile_ns(0.99), 0);
  EXPECT_EQ(h.mean_ns(), 0.0);
}

}  // namespace
}  // namespace springbok::rt
