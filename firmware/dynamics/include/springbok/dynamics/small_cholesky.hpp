// Cholesky factor A = L L' of a small symmetric positive definite matrix of compile-time
// size, and solves with it, in plain loops the compiler unrolls. Eigen's LLT sends a
// matrix right-hand side through its general blocked triangular solver, which at these
// sizes costs more than the arithmetic (the arm task's 7 x 7 solve with 3 columns; and its
// factorisation runs generic loops: the base estimator's per-foot update of up to 7 rows).
// Reads A's lower triangle.
#pragma once

#include <cmath>
#include <limits>

#include <Eigen/Core>

namespace springbok::dyn {

template <int N>
class SmallCholesky {
 public:
  using Matrix = Eigen::Matrix<double, N, N>;

  // rt: no alloc
  explicit SmallCholesky(const Matrix& a) noexcept {
    l_.setZero();
    for (int j = 0; j < N; ++j) {
      double d = a(j, j);
      for (int k = 0; k < j; ++k) d -= l_(j, k) * l_(j, k);
      if (!(d > 0.0)) {  // not positive definite (or NaN): ok() says so, solve() gives NaN
        ok_ = false;
        d = std::numeric_limits<double>::quiet_NaN();
      }
      l_(j, j) = std::sqrt(d);
      inv_diag_[j] = 1.0 / l_(j, j);
      for (int i = j + 1; i < N; ++i) {
        double s = a(i, j);
        for (int k = 0; k < j; ++k) s -= l_(i, k) * l_(j, k);
        l_(i, j) = s * inv_diag_[j];
      }
    }
  }

  bool ok() const noexcept { return ok_; }
  // L (zero above the diagonal).
  const Matrix& matrix_l() const noexcept { return l_; }

  // A^-1 b by forward and backward substitution, all K columns at once. rt: no alloc
  template <int K>
  Eigen::Matrix<double, N, K> solve(const Eigen::Matrix<double, N, K>& b) const noexcept {
    Eigen::Matrix<double, N, K> x = b;
    for (int i = 0; i < N; ++i) {
      for (int k = 0; k < i; ++k) x.row(i) -= l_(i, k) * x.row(k);
      x.row(i) *= inv_diag_[i];
    }
    for (int i = N - 1; i >= 0; --i) {
      for (int k = i + 1; k < N; ++k) x.row(i) -= l_(k, i) * x.row(k);
      x.row(i) *= inv_diag_[i];
    }
    return x;
  }

 private:
  Matrix l_;
  Eigen::Matrix<double, N, 1> inv_diag_;
  bool ok_ = true;
};

}  // namespace springbok::dyn
