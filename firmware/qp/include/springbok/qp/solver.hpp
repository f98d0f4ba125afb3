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
//     drops; the step direction is z = n - Q1 Q1'n. The reduced normal t_i of a
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
  // How many times a warm start's shortcut repairs its set (solve_on_hinted_set).
  static constexpr int kShortcutRepairs = 4;

  explicit Solver(const Options& options = {}) noexcept : options_(options) {}

  // rt: no alloc, no block
  [[gnu::noinline]] Status solve(const ProblemType& problem, ResultType& result, const Hint& hint = {}) noexcept {
    p_ = &problem;
    result.iterations = 0;
    result.from_hint = false;
    g_reduced_at_ = -1;
    repaired_set_.clear();
    result.active.clear();
    result.objective = std::numeric_limits<double>::quiet_NaN();
    iterations_ = 0;
    Status status = classify();
    if (status == Status::optimal) status = factor(hint);
    // The hinted set first, as equalities: when it is the active set of this problem,
    // that is the answer (a tick whose active set did not change); else the full method.
    const bool shortcut = status == Status::optimal && hint.active_set != nullptr &&
                          solve_on_hinted_set(*hint.active_set, result, status) == Shortcut::solved;
    if (!shortcut) {
      if (status == Status::optimal) status = eliminate_equalities();
      // After repairs the full method starts from the repaired set (closer than the hint).
      const ActiveSet<MI>* warm = repaired_set_.size > 0 ? &repaired_set_ : hint.active_set;
      status = full_method(unless_ain_bad(status), warm, result);
    }
    if (status != Status::optimal && status != Status::maxiter) {
      const double nan = std::numeric_limits<double>::quiet_NaN();
      std::fill(result.x.begin(), result.x.end(), nan);
      std::fill(result.lambda_eq.begin(), result.lambda_eq.end(), nan);
      std::fill(result.lambda_in.begin(), result.lambda_in.end(), nan);
      result.active.clear();
    }
    result.iterations = iterations_;
    result.status = status;
    return status;
  }

 private:
  static constexpr int kLd = ((N + 3) / 4) * 4;  // padded leading dimension
  static constexpr int kMaxEqRows = ME + MI;
  static constexpr double kInf = std::numeric_limits<double>::infinity();
  static constexpr double kEps = std::numeric_limits<double>::epsilon();

  enum class RowKind : std::uint8_t { dead = 0, lower = 1, upper = 2, both = 3, equal = 4 };

  template <class T, int Size>
  using Buf = std::array<T, static_cast<std::size_t>(Size)>;

  static bool finite(double v) noexcept { return std::isfinite(v); }

  // ---- step 0: validate and classify -------------------------------------
  Status classify() noexcept {
    const ProblemType& p = *p_;
    n_ = p.n;
    np_ = dense::padded(std::max(0, std::min(p.n, N)));
    if (p.n < 1 || p.n > N || p.meq < 0 || p.meq > ME || p.mi < 0 || p.mi > MI) return Status::bad_input;
    meq_ = p.meq;
    mi_ = p.mi;
    if (!dense::all_finite(p.gradient.data(), n_) || !dense::all_finite(p.beq_values.data(), meq_))
      return Status::bad_input;
    // Sums of squares along the rows of H and Aeq: finite ones prove every entry
    // finite; only a non-finite one (NaN, inf, or overflow of huge entries) needs
    // the entries checked. The same pass over H finds the variables it couples (a
    // row or column with an off-diagonal non-zero: for a symmetric H exactly the
    // coupled ones, otherwise more, never fewer; a solve reads the lower triangle, whose
    // h_ij couples i by its row and j by its column).
    dense::row_squares_and_offdiagonal_bits(p.hessian.data(), N, n_, h_row_sq_.data(), row_bits_.data(),
                                            coupled_.data());
    dense::row_squares(p.aeq.data(), ME, meq_, n_, eq_row_sq_.data());
    if (!dense::all_finite(h_row_sq_.data(), n_) || !dense::all_finite(eq_row_sq_.data(), meq_)) {
      for (int j = 0; j < n_; ++j) {
        if (!dense::all_finite(p.hessian.data() + idx(0, j, N), n_)) return Status::bad_input;
        if (!dense::all_finite(p.aeq.data() + idx(0, j, ME), meq_)) return Status::bad_input;
      }
    }
    for (int j = 0; j < n_; ++j) coupled_[j] = row_bits_[j] != 0 || coupled_[j] != 0 ? 1 : 0;

    // The rows' kinds from their bounds. Ain itself is read first by the first
    // most_violated(), which computes its row norms together with Ain x and settles
    // zero rows (rows_checked_); the exits before that check it here (check_rows()).
    // Also what most_violated() reads: the bounds a row can violate (+-inf where it has
    // no such side, is dead, or is an equality of the block) and their magnitudes.
    int nan_bound = 0, infeasible = 0;
    dense::classify_bounds(p.lower.data(), p.upper.data(), mi_, kInfiniteBound, lo_eff_.data(), hi_eff_.data(),
                           lo_abs_.data(), hi_abs_.data(), reinterpret_cast<std::uint8_t*>(kind_.data()), nan_bound,
                           infeasible);
    if (nan_bound) return Status::bad_input;
    rows_checked_ = false;
    std::fill_n(have_t_.begin(), mi_, false);
    return infeasible ? Status::infeasible : Status::optimal;
  }

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

  // ---- step 1: Cholesky ----------------------------------------------------
  // The lower triangle of H equals the one last factored with reuse_factor set.
  bool same_factored_hessian() const noexcept {
    if (!have_factored_h_ || factored_n_ != n_) return false;
    for (int j = 0; j < n_; ++j) {
      const std::size_t at = idx(j, j, N);
      if (std::memcmp(p_->hessian.data() + at, factored_h_.data() + at, sizeof(double) * static_cast<std::size_t>(n_ - j)) != 0)
        return false;
    }
    return true;
  }

  // Orders the coupled variables (coupled_, from the lower triangle of H or of the
  // caller's factor: a diagonal row of H is a diagonal row of its Cholesky factor)
  // first, in their original order, then the separable ones.
  void order_variables() noexcept {
    nc_ = 0;
    for (int j = 0; j < n_; ++j)
      if (coupled_[j] != 0) perm_[nc_++] = j;
    int k = nc_;
    for (int j = 0; j < n_; ++j)
      if (coupled_[j] == 0) perm_[k++] = j;
    for (k = 0; k < n_; ++k) ain_offset_[k] = idx(0, perm_[k], MI);
  }

  Status factor(const Hint& hint) noexcept {
    const ProblemType& p = *p_;
    const double* given_lower = hint.cholesky_lower;
    if (given_lower == nullptr && hint.reuse_factor && same_factored_hessian()) return Status::optimal;
    have_factored_h_ = false;
    if (given_lower != nullptr) {
      // The factor couples exactly the variables H couples (classify() found those): a
      // variable whose row and column of L are zero off the diagonal has them zero in
      // L L' too, and one with a zero L entry where H has none got it from L's other
      // entries in that row. So a factor of another matrix (a caller whose H gained an
      // entry its factor's structure lacks) shows here, and is bad input.
      std::copy_n(coupled_.begin(), n_, h_coupled_.begin());
      if (!dense::scan_lower_triangle(given_lower, N, n_, row_bits_.data(), coupled_.data()) ||
          !std::equal(coupled_.begin(), coupled_.begin() + n_, h_coupled_.begin()))
        return Status::bad_input;
    }
    const double* source = given_lower != nullptr ? given_lower : p.hessian.data();
    order_variables();
    const int ncp = dense::padded(nc_);
    double max_diag = 0.0;
    for (int k = 0; k < n_; ++k) max_diag = std::max(max_diag, std::abs(source[idx(perm_[k], perm_[k], N)]));
    // The coupled block, permuted, into l_ (rows past nc_ zero); Cholesky in place,
    // or the caller's L scaled to U = L D^-1 with zeros from the chunk start to the
    // diagonal (the layout cholesky_lower leaves).
    if (given_lower != nullptr) {
      for (int k = 0; k < n_; ++k) {
        const double diag = source[idx(perm_[k], perm_[k], N)];
        if (!(diag > 0.0)) return Status::bad_input;
        inv_diag_[k] = 1.0 / diag;
      }
      for (int b = 0; b < nc_; ++b) {
        double* col = lcol(b);
        const double* src = source + idx(0, perm_[b], N);
        const double scale = inv_diag_[b];
        for (int a = dense::chunk_start(b); a < ncp; ++a) col[a] = a > b && a < nc_ ? src[perm_[a]] * scale : 0.0;
      }
    } else {
      for (int b = 0; b < nc_; ++b) {
        double* col = lcol(b);
        const double* src = source + idx(0, perm_[b], N);
        for (int a = dense::chunk_start(b); a < b; ++a) col[a] = 0.0;
        for (int a = b; a < nc_; ++a) col[a] = src[perm_[a]];
        for (int a = nc_; a < ncp; ++a) col[a] = 0.0;
      }
      const double min_pivot = static_cast<double>(n_) * kEps * max_diag;
      if (!dense::cholesky_lower(l_.data(), kLd, nc_, min_pivot, inv_diag_.data()))
        return Status::not_positive_definite;
      for (int k = nc_; k < n_; ++k) {
        const double pivot = source[idx(perm_[k], perm_[k], N)];
        if (!(pivot > min_pivot)) return Status::not_positive_definite;
        inv_diag_[k] = 1.0 / std::sqrt(pivot);
      }
      if (hint.reuse_factor) {  // keep the H of this factor for the next solve
        for (int j = 0; j < n_; ++j) std::copy_n(p.hessian.data() + idx(j, j, N), n_ - j, factored_h_.data() + idx(j, j, N));
        factored_n_ = n_;
        have_factored_h_ = true;
      }
    }
    std::fill(inv_diag_.begin() + n_, inv_diag_.begin() + np_, 0.0);  // keeps padding zero
    return Status::optimal;
  }

  // y <- L^-1 y (permuted coordinates, padded) for `cols` vectors: the coupled block by
  // unit forward substitution, then D^-1 on every variable (the separable ones' L).
  template <class Column>
  void solve_lower_each(int cols, Column column) noexcept {
    dense::unit_forward_solve_each(l_.data(), kLd, nc_, cols, column);
    for (int c = 0; c < cols; ++c) dense::scale_chunks(inv_diag_.data(), column(c), np_);
  }
  void solve_lower(double* y, int ldy = 0, int cols = 1) noexcept {
    solve_lower_each(cols, [y, ldy](int c) noexcept { return y + c * ldy; });
  }

  // Row `row` of Ain in the variable order (offsets of its entries precomputed), zero
  // padding to np_.
  void gather_ain_row(int row, double* dst) const noexcept {
    const double* src = p_->ain.data() + row;
    for (int k = 0; k < n_; ++k) dst[k] = src[ain_offset_[k]];
    std::fill(dst + n_, dst + np_, 0.0);
  }
  // dst[k] = src[perm_[k]] for the n_ variables, zero padding to np_.
  void gather(const double* src, double* dst) const noexcept {
    for (int k = 0; k < n_; ++k) dst[k] = src[perm_[k]];
    std::fill(dst + n_, dst + np_, 0.0);
  }

  // ---- step 2: the equality block --------------------------------------------
  // The equality rows (Aeq's, then the lb == ub rows of Ain), permuted, into columns
  // 0 .. me_-1 of b_ (zero-padded), their right-hand sides, sources and row norms.
  void load_equalities() noexcept {
    const ProblemType& p = *p_;
    // Aeq's rows: a transposing copy that reads each column of Aeq once, contiguously.
    int k = 0;
    for (; k + 4 <= n_; k += 4) {  // four variables at a time: one chunk store per row
      const double* c0 = p.aeq.data() + idx(0, perm_[k], ME);
      const double* c1 = p.aeq.data() + idx(0, perm_[k + 1], ME);
      const double* c2 = p.aeq.data() + idx(0, perm_[k + 2], ME);
      const double* c3 = p.aeq.data() + idx(0, perm_[k + 3], ME);
      int r = 0;
      for (; r + 4 <= meq_; r += 4) dense::copy_transposed4(c0 + r, c1 + r, c2 + r, c3 + r, bcol(r) + k, kLd);
      for (; r < meq_; ++r) dense::store4(bcol(r) + k, c0[r], c1[r], c2[r], c3[r]);
    }
    for (; k < n_; ++k) {
      const double* col = p.aeq.data() + idx(0, perm_[k], ME);
      for (int r = 0; r < meq_; ++r) bcol(r)[k] = col[r];
    }
    for (me_ = 0; me_ < meq_; ++me_) {
      std::fill(bcol(me_) + n_, bcol(me_) + np_, 0.0);
      eq_row_norm_[me_] = std::sqrt(eq_row_sq_[me_]);
      eq_rhs_[me_] = p.beq_values[me_];
      eq_src_[me_] = me_;
    }
    for (int i = 0; i < mi_; ++i) {
      if (kind_[i] != RowKind::equal) continue;
      gather_ain_row(i, bcol(me_));
      eq_row_norm_[me_] = row_norm_[i] = std::sqrt(dense::dot_chunks(bcol(me_), bcol(me_), np_));
      eq_rhs_[me_] = p.lower[i];
      eq_src_[me_] = -1 - i;
      ++me_;
    }
  }

  Status eliminate_equalities() noexcept {
    const ProblemType& p = *p_;
    // g rides along as column me_: the same solve and reflectors give c = Q' L^-1 g.
    double* gcol = bcol(me_);
    if (g_reduced_at_ >= 0) {  // solve_on_hinted_set left L^-1 E' in place, L^-1 g at that column
      if (g_reduced_at_ != me_) std::copy_n(bcol(g_reduced_at_), np_, gcol);
    } else {
      load_equalities();
      gcol = bcol(me_);
      gather(p.gradient.data(), gcol);
      solve_lower(bcol(0), kLd, me_ + 1);
    }
    for (int k = 0; k < me_; ++k) {
      eq_norm2_[k] = dense::dot_chunks(bcol(k), bcol(k), np_);
      eq_left2_[k] = eq_norm2_[k];
    }
    // Householder QR with column pivoting on the relative remaining norm.
    rank_ = 0;
    const double rel_tol2 = options_.rank_tol * options_.rank_tol;
    const int steps = std::min(n_, me_);
    for (int k = 0; k < steps; ++k) {
      int best = -1;
      double best_rel = rel_tol2;
      for (int j = k; j < me_; ++j) {
        if (!(eq_norm2_[j] > 0.0)) continue;
        const double rel = eq_left2_[j] / eq_norm2_[j];
        if (rel > best_rel) {
          best_rel = rel;
          best = j;
        }
      }
      if (best < 0) break;
      if (best != k) {
        std::swap_ranges(bcol(k), bcol(k) + n_, bcol(best));
        std::swap(eq_rhs_[k], eq_rhs_[best]);
        std::swap(eq_src_[k], eq_src_[best]);
        std::swap(eq_norm2_[k], eq_norm2_[best]);
        std::swap(eq_left2_[k], eq_left2_[best]);
        std::swap(eq_row_norm_[k], eq_row_norm_[best]);
      }
      double* bk = bcol(k);
      double scale = 0.0;
      tau_[k] = dense::make_householder(bk + k, dense::tail_squared_norm(bk, k + 1, np_), scale);
      double* vk = vcol(k);  // the full padded reflector: zeros above k, 1 at k (bk's tail is left unused)
      std::fill(vk, vk + dense::chunk_start(k), 0.0);
      dense::scaled_below(bk, k, np_, scale, 1.0, vk);
      if (tau_[k] != 0.0) {  // the reflector on columns k+1 .. me_ (g last) at once
        const int start = dense::chunk_start(k), len = np_ - start, cols = me_ - k;
        dense::gemv_t_chunks(bcol(k + 1) + start, kLd, len, cols, vk + start, eq_w_.data());
        for (int j = 0; j < cols; ++j) eq_w_[j] *= tau_[k];
        dense::sub_outer_chunks(vk + start, len, cols, eq_w_.data(), bcol(k + 1) + start, kLd);
      }
      for (int j = k + 1; j < me_; ++j) {
        const double* cj = bcol(j);
        // |c_j[k+1:]|^2 = |c_j[k:]|^2 - c_j[k]^2 (LAPACK-style downdate), recomputed
        // once cancellation has eaten more than three digits of it.
        const double left2 = eq_left2_[j] - cj[k] * cj[k];
        eq_left2_[j] = left2 > 1e-3 * eq_norm2_[j] ? left2 : dense::tail_squared_norm(cj, k + 1, np_);
      }
      ++rank_;
    }
    m_ = n_ - rank_;
    mp_ = dense::padded(m_);
    build_wy();
    // Condition estimate of the equality block from the pivoted QR's diagonal: the
    // accuracy with which the equalities pin x down (rounding-level tests scale with it).
    eq_cond_ = 1.0;
    if (rank_ > 0) {
      double big = 0.0, small = kInf;
      for (int k = 0; k < rank_; ++k) {
        big = std::max(big, std::abs(bcol(k)[k]));
        small = std::min(small, std::abs(bcol(k)[k]));
      }
      eq_cond_ = small > 0.0 ? big / small : kInf;
    }
    // v1 = Re^-T e (forward substitution with the transpose of the upper Re).
    for (int k = 0; k < rank_; ++k) {
      const double* ck = bcol(k);
      v1_[k] = (eq_rhs_[k] - dense::dot(ck, v1_.data(), k)) / ck[k];
    }
    // Dependent rows must be implied: e_j'x = rho_j'v1 for rho_j = R-part of column j.
    for (int j = rank_; j < me_; ++j) {
      const double* cj = bcol(j);
      double implied = 0.0, scale = std::abs(eq_rhs_[j]);
      for (int k = 0; k < rank_; ++k) {
        implied += cj[k] * v1_[k];
        scale += std::abs(cj[k] * v1_[k]);
      }
      if (std::abs(implied - eq_rhs_[j]) > 1e-9 * scale) return Status::infeasible;
    }
    // c = Q' L^-1 g; the unconstrained reduced minimiser is w0 = -c[r:].
    std::copy_n(gcol, np_, c_.data());
    c_norm_ = std::sqrt(dense::dot_chunks(c_.data(), c_.data(), np_));
    return Status::optimal;
  }

  // Q = H_0 H_1 ... H_{r-1} is also kept in the compact WY form I - V T V' (Schreiber
  // and Van Loan 1989): T upper triangular, T_kk = tau_k, T[:k, k] = -tau_k T[:k, :k]
  // V[:, :k]' v_k, built once per equality block from V's columns (full, zero above
  // their row k). compute_x() applies Q every outer iteration: in this form that is two
  // passes of independent dot products and a small triangular product, where the
  // reflectors one at a time were a chain of r dependent dot-then-update steps. Q' on the rows
  // (reduce_queued) stays reflector by reflector: its queued rows already overlap, and
  // in WY form the opt-in QP soak's one ill-conditioned draw (seed 37 trial 48) moved.
  void build_wy() noexcept {
    for (int k = 0; k < rank_; ++k) {
      dense::gemv_t_chunks(v_.data(), kLd, np_, k, vcol(k), wy_s_.data());  // V[:, :k]' v_k
      upper_t_times_s(k);
      double* tk = wy_t_.data() + idx(0, k, kLd);
      for (int i = 0; i < k; ++i) tk[i] = -tau_[k] * wy_u_[i];
      tk[k] = tau_[k];
    }
  }
  // wy_u_ = T s for s = wy_s_, over T's leading k x k block.
  void upper_t_times_s(int k) noexcept {
    for (int i = 0; i < k; ++i) {
      double acc = 0.0;
      for (int j = i; j < k; ++j) acc += wy_t_[idx(i, j, kLd)] * wy_s_[j];
      wy_u_[i] = acc;
    }
  }
  // y <- Q y = y - V T V'y (y padded).
  void apply_q(double* y) noexcept {
    if (rank_ == 0) return;
    dense::gemv_t_chunks(v_.data(), kLd, np_, rank_, y, wy_s_.data());
    upper_t_times_s(rank_);
    dense::gemv_sub_chunks(v_.data(), kLd, np_, rank_, wy_u_.data(), y);
  }
  // y <- H_k y = (I - tau_k v_k v_k') y (y padded; v_k zero above row k).
  void apply_reflector(int k, double* y) noexcept {
    const double tau = tau_[k];
    if (tau == 0.0) return;
    const int start = dense::chunk_start(k);
    const double w = tau * dense::dot_chunks(vcol(k) + start, y + start, np_ - start);
    dense::axpy_chunks(-w, vcol(k) + start, y + start, np_ - start);
  }

  // Non-finite entries of Ain are bad input whatever else is wrong with the problem:
  // the exits before Ain is first read check it here.
  Status unless_ain_bad(Status s) noexcept {
    if ((s == Status::infeasible || s == Status::not_positive_definite) && check_rows(nullptr) == Status::bad_input)
      return Status::bad_input;
    return s;
  }

  // Row norms of Ain, with Ain x when x is given (one pass over Ain for both), zero
  // rows settled: a zero row is dead, or proves the problem infeasible when 0 lies
  // outside its bounds. Returns bad_input when Ain has a non-finite entry (a finite
  // sum of squares proves a row finite: only a non-finite one needs its entries
  // checked), infeasible for such a zero row, else optimal.
  Status check_rows(const double* x) noexcept {
    const ProblemType& p = *p_;
    if (x != nullptr)
      dense::gemv_and_row_squares(p.ain.data(), MI, mi_, n_, x, slack_.data(), row_norm_.data());
    else
      dense::row_squares(p.ain.data(), MI, mi_, n_, row_norm_.data());
    if (!dense::all_finite(row_norm_.data(), mi_)) {
      for (int j = 0; j < n_; ++j)
        if (!dense::all_finite(p.ain.data() + idx(0, j, MI), mi_)) return Status::bad_input;
    }
    bool infeasible = false;
    for (int i = 0; i < mi_; ++i) {
      row_norm_[i] = std::sqrt(row_norm_[i]);
      if (row_norm_[i] == 0.0 && kind_[i] != RowKind::dead) {  // zero row: 0 must lie in [lb, ub]
        const double lo = p.lower[i], hi = p.upper[i];
        if ((lo > -kInfiniteBound && lo > 0.0) || (hi < kInfiniteBound && hi < 0.0)) infeasible = true;
        if (kind_[i] != RowKind::equal) kind_[i] = RowKind::dead;  // an equal one is in the block already
        lo_eff_[i] = -kInf;
        hi_eff_[i] = kInf;
      }
    }
    rows_checked_ = true;
    return infeasible ? Status::infeasible : Status::optimal;
  }

  // t_i = Q' L^-1 a_i, cached per solve (have_t_), and the norm of its reduced part
  // (red_norm_). Rows are queued (their Ain row gathered) and reduced together: one
  // multi-column forward solve, then Q'.
  void queue_reduction(int row, int& queued) noexcept {
    gather_ain_row(row, tvec(row));
    have_t_[row] = true;
    batch_row_[queued++] = row;
  }
  void reduce_queued(int queued) noexcept {
    if (queued == 0) return;
    solve_lower_each(queued, [this](int c) noexcept { return tvec(batch_row_[c]); });
    for (int k = 0; k < rank_; ++k)
      for (int c = 0; c < queued; ++c) apply_reflector(k, tvec(batch_row_[c]));
    for (int c = 0; c < queued; ++c) {
      const double* t = tvec(batch_row_[c]);
      const double reduced = std::sqrt(dense::dot(t + rank_, t + rank_, m_));
      const double full = std::sqrt(dense::dot_chunks(t, t, np_));
      red_norm_[batch_row_[c]] = std::max({reduced, kMinReducedShare * full, std::numeric_limits<double>::min()});
    }
  }
  const double* t_of(int row) noexcept {
    if (!have_t_[row]) {
      int queued = 0;
      queue_reduction(row, queued);
      reduce_queued(queued);
    }
    return tvec(row);
  }

  // Reduced constraint of row `row` on side sigma (+1 lower, -1 upper): np'w >= rhs.
  // Writes np into np_vec_ and |L^-1 a| (the scale for dependence tests: np itself is
  // only rounding noise when the row lies in the span of the equalities) into
  // full_norm_; returns rhs.
  double reduced_row(int row, int sigma) noexcept {
    const double* t = t_of(row);
    full_norm_ = std::sqrt(dense::dot_chunks(t, t, np_));
    const double h = dense::dot(t, v1_.data(), rank_);
    const double* at = t + rank_;
    const double s = static_cast<double>(sigma);
    for (int i = 0; i < m_; ++i) np_vec_[i] = s * at[i];
    for (int i = m_; i < mp_; ++i) np_vec_[i] = 0.0;
    np_sq_ = dense::dot_chunks(np_vec_.data(), np_vec_.data(), mp_);
    return sigma > 0 ? p_->lower[row] - h : h - p_->upper[row];
  }

  // z = np - Q1 Q1'np by classical Gram-Schmidt, d = Q1'np; returns |z|^2. A second
  // pass only when the first cancelled more than half of |np|^2 (|z| < |np| / sqrt 2,
  // the Daniel-Gragg-Kaufman-Stewart criterion: "twice is enough", and once is enough
  // without that cancellation). Reduced vectors and the columns of Q1 are zero-padded
  // to mp_, so whole chunks are used.
  double project() noexcept {
    std::copy_n(np_vec_.data(), mp_, z_.data());
    if (q_ == 0) return np_sq_;
    dense::gemv_t_chunks(q1_.data(), kLd, mp_, q_, z_.data(), d_.data());
    dense::gemv_sub_chunks(q1_.data(), kLd, mp_, q_, d_.data(), z_.data());
    const double zz = dense::dot_chunks(z_.data(), z_.data(), mp_);
    if (zz >= 0.5 * np_sq_) return zz;
    dense::gemv_t_chunks(q1_.data(), kLd, mp_, q_, z_.data(), e_.data());
    dense::gemv_sub_chunks(q1_.data(), kLd, mp_, q_, e_.data(), z_.data());
    for (int j = 0; j < q_; ++j) d_[j] += e_[j];
    return dense::dot_chunks(z_.data(), z_.data(), mp_);
  }

  void append(int row, int sigma, double rhs, double np_norm, double z_norm, double multiplier) noexcept {
    double* qc = q1col(q_);
    const double inv = 1.0 / z_norm;
    for (int i = 0; i < mp_; ++i) qc[i] = z_[i] * inv;  // padding stays zero
    double* rc = rcol(q_);
    std::copy_n(d_.data(), q_, rc);
    rc[q_] = z_norm;
    std::fill(rc + q_ + 1, rc + dense::padded(q_ + 1), 0.0);  // column j of R: zero below j in its chunk
    u_[q_] = multiplier;
    act_row_[q_] = row;
    act_sigma_[q_] = static_cast<std::int8_t>(sigma);
    act_rhs_[q_] = rhs;
    act_norm_[q_] = np_norm;
    active_side_[row] = static_cast<std::int8_t>(sigma);
    ++q_;
    ++epoch_;
  }

  // Remove active constraint k; restore R upper triangular by Givens rotations,
  // applied to the columns of Q1 as well (N = Q1 R stays true).
  void drop(int k) noexcept {
    ++epoch_;
    active_side_[act_row_[k]] = 0;
    for (int j = k; j + 1 < q_; ++j) {
      std::copy_n(rcol(j + 1), j + 2, rcol(j));
      u_[j] = u_[j + 1];
      act_row_[j] = act_row_[j + 1];
      act_sigma_[j] = act_sigma_[j + 1];
      act_rhs_[j] = act_rhs_[j + 1];
      act_norm_[j] = act_norm_[j + 1];
    }
    for (int j = k; j + 1 < q_; ++j) {
      double c = 1.0, s = 0.0;
      double* rj = rcol(j);
      rj[j] = dense::givens(rj[j], rj[j + 1], c, s);
      rj[j + 1] = 0.0;
      for (int col = j + 1; col + 1 < q_; ++col) {
        double* rc = rcol(col);
        const double a = rc[j], b = rc[j + 1];
        rc[j] = c * a + s * b;
        rc[j + 1] = c * b - s * a;
      }
      dense::rotate_chunks(c, s, q1col(j), q1col(j + 1), mp_);  // zero padding stays zero
    }
    --q_;
  }

  // r = R^-1 d (back substitution by columns: R is stored by columns, each zero below
  // its diagonal to the end of the diagonal's chunk, so whole chunks are used: the
  // entries after j in that chunk, final already, lose v * 0). The reciprocals of the
  // diagonal come first: independent divisions, off the substitution's chain, which
  // then multiplies (a division on the chain costs a divider's latency per column).
  void solve_r(const double* d, double* out) noexcept {
    std::copy_n(d, q_, out);
    for (int j = 0; j < q_; ++j) r_inv_diag_[j] = 1.0 / rcol(j)[j];
    for (int j = q_ - 1; j >= 0; --j) {
      const double* rj = rcol(j);
      const double v = out[j] * r_inv_diag_[j];
      dense::axpy_chunks(-v, rj, out, dense::chunk_start(j) + 4);
      out[j] = v;
    }
  }

  // x = P' L^-T Q [v1; w] (P: the variable order); also |x|_2.
  void compute_x() noexcept {
    double* y = xp_.data();
    std::copy_n(v1_.data(), rank_, y);
    std::copy_n(w_.data(), m_, y + rank_);
    std::fill(y + n_, y + np_, 0.0);
    apply_q(y);
    dense::scale_chunks(inv_diag_.data(), y, np_);
    dense::unit_backward_solve_transposed(l_.data(), kLd, nc_, y);
    for (int k = 0; k < n_; ++k) x_[perm_[k]] = y[k];
    x_norm_ = std::sqrt(dense::squared_norm(x_.data(), n_));
  }

  // The most violated inactive row, or -1. A violation counts beyond feasibility_tol
  // max(|a_i| |x|, |bound|); among those rows the pick is the largest violation / |np_i|,
  // np_i the row in the reduced coordinates (the violation's distance in the metric of
  // H on the equalities' null space: the row whose addition alone would raise the
  // objective most). Against violation / |a_i| this halves the iterations of the long
  // shared instances (wbc_sat_torque_08: 132 -> 54). A row nearly in the span of the
  // equalities (|np_i| < kMinReducedShare |t_i|) counts with that share instead: its
  // violation would drive a step of violation / |np_i|^2 that is mostly rounding.
  // The t_i it needs are those of the violated rows only, each cached for when its row
  // is added. The first call of a solve reads Ain once for its row norms and Ain x
  // (check_rows()); it returns kStop with stop_status_ when Ain is bad input or a zero
  // row makes the problem infeasible.
  int most_violated(int& sigma) noexcept {
    const ProblemType& p = *p_;
    if (!rows_checked_) {
      stop_status_ = check_rows(x_.data());
      if (stop_status_ != Status::optimal) return kStop;
    } else {
      dense::gemv(p.ain.data(), MI, mi_, n_, x_.data(), slack_.data());  // Ain x for every row
    }
    const double tol = options_.feasibility_tol, xn = x_norm_;
    int candidates = 0, queued = 0;
    for (int i = 0; i < mi_; ++i) {
      bool lower_side = false;
      double limit = 0.0;
      const double viol = violation(i, xn, tol, lower_side, limit);
      if (viol > limit && active_side_[i] == 0 && skipped_epoch_[i] != epoch_ && i != ignored_row_) {
        cand_row_[candidates] = i;
        cand_viol_[candidates] = lower_side ? viol : -viol;
        ++candidates;
        if (!have_t_[i]) queue_reduction(i, queued);
      }
    }
    reduce_queued(queued);
    int best = -1;
    double best_score = 0.0;
    for (int c = 0; c < candidates; ++c) {
      const int i = cand_row_[c];
      const double viol = std::abs(cand_viol_[c]);
      if (viol > best_score * red_norm_[i]) {
        best_score = viol / red_norm_[i];
        best = i;
        sigma = cand_viol_[c] > 0.0 ? 1 : -1;
      }
    }
    return best;
  }

  // Every inactive row within most_violated()'s tolerance at x_ (slack_ must be Ain x_).
  // Off the per-iteration path: only after a refinement.
  [[gnu::noinline]] bool inactive_rows_inside() const noexcept {
    const double tol = options_.feasibility_tol;
    for (int i = 0; i < mi_; ++i) {
      if (active_side_[i] != 0 || skipped_epoch_[i] == epoch_ || i == ignored_row_) continue;
      bool lower_side = false;
      double limit = 0.0;
      if (violation(i, x_norm_, tol, lower_side, limit) > limit) return false;
    }
    return true;
  }

  // Row i's violation at slack_[i] (> 0 outside its bounds; at most one side can be
  // violated), the side and the magnitude of that side's bound.
  double side_violation(int i, bool& lower_side, double& bound) const noexcept {
    const double s = slack_[i];
    const double below = lo_eff_[i] - s, above = s - hi_eff_[i];
    lower_side = below >= above;
    bound = lower_side ? lo_abs_[i] : hi_abs_[i];
    return lower_side ? below : above;
  }
  // side_violation() and the tolerance it must exceed to count: tol max(|a_i| |x|,
  // |bound|) for |x| = xn.
  double violation(int i, double xn, double tol, bool& lower_side, double& limit) const noexcept {
    double bound = 0.0;
    const double viol = side_violation(i, lower_side, bound);
    limit = tol * std::max(row_norm_[i] * xn, bound);
    return viol;
  }

  // |[v1; w]| = |L' x|.
  double v_norm() const noexcept {
    return std::sqrt(dense::squared_norm(v1_.data(), rank_) + dense::dot_chunks(w_.data(), w_.data(), mp_));
  }

  bool count_iteration() noexcept { return ++iterations_ <= max_iterations_; }

  // The side (+1 lower, -1 upper) of a hinted row that can be active there, else 0.
  int hinted_sigma(int row, Side side) const noexcept {
    if (row < 0 || row >= mi_ || side == Side::equal) return 0;
    const RowKind kind = kind_[row];
    const int sigma = side == Side::lower ? 1 : -1;
    if (kind == RowKind::dead || kind == RowKind::equal) return 0;
    if ((sigma > 0 && kind == RowKind::upper) || (sigma < 0 && kind == RowKind::lower)) return 0;
    return sigma;
  }

  // t_i for every valid hinted row at once.
  void reduce_hinted_rows(const ActiveSet<MI>& hint, int count) noexcept {
    int queued = 0;
    for (int e = 0; e < count; ++e) {
      const int row = hint.row[static_cast<std::size_t>(e)];
      if (hinted_sigma(row, hint.side[static_cast<std::size_t>(e)]) != 0 && !have_t_[row]) queue_reduction(row, queued);
    }
    reduce_queued(queued);
  }

  // Warm start: add the hinted rows (skipping invalid or dependent ones), take the
  // minimiser on that set, drop rows with a wrong-sign multiplier one at a time.
  void warm_start(const ActiveSet<MI>& hint) noexcept {
    const int count = std::min(hint.size, MI);
    reduce_hinted_rows(hint, count);
    for (int e = 0; e < count && q_ < m_; ++e) {
      const int row = hint.row[static_cast<std::size_t>(e)];
      const int sigma = hinted_sigma(row, hint.side[static_cast<std::size_t>(e)]);
      if (sigma == 0 || active_side_[row] != 0) continue;
      const double rhs = reduced_row(row, sigma);
      const double np_norm = full_norm_;
      const double z_norm = std::sqrt(project());
      if (q_ >= m_ || !(z_norm > dependence_tol() * np_norm)) continue;
      append(row, sigma, rhs, np_norm, z_norm, 0.0);
    }
    for (;;) {
      // beta = R^-T rhs - Q1'w0, u = R^-1 beta.
      for (int j = 0; j < q_; ++j) {
        const double* rj = rcol(j);
        double v = act_rhs_[j];
        for (int l = 0; l < j; ++l) v -= rj[l] * beta_[l];
        beta_[j] = v / rj[j];
      }
      for (int j = 0; j < q_; ++j) beta_[j] -= dense::dot_chunks(q1col(j), w_.data(), mp_);
      solve_r(beta_.data(), u_.data());
      int worst = -1;
      double worst_u = 0.0;
      for (int j = 0; j < q_; ++j) {
        if (u_[j] < worst_u) {
          worst_u = u_[j];
          worst = j;
        }
      }
      if (worst < 0) break;
      drop(worst);
      ++iterations_;
    }
    for (int j = 0; j < q_; ++j) dense::axpy(beta_[j], q1col(j), w_.data(), m_);
  }

  double dependence_tol() const noexcept { return 1e-8; }
  // Relative size of a violation that the reduced coordinates cannot resolve: 1e-11,
  // or more (at most 1e-9) when an ill-conditioned equality block pins x down less
  // accurately.
  double rounding_level() const noexcept { return std::clamp(64.0 * kEps * eq_cond_, 1e-13, 1e-9); }

  // An infeasible verdict whose gap (the violation the active rows cannot trade away)
  // is within 1e-6 of the path it was measured on may be rounding that beat a
  // degenerate vertex. Such a verdict gets a second, cold run that leaves the row
  // out; its answer stands only if it satisfies that row after all (violation at most
  // 1e-9 max(1, |a| |x|, |bound|), or 1e-11 of the reduced path's scale); otherwise the
  // problem is infeasible.
  Status attempt(const ActiveSet<MI>* warm) noexcept {
    ignored_row_ = -1;
    const Status status = run(warm);
    return status == Status::infeasible ? second_opinion() : status;
  }
  Status second_opinion() noexcept {
    if (!(verdict_gap_ <= 1e-6) || verdict_row_ < 0) return Status::infeasible;
    ignored_row_ = verdict_row_;
    const int spent = iterations_;
    iterations_ = 0;
    Status status = run(nullptr);
    iterations_ += spent;
    if (status != Status::optimal) return Status::infeasible;
    const int row = ignored_row_;
    // slack_ is Ain x for this answer (its last most_violated() ignored only the choice).
    const double viol = std::max(lo_eff_[row] - slack_[row], slack_[row] - hi_eff_[row]);
    const double bound = std::max(lo_abs_[row], hi_abs_[row]);
    // Within 1e-9 of the row's scale, or within what the reduced coordinates resolve
    // along the path this answer was computed on (|L^-1 a| max(|v|, |c|)).
    const double* t = tvec(row);  // reduced when the first run picked the row
    const double t_norm = have_t_[row] ? std::sqrt(dense::dot_chunks(t, t, np_)) : 0.0;
    const double reduced_scale = t_norm * std::max(v_norm(), c_norm_) + bound;
    const double limit = std::max(1e-9 * std::max({1.0, row_norm_[row] * x_norm_, bound}), 1e-11 * reduced_scale);
    return viol <= limit ? Status::optimal : Status::infeasible;
  }

  // ---- the hinted set as equalities (a warm start's first try) ----------------
  // A controller's active set rarely changes from one tick to the next. With the
  // hinted rows (on their hinted sides) and the equalities taken as active, the
  // minimiser solves
  //   S lam = b + B'c,  S = B'B,  B = L^-1 [E' A_h'],  c = L^-1 g,
  //   v = B lam - c,    x = L^-T v        (so H x + g = [E' A_h'] lam)
  // by a Cholesky factor of S and one refinement step (corrected semi-normal
  // equations). That x is the answer when every hinted row's multiplier has its
  // side's sign, every row holds within the full method's tolerance, the active rows
  // are met to it, and the stationarity check passes; the multipliers are -lam. Any
  // thing else - nearly dependent rows (a pivot of S below 1e-8 of its diagonal: S
  // squares B's conditioning), a wrong sign, a violated row - falls back to the full
  // method (which starts from the same hint). On a tick whose active set did not
  // change this skips the QR of the equality block and the GI machinery.
  //
  // A hint a few rows off (rows that became active since the last tick, or left: wrong signs)
  // is repaired here, up to kShortcutRepairs times: every hinted row whose multiplier has the
  // wrong sign leaves the set, else the most violated row joins it on its violated side, and
  // the set is solved again (one column of B and one row and column of S change; the small
  // Cholesky of S is redone). A repaired set's answer passes the same checks (and so is the
  // QP's unique minimiser); result.iterations counts the repairs. In the trots a force ramp's
  // end changes four to six rows at once, hence several repairs, and every wrong sign leaving
  // at once rather than one per repair.
  enum class Shortcut : std::uint8_t { solved, fallback };
  Shortcut solve_on_hinted_set(const ActiveSet<MI>& hint, ResultType& result, Status& status) noexcept {
    const ProblemType& p = *p_;
    load_equalities();
    if (me_ > n_) return Shortcut::fallback;
    int cols = me_;
    const int count = std::min(hint.size, MI);
    for (int e = 0; e < count; ++e) {
      const int row = hint.row[static_cast<std::size_t>(e)];
      const int sigma = hinted_sigma(row, hint.side[static_cast<std::size_t>(e)]);
      if (sigma == 0) continue;
      // More active rows than variables are dependent; a hint that repeats rows could
      // also outgrow the block's columns (kMaxEqRows, g after them).
      if (cols >= n_ || cols >= kMaxEqRows) return Shortcut::fallback;
      load_set_row(cols++, row, sigma);
    }
    gather(p.gradient.data(), bcol(cols));  // g rides along: c = L^-1 g
    solve_lower(bcol(0), kLd, cols + 1);
    g_reduced_at_ = cols;  // a fallback's equality block starts from these columns
    gram_cols_ = 0;        // S is new: no factor of it yet
    // S = B'B's lower triangle (kept: a repair changes one row and column of it).
    const int cp = dense::padded(cols);
    for (int j = 0; j < cols; ++j) {
      double* sj = scol(j);
      dense::gemv_t_chunks(bcol(j), kLd, np_, cols - j, bcol(j), sj + j);
      std::fill(sj + cols, sj + cp, 0.0);
    }
    for (int repair = 0;; ++repair) {
      SetRepair fix;
      if (solve_on_set(cols, result, status, fix) == Shortcut::solved) return Shortcut::solved;
      if (fix.kind == SetRepair::Kind::none || repair == kShortcutRepairs) {
        if (repair > 0) {  // the full method starts from where the repairs got
          for (int k = me_; k < cols; ++k) repaired_set_.push(-1 - eq_src_[k], hinted_side_[k] > 0 ? Side::lower : Side::upper);
        }
        return Shortcut::fallback;
      }
      if (fix.kind == SetRepair::Kind::add) {
        if (!add_set_column(cols, fix.row, fix.sigma)) return Shortcut::fallback;
      } else {  // every wrong-signed row at once (right to left: the columns left stay put)
        for (int k = fix.drops - 1; k >= 0; --k) drop_set_column(cols, drop_col_[k]);
        gram_cols_ = std::min(gram_cols_, drop_col_[0]);  // the factor's rows before the first drop stay
      }
      ++iterations_;
    }
  }

  // What would make a failed set fit: Ain's row to add (on side sigma), or the block's
  // columns (>= me_) to drop; none: fall back to the full method.
  struct SetRepair {
    enum class Kind : std::uint8_t { none, add, drop } kind = Kind::none;
    int row = -1;          // add: Ain's row
    std::int8_t sigma = 0;  // add: its side
    int drops = 0;          // drop: the block's columns drop_col_[0 .. drops-1], ascending
  };

  // Ain's row `row`, active on side sigma, into the block's column k (permuted, not yet
  // reduced by L), with its norm, right-hand side and source.
  void load_set_row(int k, int row, int sigma) noexcept {
    gather_ain_row(row, bcol(k));
    eq_row_norm_[k] = row_norm_[row] = std::sqrt(dense::dot_chunks(bcol(k), bcol(k), np_));
    eq_rhs_[k] = sigma > 0 ? p_->lower[row] : p_->upper[row];
    eq_src_[k] = -1 - row;
    hinted_side_[k] = static_cast<std::int8_t>(sigma);
  }

  // A repair's added row: L^-1 a into column `cols` (c moves one column right), S's new row.
  bool add_set_column(int& cols, int row, std::int8_t sigma) noexcept {
    if (cols >= n_ || cols >= kMaxEqRows) return false;
    std::copy_n(bcol(cols), np_, bcol(cols + 1));
    load_set_row(cols, row, sigma);
    solve_lower(bcol(cols), kLd, 1);
    const int cp = dense::padded(cols + 1);
    for (int j = 0; j <= cols; ++j) {
      double* sj = scol(j);
      sj[cols] = dense::dot_chunks(bcol(j), bcol(cols), np_);
      std::fill(sj + cols + 1, sj + cp, 0.0);
    }
    ++cols;
    g_reduced_at_ = cols;
    return true;
  }

  // A repair's dropped column k (me_ <= k < cols): the columns right of it and c move one
  // left, and S loses row and column k.
  void drop_set_column(int& cols, int k) noexcept {
    for (int j = k; j < cols; ++j) std::copy_n(bcol(j + 1), np_, bcol(j));
    for (int j = k; j + 1 < cols; ++j) {
      eq_row_norm_[j] = eq_row_norm_[j + 1];
      eq_rhs_[j] = eq_rhs_[j + 1];
      eq_src_[j] = eq_src_[j + 1];
      hinted_side_[j] = hinted_side_[j + 1];
    }
    for (int j = 0; j < k; ++j) {
      double* sj = scol(j);
      for (int i = k; i + 1 < cols; ++i) sj[i] = sj[i + 1];
      sj[cols - 1] = 0.0;
    }
    for (int j = k; j + 1 < cols; ++j) {
      double* dst = scol(j);
      const double* src = scol(j + 1);
      for (int i = j; i + 1 < cols; ++i) dst[i] = src[i + 1];
      dst[cols - 1] = 0.0;
    }
    --cols;
    g_reduced_at_ = cols;
  }

  // The factor of S's leading (cols - 1) x (cols - 1) block extended to cols: its columns
  // stay, its new row j = cols - 1 is U_j = (U^-1 s)' D^-2 with s = S's row j left of the
  // diagonal, and the new pivot S_jj - s' U^-T D^-2 U^-1 s (below 1e-8 S_jj: dependent
  // rows, false).
  bool append_gram_row(int cols) noexcept {
    const int j = cols - 1, jp = dense::padded(j), cp = dense::padded(cols);
    double* y = gram_row_.data();
    for (int l = 0; l < j; ++l) y[l] = scol(l)[j];
    std::fill(y + j, y + jp, 0.0);
    dense::unit_forward_solve_each(gram_.data(), kLd, j, 1, [y](int) noexcept { return y; });
    double pivot = scol(j)[j];
    for (int l = 0; l < j; ++l) {
      const double u = y[l] * gram_inv_diag_[l];
      gcol(l)[j] = u;
      pivot -= y[l] * u;
      std::fill(gcol(l) + cols, gcol(l) + cp, 0.0);  // padding rows (new when cols passed a chunk)
    }
    gram_min_pivot_[j] = 1e-8 * scol(j)[j];
    if (!(pivot > gram_min_pivot_[j])) return false;
    std::fill(gcol(j) + dense::chunk_start(j), gcol(j) + cp, 0.0);
    gram_inv_diag_[j] = 1.0 / pivot;
    std::fill(gram_inv_diag_.begin() + cols, gram_inv_diag_.begin() + cp, 0.0);
    return true;
  }

  // The block's columns 0 .. cols-1 (the equalities, then the set's rows) taken as active,
  // L^-1 g in column cols, S in gram_s_.
  Shortcut solve_on_set(int cols, ResultType& result, Status& status, SetRepair& fix) noexcept {
    const ProblemType& p = *p_;
    const double* c = bcol(cols);
    // S's lower triangle into gram_ and its Cholesky factor in the layout of H's: a
    // pivot is the part of a column's squared norm left after the columns before it,
    // and one below 1e-8 of that squared norm means dependent rows. After a repair only
    // the rows past the columns it kept are computed (S's leading block, and so the
    // factor's, did not change): the added row, or the rows from the first dropped one on.
    const int cp = dense::padded(cols);
    if (gram_cols_ > 0 && gram_cols_ == cols) {  // only trailing rows dropped: clear their rows
      for (int l = 0; l < cols; ++l) std::fill(gcol(l) + cols, gcol(l) + cp, 0.0);
      std::fill(gram_inv_diag_.begin() + cols, gram_inv_diag_.begin() + cp, 0.0);
    } else if (gram_cols_ > 0 && gram_cols_ < cols) {
      for (int rows = gram_cols_ + 1; rows <= cols; ++rows)
        if (!append_gram_row(rows)) return Shortcut::fallback;
    } else {
      for (int j = 0; j < cols; ++j) {
        std::copy(scol(j) + j, scol(j) + cp, gcol(j) + j);
        gram_min_pivot_[j] = 1e-8 * scol(j)[j];
      }
      gram_cols_ = 0;
      if (!dense::cholesky_lower(gram_.data(), kLd, cols, 0.0, gram_inv_diag_.data(), gram_min_pivot_.data()))
        return Shortcut::fallback;
      for (int j = 0; j < cols; ++j) gram_inv_diag_[j] *= gram_inv_diag_[j];
      std::fill(gram_inv_diag_.begin() + cols, gram_inv_diag_.begin() + cp, 0.0);
    }
    gram_cols_ = cols;
    dense::gemv_t_chunks(bcol(0), kLd, np_, cols, c, lam_.data());
    for (int j = 0; j < cols; ++j) lam_[j] += eq_rhs_[j];
    solve_gram(lam_.data(), cols);
    // v = B lam - c (stationarity holds by construction whatever lam's rounding), then
    // one refinement step, lam += S^-1 (b - B'v), v += B (that step): the normal
    // equations square B's conditioning, the corrected ones recover what a QR of B
    // would give. (Skipping it when b - B'v is already at 1e-14 of the rows' scale left
    // x 1e-12 off: rows of norm 1e3 |x| then violated by 1e-8 in the soak.)
    double* v = hinted_v_.data();
    for (int j = 0; j < cols; ++j) step_[j] = -lam_[j];
    for (int i = 0; i < np_; ++i) v[i] = -c[i];
    dense::gemv_sub_chunks(bcol(0), kLd, np_, cols, step_.data(), v);
    dense::gemv_t_chunks(bcol(0), kLd, np_, cols, v, step_.data());
    for (int j = 0; j < cols; ++j) step_[j] = eq_rhs_[j] - step_[j];
    solve_gram(step_.data(), cols);
    for (int j = 0; j < cols; ++j) {
      lam_[j] += step_[j];
      step_[j] = -step_[j];
    }
    dense::gemv_sub_chunks(bcol(0), kLd, np_, cols, step_.data(), v);
    fix.drops = 0;
    for (int j = me_; j < cols; ++j) {
      if (static_cast<double>(hinted_side_[j]) * lam_[j] < 0.0) drop_col_[fix.drops++] = j;
    }
    if (fix.drops > 0) {
      fix.kind = SetRepair::Kind::drop;
      return Shortcut::fallback;
    }
    // x = L^-T v (permuted back).
    double* y = xp_.data();
    std::copy_n(v, np_, y);
    dense::scale_chunks(inv_diag_.data(), y, np_);
    dense::unit_backward_solve_transposed(l_.data(), kLd, nc_, y);
    for (int k = 0; k < n_; ++k) x_[perm_[k]] = y[k];
    x_norm_ = std::sqrt(dense::squared_norm(x_.data(), n_));
    // Every row within the tolerance, every active row met to it. Ain is read here for
    // the first time, for Ain x only: with x finite, a non-finite entry of Ain shows as a
    // non-finite Ain x (then check_rows() tells bad input from overflow, as the full
    // method would). A row's norm (the tolerance's scale) is needed only when its
    // violation exceeds tol |bound|: the active rows' come from their gathered copies,
    // any other's is read then. (A zero row outside its bounds fails here and is
    // settled by the full method.)
    if (!dense::all_finite(x_.data(), n_)) return Shortcut::fallback;
    dense::gemv(p.ain.data(), MI, mi_, n_, x_.data(), slack_.data());
    if (!dense::all_finite(slack_.data(), mi_)) {
      const Status rows = check_rows(x_.data());
      if (rows != Status::optimal) {
        status = rows;
        return Shortcut::solved;
      }
    }
    const double tol = options_.feasibility_tol;
    double worst_ratio = 0.0;
    for (int i = 0; i < mi_; ++i) {
      bool lower_side = false;
      double bound = 0.0;
      const double viol = side_violation(i, lower_side, bound);
      if (viol <= tol * bound) continue;
      const double norm = rows_checked_ || hinted_row(i, cols) ? row_norm_[i] : ain_row_norm(i);
      const double scale = std::max(norm * x_norm_, bound);
      if (viol <= tol * scale) continue;
      // Violated: a repair adds the worst one (relative to its scale), if it can be active.
      const double ratio = scale > 0.0 ? viol / scale : kInf;
      if (std::isnan(ratio)) {
        fix.kind = SetRepair::Kind::none;
        return Shortcut::fallback;
      }
      if (!(ratio > worst_ratio)) continue;
      worst_ratio = ratio;
      const int sigma = hinted_sigma(i, lower_side ? Side::lower : Side::upper);
      fix.kind = sigma != 0 && !hinted_row(i, cols) ? SetRepair::Kind::add : SetRepair::Kind::none;
      fix.row = i;
      fix.sigma = static_cast<std::int8_t>(sigma);
    }
    if (worst_ratio > 0.0) return Shortcut::fallback;
    dense::gemv(p.aeq.data(), ME, meq_, n_, x_.data(), eq_ax_.data());
    for (int k = 0; k < cols; ++k) {
      double scale = 0.0;
      if (!(std::abs(block_residual(k, scale)) <= tol * scale)) return Shortcut::fallback;
    }
    // The result: f = 1/2 |v|^2 + c'v, multipliers -lam, the hinted rows and the
    // lb == ub rows active.
    double objective = 0.0;
    for (int i = 0; i < np_; ++i) objective += v[i] * (0.5 * v[i] + c[i]);
    std::copy_n(x_.data(), n_, result.x.begin());
    result.objective = objective;
    std::fill_n(result.lambda_eq.begin(), meq_, 0.0);
    std::fill_n(result.lambda_in.begin(), mi_, 0.0);
    for (int k = 0; k < cols; ++k) {
      const int src = eq_src_[k];
      if (src >= 0)
        result.lambda_eq[static_cast<std::size_t>(src)] = -lam_[k];
      else
        result.lambda_in[static_cast<std::size_t>(-1 - src)] = -lam_[k];
    }
    for (int k = me_; k < cols; ++k) result.active.push(-1 - eq_src_[k], hinted_side_[k] > 0 ? Side::lower : Side::upper);
    for (int k = 0; k < me_; ++k)
      if (eq_src_[k] < 0) result.active.push(-1 - eq_src_[k], Side::equal);
    if (!std::isfinite(objective) || !dense::all_finite(result.x.data(), n_) ||
        !dense::all_finite(result.lambda_eq.data(), meq_) || !dense::all_finite(result.lambda_in.data(), mi_) ||
        check_stationarity(result) != Status::optimal) {
      result.active.clear();
      return Shortcut::fallback;
    }
    status = Status::optimal;
    result.from_hint = true;
    return Shortcut::solved;
  }

  // Row i of Ain is one of the hinted rows, columns me_ .. cols-1 of the block.
  bool hinted_row(int i, int cols) const noexcept {
    for (int k = me_; k < cols; ++k)
      if (eq_src_[k] == -1 - i) return true;
    return false;
  }
  // |a_i| read from Ain (a strided pass: for the few rows that need it).
  double ain_row_norm(int i) const noexcept {
    const double* a = p_->ain.data() + i;
    double sum = 0.0;
    for (int j = 0; j < n_; ++j) sum += a[idx(0, j, MI)] * a[idx(0, j, MI)];
    return std::sqrt(sum);
  }

  // y <- S^-1 y = (U D^2 U')^-1 y (the factor of solve_on_hinted_set); y padded
  // to whole chunks.
  void solve_gram(double* y, int cols) noexcept {
    const int cp = dense::padded(cols);
    std::fill(y + cols, y + cp, 0.0);
    dense::unit_forward_solve_each(gram_.data(), kLd, cols, 1, [y](int) noexcept { return y; });
    dense::scale_chunks(gram_inv_diag_.data(), y, cp);
    dense::unit_backward_solve_transposed(gram_.data(), kLd, cols, y);
  }

  // ---- step 3: Goldfarb-Idnani on the reduced problem -------------------------
  Status run(const ActiveSet<MI>* warm) noexcept {
    x_current_ = false;
    verdict_row_ = -1;
    verdict_gap_ = kInf;
    q_ = 0;
    epoch_ = 0;
    for (int i = 0; i < m_; ++i) w_[i] = -c_[rank_ + i];
    for (int i = m_; i < mp_; ++i) w_[i] = 0.0;
    for (int i = 0; i < mi_; ++i) {
      active_side_[i] = 0;
      skipped_epoch_[i] = -1;
    }
    max_iterations_ = options_.max_iterations > 0 ? options_.max_iterations : 10 * (n_ + mi_) + 50;
    if (warm != nullptr && warm->size > 0) warm_start(*warm);
    for (;;) {
      compute_x();
      int sigma = 0;
      const int p = most_violated(sigma);
      if (p == kStop) return stop_status_;
      if (p < 0) {
        x_current_ = true;  // x_ is that of the final w
        return Status::optimal;
      }
      const double rhs = reduced_row(p, sigma);
      const double np_norm = full_norm_;
      double slack = dense::dot_chunks(np_vec_.data(), w_.data(), mp_) - rhs;  // < 0 when violated
      double u_plus = 0.0;
      for (;;) {
        if (!count_iteration()) return Status::maxiter;
        const double zz = project();
        const double z_norm = std::sqrt(zz);
        solve_r(d_.data(), rdir_.data());
        // Partial (dual) step: the first active multiplier to reach zero.
        double t1 = kInf;
        int k = -1;
        for (int j = 0; j < q_; ++j) {
          if (rdir_[j] * act_norm_[j] > 1e-10 * np_norm) {
            const double ratio = u_[j] / rdir_[j];
            if (ratio < t1) {
              t1 = ratio;
              k = j;
            }
          }
        }
        const bool dependent = q_ >= m_ || !(z_norm > dependence_tol() * np_norm);
        // A row (nearly) dependent on the active rows whose violation is at the
        // rounding level of the reduced coordinates (a degenerate vertex; the path from
        // the unconstrained minimiser c sets that level) is skipped until the active set
        // changes: exchanges driven by it would only amplify rounding (a primal step of
        // violation / |z|^2 along a z of rounding noise, or a dual step through a
        // multiplier ratio of rounding noise, throws w and the multipliers far away).
        const bool nearly_dependent = dependent || !(z_norm > 1e-8 * np_norm);
        const double path = std::max(v_norm(), c_norm_);
        if (nearly_dependent && u_plus == 0.0 && -slack <= rounding_level() * (full_norm_ * path + std::abs(rhs))) {
          skipped_epoch_[p] = epoch_;
          --iterations_;  // no step taken
          break;
        }
        const double t2 = dependent ? kInf : std::max(0.0, -slack / zz);
        const double t = std::min(t1, t2);
        if (!(t < kInf)) {  // dependent, no multiplier to trade
          verdict_row_ = p;
          verdict_gap_ = -slack / (full_norm_ * path + std::abs(rhs));
          return Status::infeasible;
        }
        for (int j = 0; j < q_; ++j) u_[j] = std::max(0.0, u_[j] - t * rdir_[j]);
        u_plus += t;
        if (!dependent) {
          dense::axpy_chunks(t, z_.data(), w_.data(), mp_);
          slack += t * zz;
        }
        if (!dependent && t2 <= t1) {
          append(p, sigma, rhs, np_norm, z_norm, u_plus);
          break;
        }
        drop(k);
      }
    }
  }

  // Steps 3 and 4 after the equality block: GI from the warm set (or cold), the
  // result and its check.
  Status full_method(Status status, const ActiveSet<MI>* warm, ResultType& result) noexcept {
    if (status == Status::optimal) {
      status = attempt(warm);
      // A warm start is only a guess: a capped run from it is re-run from the cold
      // start (same factorization). An infeasible verdict stands: the warm start
      // leaves a valid dual state (the minimiser on a set of tight rows, multipliers
      // >= 0), and from such a state "violated, dependent, no multiplier to trade" is
      // a Farkas certificate however the state was reached.
      if (warm != nullptr && status == Status::maxiter) {
        iterations_ = 0;
        status = attempt(nullptr);
      }
    }
    if (status == Status::optimal || status == Status::maxiter) {
      status = finish_checked(result, status);
      // A warm start's answer that fails the check: the cold start once more.
      if (status == Status::inaccurate && warm != nullptr) {
        iterations_ = 0;
        result.active.clear();
        status = attempt(nullptr);
        if (status == Status::optimal || status == Status::maxiter) status = finish_checked(result, status);
      }
    }
    return status;
  }

  // ---- step 4: x, objective, multipliers, active set --------------------------
  // finish(), then the solver's own check of an optimal answer: stationarity
  // |H x + g + Aeq' lambda_eq + Ain' lambda_in|_inf <= 1e-6 max(1, |H| |x|, |g|) (H from the
  // lower triangle it reads). A correct answer sits near 1e-14; rounding that beats the
  // method on a degenerate problem (multipliers thrown to 1e15) shows as ~1. The full
  // product runs only when the multipliers are large against that scale (sum |lambda_i|
  // |a_i| > 1e3 of it): only then can rounding in them reach the threshold.
  Status finish_checked(ResultType& result, Status status) noexcept {
    if (!finish(result)) return Status::bad_input;  // non-finite result from finite (huge) data
    return status == Status::optimal ? check_stationarity(result) : status;
  }
  Status check_stationarity(const ResultType& result) noexcept {
    const ProblemType& p = *p_;
    const double* x = result.x.data();
    double x_max = 0.0, g_max = 0.0, h_sq_max = 0.0;
    for (int i = 0; i < n_; ++i) {
      x_max = std::max(x_max, std::abs(x[i]));
      g_max = std::max(g_max, std::abs(p.gradient[i]));
      h_sq_max = std::max(h_sq_max, h_row_sq_[i]);
    }
    const double scale = std::max({1.0, std::sqrt(h_sq_max) * x_max, g_max});
    double lambda_mass = 0.0;
    for (int k = 0; k < meq_; ++k) lambda_mass += std::abs(result.lambda_eq[static_cast<std::size_t>(k)]) * std::sqrt(eq_row_sq_[k]);
    for (int e = 0; e < result.active.size; ++e) {
      const int row = result.active.row[static_cast<std::size_t>(e)];
      lambda_mass += std::abs(result.lambda_in[static_cast<std::size_t>(row)]) * row_norm_[row];
    }
    if (lambda_mass <= 1e3 * scale) return Status::optimal;
    double* r = stat_res_.data();
    for (int i = 0; i < n_; ++i) r[i] = p.gradient[i];
    for (int j = 0; j < n_; ++j) {  // H x from the lower triangle
      const double* col = p.hessian.data() + idx(0, j, N);
      r[j] += col[j] * x[j] + dense::dot(col + j + 1, x + j + 1, n_ - j - 1);
      dense::axpy(x[j], col + j + 1, r + j + 1, n_ - j - 1);
    }
    for (int j = 0; j < n_; ++j) r[j] += dense::dot(p.aeq.data() + idx(0, j, ME), result.lambda_eq.data(), meq_);
    for (int e = 0; e < result.active.size; ++e) {
      const int row = result.active.row[static_cast<std::size_t>(e)];
      const double lambda = result.lambda_in[static_cast<std::size_t>(row)];
      const double* a = p.ain.data() + idx(row, 0, MI);
      for (int j = 0; j < n_; ++j) r[j] += a[idx(0, j, MI)] * lambda;
    }
    double worst = 0.0;
    for (int i = 0; i < n_; ++i) worst = std::max(worst, std::abs(r[i]));
    return worst <= 1e-6 * scale ? Status::optimal : Status::inaccurate;
  }

  // Residual of the final active rows, measured in the original space, relative to
  // max(|a_i| |x|, |bound|). Ill-conditioned H (cond 1e10) leaves ~1e-8 here.
  double active_residuals() noexcept {
    const ProblemType& p = *p_;
    if (!slack_current_)  // Ain x; most_violated left it for the final x otherwise
      dense::gemv(p.ain.data(), MI, mi_, n_, x_.data(), slack_.data());
    dense::gemv(p.aeq.data(), ME, meq_, n_, x_.data(), eq_ax_.data());
    double worst = 0.0;
    for (int k = 0; k < rank_; ++k) {
      double scale = 0.0;
      eq_res_[k] = block_residual(k, scale);
      worst = std::max(worst, std::abs(eq_res_[k]) / scale);
    }
    for (int j = 0; j < q_; ++j) {
      const int row = act_row_[j];
      const double bound = act_sigma_[j] > 0 ? p.lower[row] : p.upper[row];
      act_res_[j] = bound - slack_[row];
      worst = std::max(worst, std::abs(act_res_[j]) / std::max(row_norm_[row] * x_norm_, std::abs(bound)));
    }
    return worst;
  }

  // Residual e_k - a_k'x of column k of the equality block (an Aeq row or an Ain row, by
  // eq_src_; Aeq x in eq_ax_, Ain x in slack_) and its scale max(|a_k| |x|, |e_k|).
  double block_residual(int k, double& scale) const noexcept {
    const int src = eq_src_[k];
    const double ax = src >= 0 ? eq_ax_[src] : slack_[-1 - src];
    scale = std::max(eq_row_norm_[k] * x_norm_, std::abs(eq_rhs_[k]));
    return eq_rhs_[k] - ax;
  }

  // One step of iterative refinement on the final active set: the minimum-norm
  // (in the H metric) correction that zeroes the active residuals. Moves w only
  // along the active normals, so the reduced stationarity holds with u += R^-1 R^-T rho.
  void refine() noexcept {
    for (int k = 0; k < rank_; ++k) {
      const double* ck = bcol(k);
      e_[k] = (eq_res_[k] - dense::dot(ck, e_.data(), k)) / ck[k];  // dv1 = Re^-T res
    }
    for (int j = 0; j < q_; ++j) {
      const double* t = tvec(act_row_[j]);
      const double res = act_res_[j] - dense::dot(t, e_.data(), rank_);
      const double* rj = rcol(j);
      double v = static_cast<double>(act_sigma_[j]) * res;
      for (int l = 0; l < j; ++l) v -= rj[l] * beta_[l];
      beta_[j] = v / rj[j];  // R^-T rho
    }
    for (int k = 0; k < rank_; ++k) v1_[k] += e_[k];
    for (int j = 0; j < q_; ++j) dense::axpy(beta_[j], q1col(j), w_.data(), m_);
    solve_r(beta_.data(), rdir_.data());
    for (int j = 0; j < q_; ++j) u_[j] = std::max(0.0, u_[j] + rdir_[j]);
    compute_x();
  }

  bool finish(ResultType& result) noexcept {
    const ProblemType& p = *p_;
    slack_current_ = x_current_;
    if (!x_current_) compute_x();
    const double before = active_residuals();
    if (before > 1e-13) {
      // Refinement goes through R^-T: with nearly dependent active rows it can move x
      // along a direction the active rows barely see and push an inactive row out of
      // its bounds. It is kept only if it lowers the active residual and (for an
      // optimal run) leaves every row inside its tolerance.
      std::copy_n(w_.data(), mp_, keep_w_.data());
      std::copy_n(v1_.data(), rank_, keep_v1_.data());
      std::copy_n(u_.data(), q_, keep_u_.data());
      std::copy_n(x_.data(), n_, keep_x_.data());
      const double keep_x_norm = x_norm_;
      refine();
      slack_current_ = false;
      if (!(active_residuals() < before) || (x_current_ && !inactive_rows_inside())) {
        std::copy_n(keep_w_.data(), mp_, w_.data());
        std::copy_n(keep_v1_.data(), rank_, v1_.data());
        std::copy_n(keep_u_.data(), q_, u_.data());
        std::copy_n(keep_x_.data(), n_, x_.data());
        x_norm_ = keep_x_norm;
      }
    }
    std::copy_n(x_.data(), n_, result.x.begin());
    // v = [v1; w] = Q' L' x, f = 1/2 |v|^2 + c'v.
    double objective = 0.0;
    for (int i = 0; i < rank_; ++i) objective += v1_[i] * (0.5 * v1_[i] + c_[i]);
    for (int i = 0; i < m_; ++i) objective += w_[i] * (0.5 * w_[i] + c_[rank_ + i]);
    result.objective = objective;
    std::fill_n(result.lambda_eq.begin(), meq_, 0.0);
    std::fill_n(result.lambda_in.begin(), mi_, 0.0);
    // Equality multipliers: Re lambda_E = -(v1 + c1 + sum_j lambda_j t_j[:r]).
    for (int k = 0; k < rank_; ++k) y_[k] = -(v1_[k] + c_[k]);
    for (int j = 0; j < q_; ++j) {
      const double lambda = -static_cast<double>(act_sigma_[j]) * u_[j];
      result.lambda_in[static_cast<std::size_t>(act_row_[j])] = lambda;
      dense::axpy(-lambda, tvec(act_row_[j]), y_.data(), rank_);
    }
    for (int k = rank_ - 1; k >= 0; --k) {  // back substitution with Re by columns
      const double* ck = bcol(k);
      const double v = y_[k] / ck[k];
      y_[k] = v;
      dense::axpy(-v, ck, y_.data(), k);
    }
    for (int k = 0; k < rank_; ++k) {
      const int src = eq_src_[k];
      if (src >= 0)
        result.lambda_eq[static_cast<std::size_t>(src)] = y_[k];
      else
        result.lambda_in[static_cast<std::size_t>(-1 - src)] = y_[k];
    }
    for (int j = 0; j < q_; ++j) result.active.push(act_row_[j], act_sigma_[j] > 0 ? Side::lower : Side::upper);
    for (int k = 0; k < me_; ++k)  // the lb == ub rows of Ain (in the equality block)
      if (eq_src_[k] < 0) result.active.push(-1 - eq_src_[k], Side::equal);
    const bool ok = finite(objective) && dense::all_finite(result.x.data(), n_) &&
                    dense::all_finite(result.lambda_eq.data(), meq_) && dense::all_finite(result.lambda_in.data(), mi_);
    (void)p;
    return ok;
  }

  Options options_;
  const ProblemType* p_ = nullptr;
  int n_ = 0, np_ = 0, meq_ = 0, mi_ = 0;  // np_: n padded to whole chunks of four
  int me_ = 0, rank_ = 0, m_ = 0, mp_ = 0, q_ = 0;  // mp_: m_ padded to whole chunks
  int iterations_ = 0, max_iterations_ = 0, epoch_ = 0;
  int g_reduced_at_ = -1;  // column of L^-1 g when solve_on_hinted_set reduced E and g (-1: not this solve)
  int verdict_row_ = -1, ignored_row_ = -1;  // the row of an infeasible verdict; the row a second run leaves out
  double verdict_gap_ = kInf;                 // that verdict's violation relative to its path
  double x_norm_ = 0.0, full_norm_ = 0.0, c_norm_ = 0.0;
  double np_sq_ = 0.0;  // |np|^2 of reduced_row()'s np_vec_ (project())
  double eq_cond_ = 1.0;  // max/min |diagonal| of the equality block's R (a condition estimate)
  bool x_current_ = false;     // x_ = L^-T Q [v1; w] for the current w (set when run() ends optimal)
  bool rows_checked_ = false;  // Ain's row norms known, zero rows settled (check_rows())
  static constexpr double kMinReducedShare = 0.1;  // most_violated(): floor of |np_i| / |t_i|
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
  alignas(64) Buf<double, kLd> v1_{}, c_{}, w_{}, x_{}, xp_{}, y_{}, np_vec_{}, z_{}, d_{}, e_{}, rdir_{}, beta_{};
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
  Buf<double, MI> red_norm_{};  // most_violated()'s scale: |np_i| = |t_i past rank_| (floored), where have_t_
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
  alignas(64) Buf<double, kLd> lam_{}, step_{}, hinted_v_{};
  Buf<std::int8_t, N> hinted_side_{};  // side of column k >= me_ of b_ (+1 lower, -1 upper)
  alignas(64) Buf<double, kLd * N> gram_s_{};
  ActiveSet<MI> repaired_set_{};  // the shortcut's set after its repairs, when they did not fit
  Buf<int, N> drop_col_{};  // S = B'B itself (lower triangle), kept across repairs
};

}  // namespace springbok::qp
