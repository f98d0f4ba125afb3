// Data types of the dense QP solver (problem, result, active set, status).
//
//   minimize    1/2 x'Hx + g'x
//   subject to  Aeq x = beq                 (meq rows)
//               lb <= Ain x <= ub           (mi two-sided rows)
//
// Storage is fixed at compile time (N variables, ME equalities, MI inequality
// rows); the live counts n, meq, mi may be smaller. All matrices are stored
// column-major with the compile-time row count as leading dimension; the
// Eigen views (H(), Aeq(), ...) show the live block and never allocate.
#pragma once

#include <array>
#include <cstdint>

#include <Eigen/Core>

namespace springbok::qp {

enum class Status : std::uint8_t {
  optimal,
  infeasible,             // empty feasible set (incl. lb > ub, inconsistent equalities)
  maxiter,                // iteration cap reached
  bad_input,              // NaN/inf where not allowed, sizes out of range, bad factor
  not_positive_definite,  // Cholesky of H failed
  inaccurate,             // the answer failed the solver's own stationarity check (rounding won)
};

// The word used by tools and logs: optimal infeasible maxiter bad_input not_positive_definite inaccurate.
const char* to_string(Status status) noexcept;

// Which bound of a row is active. `equal` marks an Ain row with lb == ub.
enum class Side : std::uint8_t { lower, upper, equal };

// |bound| >= kInfiniteBound is treated as infinite (OSQP / Maros-Meszaros convention).
inline constexpr double kInfiniteBound = 1e20;

template <int MI>
struct ActiveSet {
  int size = 0;
  std::array<int, MI> row{};
  std::array<Side, MI> side{};

  void clear() noexcept { size = 0; }
  void push(int r, Side s) noexcept {
    if (size < MI) {
      row[static_cast<std::size_t>(size)] = r;
      side[static_cast<std::size_t>(size)] = s;
      ++size;
    }
  }
};

template <int N, int ME, int MI>
struct Problem {
  static_assert(N >= 1 && ME >= 0 && MI >= 0, "bad QP sizes");
  using Matrix = Eigen::Map<Eigen::MatrixXd, 0, Eigen::OuterStride<>>;
  using ConstMatrix = Eigen::Map<const Eigen::MatrixXd, 0, Eigen::OuterStride<>>;
  using Vector = Eigen::Map<Eigen::VectorXd>;
  using ConstVector = Eigen::Map<const Eigen::VectorXd>;

  int n = N;    // live variables
  int meq = 0;  // live equality rows
  int mi = 0;   // live inequality rows

  std::array<double, static_cast<std::size_t>(N) * N> hessian{};    // symmetric; lower triangle is read
  std::array<double, N> gradient{};
  std::array<double, static_cast<std::size_t>(ME) * N> aeq{};       // column-major, leading dim ME
  std::array<double, ME> beq_values{};
  std::array<double, static_cast<std::size_t>(MI) * N> ain{};       // column-major, leading dim MI
  std::array<double, MI> lower{};
  std::array<double, MI> upper{};

  Matrix H() noexcept { return Matrix(hessian.data(), n, n, Eigen::OuterStride<>(N)); }
  Vector g() noexcept { return Vector(gradient.data(), n); }
  Matrix Aeq() noexcept { return Matrix(aeq.data(), meq, n, Eigen::OuterStride<>(ME > 0 ? ME : 1)); }
  Vector beq() noexcept { return Vector(beq_values.data(), meq); }
  Matrix Ain() noexcept { return Matrix(ain.data(), mi, n, Eigen::OuterStride<>(MI > 0 ? MI : 1)); }
  Vector lb() noexcept { return Vector(lower.data(), mi); }
  Vector ub() noexcept { return Vector(upper.data(), mi); }

  ConstMatrix H() const noexcept { return ConstMatrix(hessian.data(), n, n, Eigen::OuterStride<>(N)); }
  ConstVector g() const noexcept { return ConstVector(gradient.data(), n); }
  ConstMatrix Aeq() const noexcept {
    return ConstMatrix(aeq.data(), meq, n, Eigen::OuterStride<>(ME > 0 ? ME : 1));
  }
  ConstVector beq() const noexcept { return ConstVector(beq_values.data(), meq); }
  ConstMatrix Ain() const noexcept {
    return ConstMatrix(ain.data(), mi, n, Eigen::OuterStride<>(MI > 0 ? MI : 1));
  }
  ConstVector lb() const noexcept { return ConstVector(lower.data(), mi); }
  ConstVector ub() const noexcept { return ConstVector(upper.data(), mi); }

  void resize(int n_live, int meq_live, int mi_live) noexcept {
    n = n_live;
    meq = meq_live;
    mi = mi_live;
  }
};

// Multiplier convention (tests/data/qp/FORMAT.md):
//   H x + g + Aeq' lambda_eq + Ain' lambda_in = 0,
//   lambda_in[i] >= 0 at the upper bound, <= 0 at the lower bound, 0 if inactive.
template <int N, int ME, int MI>
struct Result {
  Status status = Status::bad_input;
  std::array<double, N> x{};
  double objective = 0.0;
  std::array<double, ME> lambda_eq{};
  std::array<double, MI> lambda_in{};
  ActiveSet<MI> active;  // Ain rows at a bound (lower/upper), and every lb == ub row (equal)
  int iterations = 0;    // active-set changes (additions and drops; a warm start's own rows not counted)
  bool from_hint = false;  // the hinted active set held: solved on it directly, no iterations

  Eigen::Map<const Eigen::VectorXd> x_vector(int n) const noexcept { return {x.data(), n}; }
};

// Optional help for a solve: a guess of the active set (the previous tick's) and a
// Cholesky factor of H the caller already has (column-major lower, leading dim N, H = L L').
// reuse_factor: H may be bit-identical to the H of this solver's previous solve that
// also set it; the solver then compares the lower triangles (n^2/2 loads instead of
// a Cholesky) and reuses its own factor when they are equal, else factors afresh.
template <int N, int MI>
struct StartHint {
  const ActiveSet<MI>* active_set = nullptr;
  const double* cholesky_lower = nullptr;
  bool reuse_factor = false;
};

struct Options {
  int max_iterations = 0;            // 0: automatic, 10 (n + mi) + 50
  double feasibility_tol = 1e-11;    // row violation, relative to |a_i| |x| and |bound|
  double rank_tol = 1e-10;           // dependent rows: residual norm relative to row norm
};

}  // namespace springbok::qp
