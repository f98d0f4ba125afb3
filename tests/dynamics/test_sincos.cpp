// The batch sine and cosine (dyn::sincos_batch) against libm: within 2 ulp of libm's (itself
// within an ulp of the truth) over 10^6 angles across the joint range and beyond, at the
// quadrant boundaries, for zeros and tiny angles; huge, infinite and NaN angles get
// libm's answer exactly.
#include <cmath>
#include <limits>
#include <numbers>
#include <random>

#include <gtest/gtest.h>

#include "springbok/dynamics/sincos.hpp"

namespace {
using springbok::dyn::sincos_batch;

// |a - b| in units of the last place of b (0 when equal, both NaN included).
double ulps(double a, double b) {
  if (a == b || (std::isnan(a) && std::isnan(b))) return 0.0;
  const double ulp = std::nextafter(std::abs(b), std::numeric_limits<double>::infinity()) - std::abs(b);
  return std::abs(a - b) / ulp;
}

constexpr int kBatch = 19;

void expect_close(const double (&x)[kBatch], double max_ulps, double& worst) {
  double s[kBatch], c[kBatch];
  sincos_batch<kBatch>(x, s, c);
  for (int i = 0; i < kBatch; ++i) {
    const double es = ulps(s[i], std::sin(x[i])), ec = ulps(c[i], std::cos(x[i]));
    worst = std::max({worst, es, ec});
    ASSERT_LE(es, max_ulps) << "sin(" << x[i] << ") = " << s[i] << ", libm " << std::sin(x[i]);
    ASSERT_LE(ec, max_ulps) << "cos(" << x[i] << ") = " << c[i] << ", libm " << std::cos(x[i]);
  }
}

TEST(SinCosBatch, WithinTwoUlpOfLibmOverAMillionAngles) {
  std::mt19937_64 rng(7);
  double worst = 0.0;
  for (const double range : {1.0, 4.0, 50.0, 1e3, 1e5}) {
    std::uniform_real_distribution<double> angle(-range, range);
    for (int n = 0; n < 200000 / kBatch; ++n) {
      double x[kBatch];
      for (double& v : x) v = angle(rng);
      expect_close(x, 2.0, worst);
    }
  }
  std::printf("largest difference from libm: %.2f ulp\n", worst);
}

TEST(SinCosBatch, QuadrantBoundariesZerosAndTinyAngles) {
  double worst = 0.0;
  double x[kBatch];
  for (int k = -40; k <= 40; k += 1) {
    for (int i = 0; i < kBatch; ++i) {
      // Around k pi/4: exactly the nearest double, and a few ulp either side.
      const double base = k * std::numbers::pi / 4.0;
      double v = base;
      for (int step = 0; step < i - kBatch / 2; ++step) v = std::nextafter(v, 1e300);
      for (int step = 0; step < kBatch / 2 - i; ++step) v = std::nextafter(v, -1e300);
      x[i] = v;
    }
    expect_close(x, 2.0, worst);
  }
  const double special[kBatch] = {0.0, -0.0, 1e-300, -1e-300, 5e-324, 1e-8, -1e-8, 1e-16, 0.5, -0.5,
                                  std::numbers::pi, -std::numbers::pi, 2 * std::numbers::pi, 1e5, -1e5,
                                  6.283185307179586, 1.5707963267948966, -1.5707963267948966, 3e4};
  expect_close(special, 2.0, worst);
  double s[kBatch], c[kBatch];
  sincos_batch<kBatch>(special, s, c);
  EXPECT_EQ(s[0], 0.0);
  EXPECT_EQ(c[0], 1.0);
}

TEST(SinCosBatch, HugeInfiniteAndNanAnglesGetLibmsAnswer) {
  const double nan = std::numeric_limits<double>::quiet_NaN(), inf = std::numeric_limits<double>::infinity();
  double x[kBatch] = {1e6, -1e6, 1e22, -1e300, inf, -inf, nan, 0.3, 1e5 + 1.0};
  for (int i = 9; i < kBatch; ++i) x[i] = 0.1 * i;
  double s[kBatch], c[kBatch];
  sincos_batch<kBatch>(x, s, c);
  for (int i = 0; i < 9; ++i) {
    if (i == 7) continue;
    EXPECT_EQ(ulps(s[i], std::sin(x[i])), 0.0) << x[i];
    EXPECT_EQ(ulps(c[i], std::cos(x[i])), 0.0) << x[i];
  }
  EXPECT_TRUE(std::isnan(s[4]) && std::isnan(c[6]));
  EXPECT_LE(ulps(s[7], std::sin(0.3)), 2.0);
}

}  // namespace
