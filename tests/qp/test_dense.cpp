// qp::dense::scan_lower_triangle (the caller's Cholesky factor: finite, which variables it
// couples) against the entry-by-entry definition, on random sparsity patterns, sizes and
// leading dimensions, with non-finite entries on, below and above the diagonal.
#include <cmath>
#include <cstdint>
#include <limits>
#include <random>
#include <vector>

#include <gtest/gtest.h>

#include "springbok/qp/dense.hpp"

namespace {
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

}  // namespace
