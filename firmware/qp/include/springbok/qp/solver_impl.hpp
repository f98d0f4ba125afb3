// springbok::qp::Solver's steps 0-4 (the method in solver.hpp's opening comment):
// solve(), validation and classification, the factor of H, the equality block,
// Goldfarb-Idnani on the reduced problem, and x, the multipliers and the checks.
// Part of springbok/qp/solver.hpp, which includes it after the class: not meant to be
// included alone. Every definition but the two [[gnu::noinline]] ones is declared
// inline, as it was in the class body: GCC's inliner weighs declared-inline functions
// differently, and the same declarations give the same code.
#pragma once

#ifndef SPRINGBOK_QP_SOLVER_DEFINITIONS
#error "springbok/qp/solver_impl.hpp is part of springbok/qp/solver.hpp: include that"
#endif

namespace springbok::qp {

// rt: no alloc, no block
template <int N, int ME, int MI>
[[gnu::noinline]] auto Solver<N, ME, MI>::solve(
    const ProblemType& problem, ResultType& result, const Hint& hint) noexcept -> Status {
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

// ---- step 0: validate and classify -------------------------------------
template <int N, int ME, int MI>
inline auto Solver<N, ME, MI>::classify() noexcept -> Status {
  const ProblemType& p = *p_;
  n_ = p.n;
  n_padded_ = dense::padded(std::max(0, std::min(p.n, N)));
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

// ---- step 1: Cholesky ----------------------------------------------------
// The lower triangle of H equals the one last factored with reuse_factor set.
template <int N, int ME, int MI>
inline auto Solver<N, ME, MI>::same_factored_hessian() const noexcept -> bool {
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
template <int N, int ME, int MI>
inline auto Solver<N, ME, MI>::order_variables() noexcept -> void {
  nc_ = 0;
  for (int j = 0; j < n_; ++j)
    if (coupled_[j] != 0) perm_[nc_++] = j;
  int k = nc_;
  for (int j = 0; j < n_; ++j)
    if (coupled_[j] == 0) perm_[k++] = j;
  for (k = 0; k < n_; ++k) ain_offset_[k] = idx(0, perm_[k], MI);
}

template <int N, int ME, int MI>
inline auto Solver<N, ME, MI>::factor(const Hint& hint) noexcept -> Status {
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
  std::fill(inv_diag_.begin() + n_, inv_diag_.begin() + n_padded_, 0.0);  // keeps padding zero
  return Status::optimal;
}

// y <- L^-1 y (permuted coordinates, padded) for `cols` vectors: the coupled block by
// unit forward substitution, then D^-1 on every variable (the separable ones' L).
template <int N, int ME, int MI>
template <class Column>
inline auto Solver<N, ME, MI>::solve_lower_each(int cols, Column column) noexcept -> void {
  dense::unit_forward_solve_each(l_.data(), kLd, nc_, cols, column);
  for (int c = 0; c < cols; ++c) dense::scale_chunks(inv_diag_.data(), column(c), n_padded_);
}

template <int N, int ME, int MI>
inline auto Solver<N, ME, MI>::solve_lower(double* y, int ldy, int cols) noexcept -> void {
  solve_lower_each(cols, [y, ldy](int c) noexcept { return y + c * ldy; });
}

// Row `row` of Ain in the variable order (offsets of its entries precomputed), zero
// padding to n_padded_.
template <int N, int ME, int MI>
inline auto Solver<N, ME, MI>::gather_ain_row(int row, double* dst) const noexcept -> void {
  const double* src = p_->ain.data() + row;
  for (int k = 0; k < n_; ++k) dst[k] = src[ain_offset_[k]];
  std::fill(dst + n_, dst + n_padded_, 0.0);
}

// dst[k] = src[perm_[k]] for the n_ variables, zero padding to n_padded_.
template <int N, int ME, int MI>
inline auto Solver<N, ME, MI>::gather(const double* src, double* dst) const noexcept -> void {
  for (int k = 0; k < n_; ++k) dst[k] = src[perm_[k]];
  std::fill(dst + n_, dst + n_padded_, 0.0);
}

// ---- step 2: the equality block --------------------------------------------
// The equality rows (Aeq's, then the lb == ub rows of Ain), permuted, into columns
// 0 .. me_-1 of b_ (zero-padded), their right-hand sides, sources and row norms.
template <int N, int ME, int MI>
inline auto Solver<N, ME, MI>::load_equalities() noexcept -> void {
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
    std::fill(bcol(me_) + n_, bcol(me_) + n_padded_, 0.0);
    eq_row_norm_[me_] = std::sqrt(eq_row_sq_[me_]);
    eq_rhs_[me_] = p.beq_values[me_];
    eq_src_[me_] = me_;
  }
  for (int i = 0; i < mi_; ++i) {
    if (kind_[i] != RowKind::equal) continue;
    gather_ain_row(i, bcol(me_));
    eq_row_norm_[me_] = row_norm_[i] = std::sqrt(dense::dot_chunks(bcol(me_), bcol(me_), n_padded_));
    eq_rhs_[me_] = p.lower[i];
    eq_src_[me_] = -1 - i;
    ++me_;
  }
}

template <int N, int ME, int MI>
inline auto Solver<N, ME, MI>::eliminate_equalities() noexcept -> Status {
  const ProblemType& p = *p_;
  // g rides along as column me_: the same solve and reflectors give c = Q' L^-1 g.
  double* gcol = bcol(me_);
  if (g_reduced_at_ >= 0) {  // solve_on_hinted_set left L^-1 E' in place, L^-1 g at that column
    if (g_reduced_at_ != me_) std::copy_n(bcol(g_reduced_at_), n_padded_, gcol);
  } else {
    load_equalities();
    gcol = bcol(me_);
    gather(p.gradient.data(), gcol);
    solve_lower(bcol(0), kLd, me_ + 1);
  }
  for (int k = 0; k < me_; ++k) {
    eq_norm2_[k] = dense::dot_chunks(bcol(k), bcol(k), n_padded_);
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
    tau_[k] = dense::make_householder(bk + k, dense::tail_squared_norm(bk, k + 1, n_padded_), scale);
    double* vk = vcol(k);  // the full padded reflector: zeros above k, 1 at k (bk's tail is left unused)
    std::fill(vk, vk + dense::chunk_start(k), 0.0);
    dense::scaled_below(bk, k, n_padded_, scale, 1.0, vk);
    if (tau_[k] != 0.0) {  // the reflector on columns k+1 .. me_ (g last) at once
      const int start = dense::chunk_start(k), len = n_padded_ - start, cols = me_ - k;
      dense::gemv_t_chunks(bcol(k + 1) + start, kLd, len, cols, vk + start, eq_w_.data());
      for (int j = 0; j < cols; ++j) eq_w_[j] *= tau_[k];
      dense::sub_outer_chunks(vk + start, len, cols, eq_w_.data(), bcol(k + 1) + start, kLd);
    }
    for (int j = k + 1; j < me_; ++j) {
      const double* cj = bcol(j);
      // |c_j[k+1:]|^2 = |c_j[k:]|^2 - c_j[k]^2 (LAPACK-style downdate), recomputed
      // once cancellation has eaten more than three digits of it.
      const double left2 = eq_left2_[j] - cj[k] * cj[k];
      eq_left2_[j] = left2 > 1e-3 * eq_norm2_[j] ? left2 : dense::tail_squared_norm(cj, k + 1, n_padded_);
    }
    ++rank_;
  }
  m_ = n_ - rank_;
  m_padded_ = dense::padded(m_);
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
  std::copy_n(gcol, n_padded_, c_.data());
  c_norm_ = std::sqrt(dense::dot_chunks(c_.data(), c_.data(), n_padded_));
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
template <int N, int ME, int MI>
inline auto Solver<N, ME, MI>::build_wy() noexcept -> void {
  for (int k = 0; k < rank_; ++k) {
    dense::gemv_t_chunks(v_.data(), kLd, n_padded_, k, vcol(k), wy_s_.data());  // V[:, :k]' v_k
    upper_t_times_s(k);
    double* tk = wy_t_.data() + idx(0, k, kLd);
    for (int i = 0; i < k; ++i) tk[i] = -tau_[k] * wy_u_[i];
    tk[k] = tau_[k];
  }
}

// wy_u_ = T s for s = wy_s_, over T's leading k x k block.
template <int N, int ME, int MI>
inline auto Solver<N, ME, MI>::upper_t_times_s(int k) noexcept -> void {
  for (int i = 0; i < k; ++i) {
    double acc = 0.0;
    for (int j = i; j < k; ++j) acc += wy_t_[idx(i, j, kLd)] * wy_s_[j];
    wy_u_[i] = acc;
  }
}

// y <- Q y = y - V T V'y (y padded).
template <int N, int ME, int MI>
inline auto Solver<N, ME, MI>::apply_q(double* y) noexcept -> void {
  if (rank_ == 0) return;
  dense::gemv_t_chunks(v_.data(), kLd, n_padded_, rank_, y, wy_s_.data());
  upper_t_times_s(rank_);
  dense::gemv_sub_chunks(v_.data(), kLd, n_padded_, rank_, wy_u_.data(), y);
}

// y <- H_k y = (I - tau_k v_k v_k') y (y padded; v_k zero above row k).
template <int N, int ME, int MI>
inline auto Solver<N, ME, MI>::apply_reflector(int k, double* y) noexcept -> void {
  const double tau = tau_[k];
  if (tau == 0.0) return;
  const int start = dense::chunk_start(k);
  const double w = tau * dense::dot_chunks(vcol(k) + start, y + start, n_padded_ - start);
  dense::axpy_chunks(-w, vcol(k) + start, y + start, n_padded_ - start);
}

// ---- step 3: Goldfarb-Idnani on the reduced problem -------------------------
// Non-finite entries of Ain are bad input whatever else is wrong with the problem:
// the exits before Ain is first read check it here.
template <int N, int ME, int MI>
inline auto Solver<N, ME, MI>::unless_ain_bad(Status s) noexcept -> Status {
  if ((s == Status::infeasible || s == Status::not_positive_definite) && check_rows(nullptr) == Status::bad_input)
    return Status::bad_input;
  return s;
}

// Row norms of Ain, with Ain x when x is given (one pass over Ain for both), zero
// rows settled: a zero row is dead, or proves the problem infeasible when 0 lies
// outside its bounds. Returns bad_input when Ain has a non-finite entry (a finite
// sum of squares proves a row finite: only a non-finite one needs its entries
// checked), infeasible for such a zero row, else optimal.
template <int N, int ME, int MI>
inline auto Solver<N, ME, MI>::check_rows(const double* x) noexcept -> Status {
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
template <int N, int ME, int MI>
inline auto Solver<N, ME, MI>::queue_reduction(int row, int& queued) noexcept -> void {
  gather_ain_row(row, tvec(row));
  have_t_[row] = true;
  batch_row_[queued++] = row;
}

template <int N, int ME, int MI>
inline auto Solver<N, ME, MI>::reduce_queued(int queued) noexcept -> void {
  if (queued == 0) return;
  solve_lower_each(queued, [this](int c) noexcept { return tvec(batch_row_[c]); });
  for (int k = 0; k < rank_; ++k)
    for (int c = 0; c < queued; ++c) apply_reflector(k, tvec(batch_row_[c]));
  for (int c = 0; c < queued; ++c) {
    const double* t = tvec(batch_row_[c]);
    const double reduced = std::sqrt(dense::dot(t + rank_, t + rank_, m_));
    const double full = std::sqrt(dense::dot_chunks(t, t, n_padded_));
    red_norm_[batch_row_[c]] = std::max({reduced, kMinReducedShare * full, std::numeric_limits<double>::min()});
  }
}

template <int N, int ME, int MI>
inline auto Solver<N, ME, MI>::t_of(int row) noexcept -> const double* {
  if (!have_t_[row]) {
    int queued = 0;
    queue_reduction(row, queued);
    reduce_queued(queued);
  }
  return tvec(row);
}

// Reduced constraint of row `row` on side sigma (+1 lower, -1 upper): n+'w >= rhs.
// Writes n+ (the normal of the row to add, in the reduced coordinates: Goldfarb and
// Idnani's n+) into normal_ and |L^-1 a| (the scale for dependence tests: n+ itself is
// only rounding noise when the row lies in the span of the equalities) into
// full_norm_; returns rhs.
template <int N, int ME, int MI>
inline auto Solver<N, ME, MI>::reduced_row(int row, int sigma) noexcept -> double {
  const double* t = t_of(row);
  full_norm_ = std::sqrt(dense::dot_chunks(t, t, n_padded_));
  const double h = dense::dot(t, v1_.data(), rank_);
  const double* at = t + rank_;
  const double s = static_cast<double>(sigma);
  for (int i = 0; i < m_; ++i) normal_[i] = s * at[i];
  for (int i = m_; i < m_padded_; ++i) normal_[i] = 0.0;
  normal_sq_ = dense::dot_chunks(normal_.data(), normal_.data(), m_padded_);
  return sigma > 0 ? p_->lower[row] - h : h - p_->upper[row];
}

// z = n+ - Q1 Q1'n+ by classical Gram-Schmidt, d = Q1'n+; returns |z|^2. A second
// pass only when the first cancelled more than half of |n+|^2 (|z| < |n+| / sqrt 2,
// the Daniel-Gragg-Kaufman-Stewart criterion: "twice is enough", and once is enough
// without that cancellation). Reduced vectors and the columns of Q1 are zero-padded
// to m_padded_, so whole chunks are used.
template <int N, int ME, int MI>
inline auto Solver<N, ME, MI>::project() noexcept -> double {
  std::copy_n(normal_.data(), m_padded_, z_.data());
  if (q_ == 0) return normal_sq_;
  dense::gemv_t_chunks(q1_.data(), kLd, m_padded_, q_, z_.data(), d_.data());
  dense::gemv_sub_chunks(q1_.data(), kLd, m_padded_, q_, d_.data(), z_.data());
  const double zz = dense::dot_chunks(z_.data(), z_.data(), m_padded_);
  if (zz >= 0.5 * normal_sq_) return zz;
  dense::gemv_t_chunks(q1_.data(), kLd, m_padded_, q_, z_.data(), e_.data());
  dense::gemv_sub_chunks(q1_.data(), kLd, m_padded_, q_, e_.data(), z_.data());
  for (int j = 0; j < q_; ++j) d_[j] += e_[j];
  return dense::dot_chunks(z_.data(), z_.data(), m_padded_);
}

template <int N, int ME, int MI>
inline auto Solver<N, ME, MI>::append(
    int row, int sigma, double rhs, double full_norm, double z_norm, double multiplier) noexcept -> void {
  double* qc = q1col(q_);
  const double inv = 1.0 / z_norm;
  for (int i = 0; i < m_padded_; ++i) qc[i] = z_[i] * inv;  // padding stays zero
  double* rc = rcol(q_);
  std::copy_n(d_.data(), q_, rc);
  rc[q_] = z_norm;
  std::fill(rc + q_ + 1, rc + dense::padded(q_ + 1), 0.0);  // column j of R: zero below j in its chunk
  u_[q_] = multiplier;
  act_row_[q_] = row;
  act_sigma_[q_] = static_cast<std::int8_t>(sigma);
  act_rhs_[q_] = rhs;
  act_norm_[q_] = full_norm;
  active_side_[row] = static_cast<std::int8_t>(sigma);
  ++q_;
  ++epoch_;
}

// Remove active constraint k; restore R upper triangular by Givens rotations,
// applied to the columns of Q1 as well (N = Q1 R stays true).
template <int N, int ME, int MI>
inline auto Solver<N, ME, MI>::drop(int k) noexcept -> void {
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
    dense::rotate_chunks(c, s, q1col(j), q1col(j + 1), m_padded_);  // zero padding stays zero
  }
  --q_;
}

// r = R^-1 d (back substitution by columns: R is stored by columns, each zero below
// its diagonal to the end of the diagonal's chunk, so whole chunks are used: the
// entries after j in that chunk, final already, lose v * 0). The reciprocals of the
// diagonal come first: independent divisions, off the substitution's chain, which
// then multiplies (a division on the chain costs a divider's latency per column).
template <int N, int ME, int MI>
inline auto Solver<N, ME, MI>::solve_r(const double* d, double* out) noexcept -> void {
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
template <int N, int ME, int MI>
inline auto Solver<N, ME, MI>::compute_x() noexcept -> void {
  double* y = xp_.data();
  std::copy_n(v1_.data(), rank_, y);
  std::copy_n(w_.data(), m_, y + rank_);
  std::fill(y + n_, y + n_padded_, 0.0);
  apply_q(y);
  dense::scale_chunks(inv_diag_.data(), y, n_padded_);
  dense::unit_backward_solve_transposed(l_.data(), kLd, nc_, y);
  for (int k = 0; k < n_; ++k) x_[perm_[k]] = y[k];
  x_norm_ = std::sqrt(dense::squared_norm(x_.data(), n_));
}

// The most violated inactive row, or -1. A violation counts beyond feasibility_tol
// max(|a_i| |x|, |bound|); among those rows the pick is the largest violation / |n+_i|,
// n+_i the row in the reduced coordinates (the violation's distance in the metric of
// H on the equalities' null space: the row whose addition alone would raise the
// objective most): it takes fewer iterations than violation / |a_i| on the long
// shared instances. A row nearly in the span of the equalities (|n+_i| <
// kMinReducedShare |t_i|) counts with that share instead: its violation would drive a
// step of violation / |n+_i|^2 that is mostly rounding.
// The t_i it needs are those of the violated rows only, each cached for when its row
// is added. The first call of a solve reads Ain once for its row norms and Ain x
// (check_rows()); it returns kStop with stop_status_ when Ain is bad input or a zero
// row makes the problem infeasible.
template <int N, int ME, int MI>
inline auto Solver<N, ME, MI>::most_violated(int& sigma) noexcept -> int {
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
template <int N, int ME, int MI>
[[gnu::noinline]] auto Solver<N, ME, MI>::inactive_rows_inside() const noexcept -> bool {
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
template <int N, int ME, int MI>
inline auto Solver<N, ME, MI>::side_violation(int i, bool& lower_side, double& bound) const noexcept -> double {
  const double s = slack_[i];
  const double below = lo_eff_[i] - s, above = s - hi_eff_[i];
  lower_side = below >= above;
  bound = lower_side ? lo_abs_[i] : hi_abs_[i];
  return lower_side ? below : above;
}

// side_violation() and the tolerance it must exceed to count: tol max(|a_i| |x|,
// |bound|) for |x| = xn.
template <int N, int ME, int MI>
inline auto Solver<N, ME, MI>::violation(
    int i, double xn, double tol, bool& lower_side, double& limit) const noexcept -> double {
  double bound = 0.0;
  const double viol = side_violation(i, lower_side, bound);
  limit = tol * std::max(row_norm_[i] * xn, bound);
  return viol;
}

// |[v1; w]| = |L' x|.
template <int N, int ME, int MI>
inline auto Solver<N, ME, MI>::v_norm() const noexcept -> double {
  return std::sqrt(dense::squared_norm(v1_.data(), rank_) + dense::dot_chunks(w_.data(), w_.data(), m_padded_));
}

// The side (+1 lower, -1 upper) of a hinted row that can be active there, else 0.
template <int N, int ME, int MI>
inline auto Solver<N, ME, MI>::hinted_sigma(int row, Side side) const noexcept -> int {
  if (row < 0 || row >= mi_ || side == Side::equal) return 0;
  const RowKind kind = kind_[row];
  const int sigma = side == Side::lower ? 1 : -1;
  if (kind == RowKind::dead || kind == RowKind::equal) return 0;
  if ((sigma > 0 && kind == RowKind::upper) || (sigma < 0 && kind == RowKind::lower)) return 0;
  return sigma;
}

// t_i for every valid hinted row at once.
template <int N, int ME, int MI>
inline auto Solver<N, ME, MI>::reduce_hinted_rows(const ActiveSet<MI>& hint, int count) noexcept -> void {
  int queued = 0;
  for (int e = 0; e < count; ++e) {
    const int row = hint.row[static_cast<std::size_t>(e)];
    if (hinted_sigma(row, hint.side[static_cast<std::size_t>(e)]) != 0 && !have_t_[row]) queue_reduction(row, queued);
  }
  reduce_queued(queued);
}

// Warm start: add the hinted rows (skipping invalid or dependent ones), take the
// minimiser on that set, drop rows with a wrong-sign multiplier one at a time.
template <int N, int ME, int MI>
inline auto Solver<N, ME, MI>::warm_start(const ActiveSet<MI>& hint) noexcept -> void {
  const int count = std::min(hint.size, MI);
  reduce_hinted_rows(hint, count);
  for (int e = 0; e < count && q_ < m_; ++e) {
    const int row = hint.row[static_cast<std::size_t>(e)];
    const int sigma = hinted_sigma(row, hint.side[static_cast<std::size_t>(e)]);
    if (sigma == 0 || active_side_[row] != 0) continue;
    const double rhs = reduced_row(row, sigma);
    const double full_norm = full_norm_;
    const double z_norm = std::sqrt(project());
    if (q_ >= m_ || !(z_norm > dependence_tol() * full_norm)) continue;
    append(row, sigma, rhs, full_norm, z_norm, 0.0);
  }
  for (;;) {
    // beta = R^-T rhs - Q1'w0, u = R^-1 beta.
    for (int j = 0; j < q_; ++j) {
      const double* rj = rcol(j);
      double v = act_rhs_[j];
      for (int l = 0; l < j; ++l) v -= rj[l] * beta_[l];
      beta_[j] = v / rj[j];
    }
    for (int j = 0; j < q_; ++j) beta_[j] -= dense::dot_chunks(q1col(j), w_.data(), m_padded_);
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

// An infeasible verdict whose gap (the violation the active rows cannot trade away)
// is within 1e-6 of the path it was measured on may be rounding that beat a
// degenerate vertex. Such a verdict gets a second, cold run that leaves the row
// out; its answer stands only if it satisfies that row after all (violation at most
// 1e-9 max(1, |a| |x|, |bound|), or 1e-11 of the reduced path's scale); otherwise the
// problem is infeasible.
template <int N, int ME, int MI>
inline auto Solver<N, ME, MI>::attempt(const ActiveSet<MI>* warm) noexcept -> Status {
  ignored_row_ = -1;
  const Status status = run(warm);
  return status == Status::infeasible ? second_opinion() : status;
}

template <int N, int ME, int MI>
inline auto Solver<N, ME, MI>::second_opinion() noexcept -> Status {
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
  const double t_norm = have_t_[row] ? std::sqrt(dense::dot_chunks(t, t, n_padded_)) : 0.0;
  const double reduced_scale = t_norm * std::max(v_norm(), c_norm_) + bound;
  const double limit = std::max(1e-9 * std::max({1.0, row_norm_[row] * x_norm_, bound}), 1e-11 * reduced_scale);
  return viol <= limit ? Status::optimal : Status::infeasible;
}

template <int N, int ME, int MI>
inline auto Solver<N, ME, MI>::run(const ActiveSet<MI>* warm) noexcept -> Status {
  x_current_ = false;
  verdict_row_ = -1;
  verdict_gap_ = kInf;
  q_ = 0;
  epoch_ = 0;
  for (int i = 0; i < m_; ++i) w_[i] = -c_[rank_ + i];
  for (int i = m_; i < m_padded_; ++i) w_[i] = 0.0;
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
    const double full_norm = full_norm_;
    double slack = dense::dot_chunks(normal_.data(), w_.data(), m_padded_) - rhs;  // < 0 when violated
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
        if (rdir_[j] * act_norm_[j] > 1e-10 * full_norm) {
          const double ratio = u_[j] / rdir_[j];
          if (ratio < t1) {
            t1 = ratio;
            k = j;
          }
        }
      }
      const bool dependent = q_ >= m_ || !(z_norm > dependence_tol() * full_norm);
      // A row (nearly) dependent on the active rows whose violation is at the
      // rounding level of the reduced coordinates (a degenerate vertex; the path from
      // the unconstrained minimiser c sets that level) is skipped until the active set
      // changes: exchanges driven by it would only amplify rounding (a primal step of
      // violation / |z|^2 along a z of rounding noise, or a dual step through a
      // multiplier ratio of rounding noise, throws w and the multipliers far away).
      const bool nearly_dependent = dependent || !(z_norm > 1e-8 * full_norm);
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
        dense::axpy_chunks(t, z_.data(), w_.data(), m_padded_);
        slack += t * zz;
      }
      if (!dependent && t2 <= t1) {
        append(p, sigma, rhs, full_norm, z_norm, u_plus);
        break;
      }
      drop(k);
    }
  }
}

// Steps 3 and 4 after the equality block: GI from the warm set (or cold), the
// result and its check.
template <int N, int ME, int MI>
inline auto Solver<N, ME, MI>::full_method(
    Status status, const ActiveSet<MI>* warm, ResultType& result) noexcept -> Status {
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
template <int N, int ME, int MI>
inline auto Solver<N, ME, MI>::finish_checked(ResultType& result, Status status) noexcept -> Status {
  if (!finish(result)) return Status::bad_input;  // non-finite result from finite (huge) data
  return status == Status::optimal ? check_stationarity(result) : status;
}

template <int N, int ME, int MI>
inline auto Solver<N, ME, MI>::check_stationarity(const ResultType& result) noexcept -> Status {
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
template <int N, int ME, int MI>
inline auto Solver<N, ME, MI>::active_residuals() noexcept -> double {
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
template <int N, int ME, int MI>
inline auto Solver<N, ME, MI>::block_residual(int k, double& scale) const noexcept -> double {
  const int src = eq_src_[k];
  const double ax = src >= 0 ? eq_ax_[src] : slack_[-1 - src];
  scale = std::max(eq_row_norm_[k] * x_norm_, std::abs(eq_rhs_[k]));
  return eq_rhs_[k] - ax;
}

// One step of iterative refinement on the final active set: the minimum-norm
// (in the H metric) correction that zeroes the active residuals. Moves w only
// along the active normals, so the reduced stationarity holds with u += R^-1 R^-T rho.
template <int N, int ME, int MI>
inline auto Solver<N, ME, MI>::refine() noexcept -> void {
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

template <int N, int ME, int MI>
inline auto Solver<N, ME, MI>::finish(ResultType& result) noexcept -> bool {
  const ProblemType& p = *p_;
  slack_current_ = x_current_;
  if (!x_current_) compute_x();
  const double before = active_residuals();
  if (before > 1e-13) {
    // Refinement goes through R^-T: with nearly dependent active rows it can move x
    // along a direction the active rows barely see and push an inactive row out of
    // its bounds. It is kept only if it lowers the active residual and (for an
    // optimal run) leaves every row inside its tolerance.
    std::copy_n(w_.data(), m_padded_, keep_w_.data());
    std::copy_n(v1_.data(), rank_, keep_v1_.data());
    std::copy_n(u_.data(), q_, keep_u_.data());
    std::copy_n(x_.data(), n_, keep_x_.data());
    const double keep_x_norm = x_norm_;
    refine();
    slack_current_ = false;
    if (!(active_residuals() < before) || (x_current_ && !inactive_rows_inside())) {
      std::copy_n(keep_w_.data(), m_padded_, w_.data());
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

}  // namespace springbok::qp
