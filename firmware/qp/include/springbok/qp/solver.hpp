// springbok::qp::Solver<N, ME, MI>: the dual active-set method of Goldfarb and
// Idnani (1983) for strictly convex dense QPs, sized at compile time.
//
// The method, as built here:
//  1. H = L L', kept as L = U D with U unit lower (Cholesky once; or the caller's
//     factor; or, when asked, the previous solve's factor again after checking that
//     H has not changed). Variables that H
//     couples to no other (a diagonal row: contact forces, regularised accelerations
//     in the WBC) are ordered last; in that order L = [Lc 0; 0 D^1/2], so the factor
//     costs nc^3/3 and every solve with L nc^2/2 + n for the nc coupled variables.
//     Everything below works in that order (x is gathered and scattered at the edges).
//  2. Equalities (Aeq rows and lb == ub rows of Ain) are eliminated as one block:
//     B = L^-1 E' is factored by Householder QR with column pivoting, B P = Q [Re; 0]
//     (Q kept as its reflectors and in compact WY form, Q = I - V T V').
//     Rank-deficient (duplicated, redundant) rows are detected here and checked for
//     consistency. In the coordinates v = Q' L' x = [v1; w] the equalities fix
//     v1 = Re^-T e, and what remains is a QP in w with identity Hessian:
//         minimize 1/2 |w|^2 + c2'w   s.t.  lb_i - h_i <= at_i'w <= ub_i - h_i
//     with t_i = Q' L^-1 a_i = [h-part; at_i], h_i = t_i[:r]'v1, c = Q' L^-1 g.
//  3. Goldfarb-Idnani on that reduced QP. With H = I the GI basis J = [Q1 Q2] needs
//     only Q1, the orthonormal basis of the active normals (N = Q1 R), kept by
//     Gram-Schmidt with re-orthogonalisation on additions and Givens rotations on
//     drops; the step direction is z = n+ - Q1 Q1'n+. The reduced normal t_i of a
//     row is computed only when the row is picked (rows that never become
//     violated cost one dot product per outer iteration, in Ain x). A row within
//     1e-8 of the span of the active rows counts as dependent (dual steps only);
//     an "infeasible" verdict whose gap is near rounding gets a second run without
//     that row, which stands only if the row holds after all.
//  4. Multipliers of the equalities are recovered at the end from Re.
//
// A warm start first tries the hinted set as it is (solve_on_hinted_set): with the
// hinted rows and the equalities taken as active, the minimiser comes from the
// Cholesky factor of the small Gram matrix of L^-1 [E' A_h'] (corrected semi-normal
// equations); it is the answer when the hinted multipliers have their sides' signs
// and every row holds, which is the common case of a controller whose active set did
// not change since the last tick. Otherwise steps 2-4 run from the same hint.
//
// Every loop is bounded (iteration cap), every division guarded; solve() is
// noexcept and never allocates: the workspace lives in the object.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>

#include "springbok/qp/dense.hpp"
#include "springbok/qp/types.hpp"

namespace springbok::qp {

template <int N, int ME, int MI>
class Solver {
 public:
  using ProblemType = Problem<N, ME, MI>;
  using ResultType = Result<N, ME, MI>;
  using Hint = StartHint<N, MI>;
  static constexpr int kMaxVariables = N;
  static constexpr int kMaxEqualities = ME;
  static constexpr int kMaxInequalities = MI;
  // How many times a warm start's shortcut repairs its set (solve_on_hinted_set). A
  // trot's touch-down takes up to seven, a walk's up to eleven on the estimated state. A
  // repair costs a small part of the full method's start, so the tick whose set is repaired
  // is not the slow one the fallback would make.
  static constexpr int kShortcutRepairs = 12;

  explicit Solver(const Options& options = {}) noexcept : options_(options) {}

  // rt: no alloc, no block
  [[gnu::noinline]] Status solve(const ProblemType& problem, ResultType& result, const Hint& hint = {}) noexcept;

 private:
  static constexpr int kLd = ((N + 3) / 4) * 4;  // padded leading dimension
  static constexpr int kMaxEqRows = ME + MI;
  static constexpr double kInf = std::numeric_limits<double>::infinity();
  static constexpr double kEps = std::numeric_limits<double>::epsilon();

  enum class RowKind : std::uint8_t { dead = 0, lower = 1, upper = 2, both = 3, equal = 4 };

  template <class T, int Size>
  using Buf = std::array<T, static_cast<std::size_t>(Size)>;

  static bool finite(double v) noexcept { return std::isfinite(v); }

  // Offset of entry (i, j) in a column-major matrix of leading dimension ld; column j
  // of the workspaces (leading dimension kLd).
  static constexpr std::size_t idx(int i, int j, int ld) noexcept {
    return static_cast<std::size_t>(j) * static_cast<std::size_t>(ld > 0 ? ld : 1) + static_cast<std::size_t>(i);
  }
  double* lcol(int j) noexcept { return l_.data() + idx(0, j, kLd); }
  double* bcol(int j) noexcept { return b_.data() + idx(0, j, kLd); }
  double* vcol(int j) noexcept { return v_.data() + idx(0, j, kLd); }
  double* q1col(int j) noexcept { return q1_.data() + idx(0, j, kLd); }
  double* rcol(int j) noexcept { return r_.data() + idx(0, j, kLd); }
  double* tvec(int row) noexcept { return t_.data() + idx(0, row, kLd); }
  double* gcol(int j) noexcept { return gram_.data() + idx(0, j, kLd); }
  double* scol(int j) noexcept { return gram_s_.data() + idx(0, j, kLd); }

  // Steps 0-4 (defined in solver_impl.hpp).
  // ---- step 0: validate and classify
  Status classify() noexcept;
  // ---- step 1: Cholesky
  bool same_factored_hessian() const noexcept;
  void order_variables() noexcept;
  Status factor(const Hint& hint) noexcept;
  template <class Column>
  void solve_lower_each(int cols, Column column) noexcept;
  void solve_lower(double* y, int ldy = 0, int cols = 1) noexcept;
  void gather_ain_row(int row, double* dst) const noexcept;
  void gather(const double* src, double* dst) const noexcept;
  // ---- step 2: the equality block
  void load_equalities() noexcept;
  Status eliminate_equalities() noexcept;
  void build_wy() noexcept;
  void upper_t_times_s(int k) noexcept;
  void apply_q(double* y) noexcept;
  void apply_reflector(int k, double* y) noexcept;
  // ---- step 3: Goldfarb-Idnani on the reduced problem
  Status unless_ain_bad(Status s) noexcept;
  Status check_rows(const double* x) noexcept;
  void queue_reduction(int row, int& queued) noexcept;
  void reduce_queued(int queued) noexcept;
  const double* t_of(int row) noexcept;
  double reduced_row(int row, int sigma) noexcept;
  double project() noexcept;
  void append(int row, int sigma, double rhs, double full_norm, double z_norm, double multiplier) noexcept;
  void drop(int k) noexcept;
  void solve_r(const double* d, double* out) noexcept;
  void compute_x() noexcept;
  int most_violated(int& sigma) noexcept;
  [[gnu::noinline]] bool inactive_rows_inside() const noexcept;
  double side_violation(int i, bool& lower_side, double& bound) const noexcept;
  double violation(int i, double xn, double tol, bool& lower_side, double& limit) const noexcept;
  double v_norm() const noexcept;
  bool count_iteration() noexcept { return ++iterations_ <= max_iterations_; }
  int hinted_sigma(int row, Side side) const noexcept;
  void reduce_hinted_rows(const ActiveSet<MI>& hint, int count) noexcept;
  void warm_start(const ActiveSet<MI>& hint) noexcept;
  double dependence_tol() const noexcept { return 1e-8; }
  // Relative size of a violation that the reduced coordinates cannot resolve: 1e-11,
  // or more (at most 1e-9) when an ill-conditioned equality block pins x down less
  // accurately.
  double rounding_level() const noexcept { return std::clamp(64.0 * kEps * eq_cond_, 1e-13, 1e-9); }
  Status attempt(const ActiveSet<MI>* warm) noexcept;
  Status second_opinion() noexcept;
  Status run(const ActiveSet<MI>* warm) noexcept;
  Status full_method(Status status, const ActiveSet<MI>* warm, ResultType& result) noexcept;
  // ---- step 4: x, objective, multipliers, active set
  Status finish_checked(ResultType& result, Status status) noexcept;
  Status check_stationarity(const ResultType& result) noexcept;
  double active_residuals() noexcept;
  double block_residual(int k, double& scale) const noexcept;
  void refine() noexcept;
  bool finish(ResultType& result) noexcept;

  // The warm start's shortcut, the hinted set as equalities (defined in solver_warm_start.hpp).
  enum class Shortcut : std::uint8_t { solved, fallback };
  // What would make a failed set fit: Ain's row to add (on side sigma), or the block's
  // columns (>= me_) to drop; none: fall back to the full method.
  struct SetRepair {
    enum class Kind : std::uint8_t { none, add, drop } kind = Kind::none;
    int row = -1;          // add: Ain's row
    std::int8_t sigma = 0;  // add: its side
    int drops = 0;          // drop: the block's columns drop_col_[0 .. drops-1], ascending
  };
  Shortcut solve_on_hinted_set(const ActiveSet<MI>& hint, ResultType& result, Status& status) noexcept;
  void load_set_row(int k, int row, int sigma) noexcept;
  bool add_set_column(int& cols, int row, std::int8_t sigma) noexcept;
  void drop_set_column(int& cols, int k) noexcept;
  bool append_gram_row(int cols) noexcept;
  Shortcut solve_on_set(int cols, bool added, ResultType& result, Status& status, SetRepair& fix) noexcept;
  void solve_set_equations(int cols) noexcept;
  void extend_solution(int cols) noexcept;
  bool hinted_row(int i, int cols) const noexcept;
  double ain_row_norm(int i) const noexcept;
  void solve_gram(double* y, int cols) noexcept;

  // The state and the workspace: all of it in the object (solve() never allocates).
  Options options_;
  const ProblemType* p_ = nullptr;
  int n_ = 0, n_padded_ = 0, meq_ = 0, mi_ = 0;  // n_padded_: n padded to whole chunks of four
  int me_ = 0, rank_ = 0, m_ = 0, m_padded_ = 0, q_ = 0;  // m_padded_: m_ padded to whole chunks
  int iterations_ = 0, max_iterations_ = 0, epoch_ = 0;
  int g_reduced_at_ = -1;  // column of L^-1 g when solve_on_hinted_set reduced E and g (-1: not this solve)
  int verdict_row_ = -1, ignored_row_ = -1;  // the row of an infeasible verdict; the row a second run leaves out
  double verdict_gap_ = kInf;                 // that verdict's violation relative to its path
  double x_norm_ = 0.0, full_norm_ = 0.0, c_norm_ = 0.0;
  double normal_sq_ = 0.0;  // |n+|^2 of reduced_row()'s normal_ (project())
  double eq_cond_ = 1.0;  // max/min |diagonal| of the equality block's R (a condition estimate)
  bool x_current_ = false;     // x_ = L^-T Q [v1; w] for the current w (set when run() ends optimal)
  bool rows_checked_ = false;  // Ain's row norms known, zero rows settled (check_rows())
  static constexpr double kMinReducedShare = 0.1;  // most_violated(): floor of |n+_i| / |t_i|
  static constexpr int kStop = -2;       // most_violated(): stop with stop_status_
  Status stop_status_ = Status::optimal;
  bool slack_current_ = false;  // slack_ = Ain x_ (set by finish() when x_ is the one most_violated used)

  // factor of H
  alignas(64) Buf<double, kLd * N> l_{};  // H's coupled block = U D^2 U': U's strict lower part (cholesky_lower)
  alignas(64) Buf<double, kLd> inv_diag_{};  // 1 / L_kk, zero past n_
  Buf<double, N * N> factored_h_{};  // lower triangle of the H last factored with reuse_factor
  int factored_n_ = 0;
  Buf<std::size_t, N> ain_offset_{};  // offset of Ain's column perm_[k]
  Buf<int, N> perm_{};               // variable order: original index of position k
  Buf<std::uint8_t, N> coupled_{};   // H couples variable j to another one
  Buf<std::uint8_t, N> h_coupled_{};  // factor(): coupled_ from H, against a given factor's
  int nc_ = 0;                       // coupled variables (the first nc_ positions)
  bool have_factored_h_ = false;
  // equality block: Householder QR of L^-1 E' (column-major, leading dim kLd)
  alignas(64) Buf<double, kLd*(kMaxEqRows + 1)> b_{};  // and L^-1 g in column me_
  alignas(64) Buf<double, kLd * N> v_{};  // Householder vectors, full and padded
  alignas(64) Buf<double, kLd * N> wy_t_{};   // T of Q = I - V T V' (rank_ x rank_, upper)
  alignas(64) Buf<double, kLd> wy_s_{}, wy_u_{};  // V'y and T V'y (apply_q, build_wy)
  Buf<double, kMaxEqRows> tau_{}, eq_rhs_{}, eq_norm2_{}, eq_left2_{}, eq_res_{}, eq_row_norm_{};
  Buf<int, kMaxEqRows> eq_src_{};
  Buf<double, kMaxEqRows + 1> eq_w_{};  // tau v'c_j of one reflector for the columns right of it
  // reduced problem
  alignas(64) Buf<double, kLd> stat_res_{};  // the stationarity residual of finish_checked()
  alignas(64) Buf<double, kLd> v1_{}, c_{}, w_{}, x_{}, xp_{}, y_{}, normal_{}, z_{}, d_{}, e_{}, rdir_{}, beta_{};
  alignas(64) Buf<double, kLd * N> q1_{};
  alignas(64) Buf<double, kLd * N> r_{};
  alignas(64) Buf<double, kLd> u_{};  // multipliers of the active rows (padded: solve_r's chunks)
  Buf<double, N> r_inv_diag_{};       // solve_r(): 1 / R_jj
  Buf<double, N> act_rhs_{}, act_norm_{}, act_res_{};
  alignas(64) Buf<double, kLd> keep_w_{}, keep_v1_{};  // the state before refine()
  Buf<double, N> keep_u_{}, keep_x_{};
  Buf<int, N> act_row_{};
  Buf<std::int8_t, N> act_sigma_{};
  // per inequality row
  alignas(64) Buf<double, kLd * MI> t_{};
  alignas(64) Buf<double, MI> slack_{};  // Ain x
  Buf<double, ME> eq_ax_{};               // Aeq x
  Buf<double, MI> row_norm_{};
  Buf<double, N> h_row_sq_{};          // sums of squares along the rows of H (finiteness check)
  Buf<std::uint64_t, N> row_bits_{};  // off-diagonal non-zero bits per row of H (or of a given factor)
  Buf<double, ME> eq_row_sq_{};  // and of Aeq (finiteness check, row norms)
  Buf<RowKind, MI> kind_{};
  Buf<double, MI> lo_eff_{}, hi_eff_{}, lo_abs_{}, hi_abs_{};  // violable bounds (most_violated)
  Buf<std::int8_t, MI> active_side_{};
  Buf<bool, MI> have_t_{};
  Buf<double, MI> red_norm_{};  // most_violated()'s scale: |n+_i| = |t_i past rank_| (floored), where have_t_
  Buf<int, MI> cand_row_{};      // most_violated()'s violated rows
  Buf<double, MI> cand_viol_{};  // and their violations (negative: the upper side)
  Buf<int, MI> skipped_epoch_{};  // row skipped as a rounding-level violation while epoch_ holds
  Buf<int, MI> batch_row_{};      // rows whose t_i one multi-column solve computes
  // the hinted set as equalities (solve_on_hinted_set)
  alignas(64) Buf<double, kLd * N> gram_{};  // factor of S = B'B = U D^2 U'
  alignas(64) Buf<double, kLd> gram_inv_diag_{};  // D^-2 (zero-padded)
  Buf<double, N> gram_min_pivot_{};                 // 1e-8 S_jj
  alignas(64) Buf<double, kLd> gram_row_{};         // append_gram_row's U^-1 s
  int gram_cols_ = 0;                               // columns of S that gram_ holds the factor of
  alignas(64) Buf<double, kLd> lam_{}, step_{}, hinted_v_{}, hinted_z_{};  // hinted_z_: extend_solution's z
  Buf<std::int8_t, N> hinted_side_{};  // side of column k >= me_ of b_ (+1 lower, -1 upper)
  alignas(64) Buf<double, kLd * N> gram_s_{};  // S = B'B itself (lower triangle), kept across repairs
  ActiveSet<MI> repaired_set_{};  // the shortcut's set after its repairs, when they did not fit
  Buf<int, N> drop_col_{};  // the block's columns a repair drops (SetRepair::drops of them)
};

}  // namespace springbok::qp

// The definitions (a template: they stay in headers). Not meant to be included alone.
#define SPRINGBOK_QP_SOLVER_DEFINITIONS
#include "springbok/qp/solver_impl.hpp"
#include "springbok/qp/solver_warm_start.hpp"
#undef SPRINGBOK_QP_SOLVER_DEFINITIONS
