// dyn::SmallCholesky against Eigen's LLT: the factor, solves with several right-hand sides,
// and a matrix that is not positive definite.
#include <random>

#include <gtest/gtest.h>

#include <Eigen/Cholesky>

#include "springbok/dynamics/small_cholesky.hpp"

namespace {
using springbok::dyn::SmallCholesky;

template <int N>
Eigen::Matrix<double, N, N> random_spd(std::mt19937& rng, double condition_scale) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  Eigen::Matrix<double, N, N> a;
  for (int i = 0; i < N; ++i)
    for (int j = 0; j < N; ++j) a(i, j) = u(rng);
  Eigen::Matrix<double, N, N> spd = a * a.transpose();
  spd.diagonal().array() += condition_scale;
  return spd;
}

template <int N, int K>
void check(std::mt19937& rng, double condition_scale) {
  const Eigen::Matrix<double, N, N> a = random_spd<N>(rng, condition_scale);
  Eigen::Matrix<double, N, K> b;
  std::uniform_real_distribution<double> u(-10.0, 10.0);
  for (int i = 0; i < N; ++i)
    for (int k = 0; k < K; ++k) b(i, k) = u(rng);
  const SmallCholesky<N> small(a);
  ASSERT_TRUE(small.ok());
  const Eigen::LLT<Eigen::Matrix<double, N, N>> llt(a);
  const Eigen::Matrix<double, N, N> l = llt.matrixL();
  EXPECT_LT((small.matrix_l() - l).cwiseAbs().maxCoeff(), 1e-12 * l.cwiseAbs().maxCoeff());
  EXPECT_EQ(small.matrix_l().template triangularView<Eigen::StrictlyUpper>().toDenseMatrix().cwiseAbs().maxCoeff(), 0.0);
  const Eigen::Matrix<double, N, K> x = small.template solve<K>(b);
  // The residual against A itself, relative to the scales involved.
  EXPECT_LT((a * x - b).cwiseAbs().maxCoeff(), 1e-11 * (a.cwiseAbs().maxCoeff() * x.cwiseAbs().maxCoeff() + 1.0));
  EXPECT_LT((x - llt.solve(b)).cwiseAbs().maxCoeff(), 1e-9 * (1.0 + x.cwiseAbs().maxCoeff()));
}

TEST(SmallCholesky, MatchesEigensLltOnRandomSpdMatrices) {
  std::mt19937 rng(11);
  for (int trial = 0; trial < 50; ++trial) {
    const double scale = trial % 2 == 0 ? 1.0 : 1e-4;  // well and less well conditioned
    check<6, 1>(rng, scale);
    check<7, 3>(rng, scale);
    check<7, 6>(rng, scale);
  }
}

TEST(SmallCholesky, SaysWhenNotPositiveDefinite) {
  Eigen::Matrix<double, 3, 3> a;
  a << 4, 1, 0, 1, -2, 0, 0, 0, 1;  // indefinite
  EXPECT_FALSE(SmallCholesky<3>(a).ok());
  a << 1, 0, 0, 0, std::numeric_limits<double>::quiet_NaN(), 0, 0, 0, 1;
  EXPECT_FALSE(SmallCholesky<3>(a).ok());
  a.setIdentity();
  const SmallCholesky<3> id(a);
  EXPECT_TRUE(id.ok());
  const Eigen::Vector3d b(1.0, -2.0, 3.0);
  EXPECT_EQ(id.solve<1>(b), b);
}

}  // namespace
