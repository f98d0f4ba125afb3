// Independent KKT check of a QP solution, in long double, on the problem data
// alone (H, g, Aeq, beq, Ain, lb, ub as dense row-major arrays): it shares no
// code with the solver. Tolerances are those of tests/data/qp/FORMAT.md.
#pragma once

#include <algorithm>
#include <cmath>
#include <memory>
#include <vector>

namespace springbok::qp::test {

struct DenseQp {
  int n = 0, meq = 0, mi = 0;
  std::vector<double> H, g, Aeq, beq, Ain, lb, ub;  // row-major
};

struct KktReport {
  double primal = 0.0;        // worst row violation / max(1, |bound|)
  double stationarity = 0.0;  // |Hx + g + Aeq'le + Ain'li|_inf / scale
  double wrong_sign = 0.0;    // worst wrong-sign multiplier part / scale
  double complementarity = 0.0;  // worst |li| * distance to the bound its sign names / (scale max(1,|x|))
  double scale = 1.0;         // max(1, |H|_inf |x|_inf, |g|_inf)
};

inline bool infinite_bound(double b) { return std::abs(b) >= 1e20; }

inline KktReport kkt_check(const DenseQp& q, const double* x, const double* le, const double* li) {
  using ld = long double;
  KktReport r;
  double h_max = 0.0, g_max = 0.0, x_max = 0.0;
  for (double v : q.H) h_max = std::max(h_max, std::abs(v));
  for (double v : q.g) g_max = std::max(g_max, std::abs(v));
  for (int i = 0; i < q.n; ++i) x_max = std::max(x_max, std::abs(x[i]));
  r.scale = std::max({1.0, h_max * x_max, g_max});
  std::vector<ld> grad(static_cast<std::size_t>(q.n));
  for (int i = 0; i < q.n; ++i) {
    ld s = q.g[static_cast<std::size_t>(i)];
    for (int j = 0; j < q.n; ++j) s += static_cast<ld>(q.H[static_cast<std::size_t>(i * q.n + j)]) * x[j];
    grad[static_cast<std::size_t>(i)] = s;
  }
  for (int k = 0; k < q.meq; ++k) {
    ld ax = 0;
    for (int j = 0; j < q.n; ++j) {
      const ld a = q.Aeq[static_cast<std::size_t>(k * q.n + j)];
      ax += a * x[j];
      grad[static_cast<std::size_t>(j)] += a * le[k];
    }
    const double b = q.beq[static_cast<std::size_t>(k)];
    r.primal = std::max(r.primal, static_cast<double>(std::abs(ax - b)) / std::max(1.0, std::abs(b)));
  }
  for (int k = 0; k < q.mi; ++k) {
    ld ax = 0;
    for (int j = 0; j < q.n; ++j) {
      const ld a = q.Ain[static_cast<std::size_t>(k * q.n + j)];
      ax += a * x[j];
      grad[static_cast<std::size_t>(j)] += a * li[k];
    }
    const double lo = q.lb[static_cast<std::size_t>(k)], hi = q.ub[static_cast<std::size_t>(k)];
    const bool has_lo = !infinite_bound(lo), has_hi = !infinite_bound(hi);
    const double axd = static_cast<double>(ax);
    if (has_lo) r.primal = std::max(r.primal, (lo - axd) / std::max(1.0, std::abs(lo)));
    if (has_hi) r.primal = std::max(r.primal, (axd - hi) / std::max(1.0, std::abs(hi)));
    const double lam = li[k];
    const bool eq_row = has_lo && has_hi && lo == hi;
    if (eq_row) continue;
    // lambda > 0 belongs to the upper bound, lambda < 0 to the lower bound.
    if (lam > 0.0) {
      if (!has_hi) r.wrong_sign = std::max(r.wrong_sign, lam / r.scale);
      else r.complementarity = std::max(r.complementarity, lam * std::abs(hi - axd) / (r.scale * std::max(1.0, x_max)));
    } else if (lam < 0.0) {
      if (!has_lo) r.wrong_sign = std::max(r.wrong_sign, -lam / r.scale);
      else r.complementarity = std::max(r.complementarity, -lam * std::abs(axd - lo) / (r.scale * std::max(1.0, x_max)));
    }
  }
  ld worst = 0;
  for (const ld v : grad) worst = std::max(worst, std::abs(v));
  r.stationarity = static_cast<double>(worst) / r.scale;
  return r;
}

// A solver of type S with a problem and a result of its sizes, each on the heap (fixed-size
// objects too large for the stack): auto [solver, problem, result] = on_heap<S>();
template <class S>
struct OnHeap {
  std::unique_ptr<S> solver = std::make_unique<S>();
  std::unique_ptr<typename S::ProblemType> problem = std::make_unique<typename S::ProblemType>();
  std::unique_ptr<typename S::ResultType> result = std::make_unique<typename S::ResultType>();
};
template <class S>
OnHeap<S> on_heap() {
  return {};
}

}  // namespace springbok::qp::test
