// qp::dense::scan_lower_triangle (the caller's Cholesky factor: finite, which variables it
// couples) against the entry-by-entry definition, on random sparsity patterns, sizes and
// leading dimensions, with non-finite entries on, below and above the diagonal; the
// shuffling kernels (a 4 x 4 transposing copy, four dot products summed at once) against
// their definitions, bit for bit.
#include <cmath>
#include <cstdint>
#include <limits>
#include <random>
#include <vector>

#include <gtest/gtest.h>

#include "springbok/qp/dense.hpp"

namespace {
using springbok::qp::dense::copy_transposed4;
using springbok::qp::dense::four_column_dots;
using springbok::qp::dense::scan_lower_triangle;

struct Reference {
  bool finite = true;
  std::vector<std::uint8_t> coupled;
};

Reference reference(const std::vector<double>& a, int ld, int n) {
  Reference r;
  r.coupled.assign(static_cast<std::size_t>(n), 0);
  for (int j = 0; j < n; ++j) {
    for (int i = j; i < n; ++i) {
      const double v = a[static_cast<std::size_t>(j * ld + i)];
      if (!std::isfinite(v)) r.finite = false;
      if (i > j && v != 0.0) r.coupled[static_cast<std::size_t>(i)] = r.coupled[static_cast<std::size_t>(j)] = 1;
    }
  }
  return r;
}

TEST(DenseScan, LowerTriangleScanMatchesItsDefinition) {
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(-1.0, 1.0), p(0.0, 1.0);
  const double kNan = std::numeric_limits<double>::quiet_NaN(), kInf = std::numeric_limits<double>::infinity();
  int non_finite_cases = 0, coupled_cases = 0;
  for (int trial = 0; trial < 3000; ++trial) {
    const int n = 1 + static_cast<int>(rng() % 64);
    const int lds[3] = {n, (n + 3) & ~3, 64};
    const int ld = lds[trial % 3];
    std::vector<double> a(static_cast<std::size_t>(ld * n), 0.0);
    const double density = p(rng) * 0.2;
    for (int j = 0; j < n; ++j) {
      for (int i = 0; i < ld; ++i) {
        double& v = a[static_cast<std::size_t>(j * ld + i)];
        if (i == j) v = 1.0 + p(rng);
        else if (p(rng) < density) v = u(rng);
        if (i < j && p(rng) < 0.05) v = kNan;  // above the diagonal: never read as data
        if (i >= n && p(rng) < 0.2) v = kInf;  // past row n - 1: not part of the matrix
      }
    }
    if (trial % 5 == 0) {  // one non-finite entry on or below the diagonal
      const int j = static_cast<int>(rng() % n);
      const int i = j + static_cast<int>(rng() % (n - j));
      a[static_cast<std::size_t>(j * ld + i)] = trial % 10 == 0 ? kNan : -kInf;
    }
    const Reference expected = reference(a, ld, n);
    std::vector<std::uint64_t> row_bits(static_cast<std::size_t>(n) + 4, 0);
    std::vector<std::uint8_t> coupled(static_cast<std::size_t>(n), 7);
    const bool finite = scan_lower_triangle(a.data(), ld, n, row_bits.data(), coupled.data());
    ASSERT_EQ(finite, expected.finite) << "trial " << trial << " n " << n << " ld " << ld;
    if (!finite) {
      ++non_finite_cases;
      continue;
    }
    for (int j = 0; j < n; ++j) {
      ASSERT_EQ(coupled[static_cast<std::size_t>(j)], expected.coupled[static_cast<std::size_t>(j)])
          << "trial " << trial << " n " << n << " ld " << ld << " variable " << j;
      coupled_cases += coupled[static_cast<std::size_t>(j)];
    }
  }
  EXPECT_GT(non_finite_cases, 500);
  EXPECT_GT(coupled_cases, 1000);
}


TEST(DenseShuffles, TransposedCopyPutsColumnsIntoRows) {
  constexpr int kLd = 8;
  std::vector<double> a(4 * kLd), y(4 * kLd + 3, -7.0);
  for (std::size_t k = 0; k < a.size(); ++k) a[k] = 1.0 + static_cast<double>(k);
  // Rows 2..5 of the four columns into rows of y (leading dimension 9: rows not chunk aligned).
  copy_transposed4(a.data() + 2, a.data() + kLd + 2, a.data() + 2 * kLd + 2, a.data() + 3 * kLd + 2, y.data() + 1, 9);
  for (int l = 0; l < 4; ++l)
    for (int c = 0; c < 4; ++c)
      EXPECT_EQ(y[static_cast<std::size_t>(1 + l * 9 + c)], a[static_cast<std::size_t>(c * kLd + 2 + l)]) << l << " " << c;
  EXPECT_EQ(y[0], -7.0);  // nothing written outside the four rows
  EXPECT_EQ(y[5], -7.0);
}

TEST(DenseShuffles, FourColumnDotsSumEachColumnsLanesInItsOrder) {
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (int trial = 0; trial < 200; ++trial) {
    const int ld = 4 * (1 + trial % 5), to = ld;
    std::vector<double> a(static_cast<std::size_t>(4 * ld)), x(static_cast<std::size_t>(ld));
    for (double& v : a) v = u(rng) * std::pow(10.0, static_cast<int>(trial % 7) - 3);
    for (double& v : x) v = u(rng);
    double out[4];
    four_column_dots(a.data(), ld, 0, to, x.data(), out);
    for (int c = 0; c < 4; ++c) {
      double lane[4] = {0.0, 0.0, 0.0, 0.0};  // the kernel's four partial sums, then ((0 + 1) + (2 + 3))
      for (int i = 0; i < to; ++i) lane[i % 4] += a[static_cast<std::size_t>(c * ld + i)] * x[static_cast<std::size_t>(i)];
      EXPECT_EQ(out[c], (lane[0] + lane[1]) + (lane[2] + lane[3])) << "trial " << trial << " column " << c;
    }
  }
}
}  // namespace
