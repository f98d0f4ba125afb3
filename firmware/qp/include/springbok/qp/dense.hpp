// Small dense kernels on raw column-major storage, written so that g++ -O3
// vectorises them (axpy loops, dot products with independent accumulators).
// Sizes are the live ones; storage and leading dimensions are the caller's.
// rt: no alloc, no block, noexcept.
#pragma once

#include <cmath>

namespace springbok::qp::dense {

// a . b over n entries; eight partial sums so the compiler can keep two vector
// accumulators (a plain reduction is not vectorised without -ffast-math).
inline double dot(const double* __restrict a, const double* __restrict b, int n) noexcept {
  double s0 = 0.0, s1 = 0.0, s2 = 0.0, s3 = 0.0, s4 = 0.0, s5 = 0.0, s6 = 0.0, s7 = 0.0;
  int i = 0;
  for (; i + 8 <= n; i += 8) {
    s0 += a[i] * b[i];
    s1 += a[i + 1] * b[i + 1];
    s2 += a[i + 2] * b[i + 2];
    s3 += a[i + 3] * b[i + 3];
    s4 += a[i + 4] * b[i + 4];
    s5 += a[i + 5] * b[i + 5];
    s6 += a[i + 6] * b[i + 6];
    s7 += a[i + 7] * b[i + 7];
  }
  for (; i < n; ++i) s0 += a[i] * b[i];
  return ((s0 + s4) + (s1 + s5)) + ((s2 + s6) + (s3 + s7));
}

inline double squared_norm(const double* a, int n) noexcept { return dot(a, a, n); }

// y += alpha x
inline void axpy(double alpha, const double* __restrict x, double* __restrict y, int n) noexcept {
  for (int i = 0; i < n; ++i) y[i] += alpha * x[i];
}

// In-place Cholesky A = L L' of the lower triangle of a (column-major, leading
// dimension ld), right-looking. Writes 1/L_kk into inv_diag. Returns false when
// a pivot is not above min_pivot (not positive definite, or NaN).
inline bool cholesky_lower(double* a, int ld, int n, double min_pivot, double* inv_diag) noexcept {
  for (int k = 0; k < n; ++k) {
    double* col_k = a + k * ld;
    const double pivot = col_k[k];
    if (!(pivot > min_pivot)) return false;
    const double diag = std::sqrt(pivot);
    const double inv = 1.0 / diag;
    col_k[k] = diag;
    inv_diag[k] = inv;
    for (int i = k + 1; i < n; ++i) col_k[i] *= inv;
    for (int j = k + 1; j < n; ++j) {
      double* col_j = a + j * ld;
      const double l_jk = col_k[j];
      for (int i = j; i < n; ++i) col_j[i] -= col_k[i] * l_jk;
    }
  }
  return true;
}

// y <- L^-1 y (forward substitution, axpy form).
inline void forward_solve(const double* l, int ld, const double* inv_diag, int n, double* __restrict y) noexcept {
  for (int k = 0; k < n; ++k) {
    const double yk = y[k] * inv_diag[k];
    y[k] = yk;
    const double* __restrict col_k = l + k * ld;
    for (int i = k + 1; i < n; ++i) y[i] -= col_k[i] * yk;
  }
}

// y <- L^-T y (back substitution, dot form over the columns of L).
inline void backward_solve_transposed(const double* l, int ld, const double* inv_diag, int n, double* y) noexcept {
  for (int k = n - 1; k >= 0; --k) {
    const double* col_k = l + k * ld;
    y[k] = (y[k] - dot(col_k + k + 1, y + k + 1, n - k - 1)) * inv_diag[k];
  }
}

// Householder reflector P = I - tau v v' with v = [1; tail] so that P x = [beta; 0].
// x has len entries; on return x[0] = beta and x[1..] holds the tail of v.
inline double make_householder(double* x, int len) noexcept {
  const double alpha = x[0];
  const double tail2 = squared_norm(x + 1, len - 1);
  if (tail2 == 0.0) return 0.0;  // already reduced: P = I
  const double beta = (alpha >= 0.0 ? -1.0 : 1.0) * std::sqrt(alpha * alpha + tail2);
  const double scale = 1.0 / (alpha - beta);
  for (int i = 1; i < len; ++i) x[i] *= scale;
  x[0] = beta;
  return (beta - alpha) / beta;
}

// y <- (I - tau v v') y, v = [1; tail] of len entries.
inline void apply_householder(const double* tail, double tau, int len, double* y) noexcept {
  if (tau == 0.0) return;
  const double w = tau * (y[0] + dot(tail, y + 1, len - 1));
  y[0] -= w;
  axpy(-w, tail, y + 1, len - 1);
}

// Givens rotation (c, s) with [c s; -s c] [a; b] = [r; 0]; returns r >= 0.
inline double givens(double a, double b, double& c, double& s) noexcept {
  const double r = std::hypot(a, b);
  if (r == 0.0) {
    c = 1.0;
    s = 0.0;
    return 0.0;
  }
  c = a / r;
  s = b / r;
  return r;
}

}  // namespace springbok::qp::dense
