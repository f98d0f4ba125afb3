// springbok::qp::Solver's warm-start shortcut: the hinted set solved as equalities
// (solve_on_hinted_set), its repairs (a row added, wrong-signed rows dropped), the
// set's columns and the Cholesky factor of their Gram matrix S. Part of
// springbok/qp/solver.hpp, which includes it after the class: not meant to be included
// alone. Every definition is declared inline, as it was in the class body (see
// solver_impl.hpp).
#pragma once

#ifndef SPRINGBOK_QP_SOLVER_DEFINITIONS
#error "springbok/qp/solver_warm_start.hpp is part of springbok/qp/solver.hpp: include that"
#endif

namespace springbok::qp {

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
// the set is solved again (one column of B and one row and column of S change; S's factor
// keeps its rows before the change, and after an added row the last answer is extended,
// extend_solution, rather than solved anew). A repaired set's answer passes the same checks (and so is the
// QP's unique minimiser); result.iterations counts the repairs. In the trots a force ramp's
// end and a touch-down change four to seven rows at once, hence several repairs, and every
// wrong sign leaving at once rather than one per repair. (Every violated row joining at once
// instead made more sets fail and fall back.)
template <int N, int ME, int MI>
inline auto Solver<N, ME, MI>::solve_on_hinted_set(
    const ActiveSet<MI>& hint, ResultType& result, Status& status) noexcept -> Shortcut {
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
    dense::gemv_t_chunks(bcol(j), kLd, n_padded_, cols - j, bcol(j), sj + j);
    std::fill(sj + cols, sj + cp, 0.0);
  }
  bool added = false;  // the last repair added a row: lam_ and hinted_v_ hold the answer without it
  for (int repair = 0;; ++repair) {
    SetRepair fix;
    if (solve_on_set(cols, added, result, status, fix) == Shortcut::solved) return Shortcut::solved;
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
    added = fix.kind == SetRepair::Kind::add;
    ++iterations_;
  }
}

// Ain's row `row`, active on side sigma, into the block's column k (permuted, not yet
// reduced by L), with its norm, right-hand side and source.
template <int N, int ME, int MI>
inline auto Solver<N, ME, MI>::load_set_row(int k, int row, int sigma) noexcept -> void {
  gather_ain_row(row, bcol(k));
  eq_row_norm_[k] = row_norm_[row] = std::sqrt(dense::dot_chunks(bcol(k), bcol(k), n_padded_));
  eq_rhs_[k] = sigma > 0 ? p_->lower[row] : p_->upper[row];
  eq_src_[k] = -1 - row;
  hinted_side_[k] = static_cast<std::int8_t>(sigma);
}

// A repair's added row: L^-1 a into column `cols` (c moves one column right), S's new row.
template <int N, int ME, int MI>
inline auto Solver<N, ME, MI>::add_set_column(int& cols, int row, std::int8_t sigma) noexcept -> bool {
  if (cols >= n_ || cols >= kMaxEqRows) return false;
  std::copy_n(bcol(cols), n_padded_, bcol(cols + 1));
  load_set_row(cols, row, sigma);
  solve_lower(bcol(cols), kLd, 1);
  const int cp = dense::padded(cols + 1);
  for (int j = 0; j <= cols; ++j) {
    double* sj = scol(j);
    sj[cols] = dense::dot_chunks(bcol(j), bcol(cols), n_padded_);
    std::fill(sj + cols + 1, sj + cp, 0.0);
  }
  ++cols;
  g_reduced_at_ = cols;
  return true;
}

// A repair's dropped column k (me_ <= k < cols): the columns right of it and c move one
// left, and S loses row and column k.
template <int N, int ME, int MI>
inline auto Solver<N, ME, MI>::drop_set_column(int& cols, int k) noexcept -> void {
  for (int j = k; j < cols; ++j) std::copy_n(bcol(j + 1), n_padded_, bcol(j));
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
template <int N, int ME, int MI>
inline auto Solver<N, ME, MI>::append_gram_row(int cols) noexcept -> bool {
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
// L^-1 g in column cols, S in gram_s_; added: column cols - 1 was just added to a set whose
// answer lam_ and hinted_v_ hold.
template <int N, int ME, int MI>
inline auto Solver<N, ME, MI>::solve_on_set(
    int cols, bool added, ResultType& result, Status& status, SetRepair& fix) noexcept -> Shortcut {
  const ProblemType& p = *p_;
  const double* c = bcol(cols);
  // S's lower triangle into gram_ and its Cholesky factor in the layout of H's: a
  // pivot is the part of a column's squared norm left after the columns before it,
  // and one below 1e-8 of that squared norm means dependent rows. After a repair only
  // the rows past the columns it kept are computed (S's leading block, and so the
  // factor's, did not change): the added row, or the rows from the first dropped one on.
  const int cp = dense::padded(cols);
  const bool extend = added && gram_cols_ > 0 && gram_cols_ + 1 == cols;
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
  double* v = hinted_v_.data();
  if (extend) {
    extend_solution(cols);
  } else {
    solve_set_equations(cols);
  }
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
  std::copy_n(v, n_padded_, y);
  dense::scale_chunks(inv_diag_.data(), y, n_padded_);
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
  for (int i = 0; i < n_padded_; ++i) objective += v[i] * (0.5 * v[i] + c[i]);
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

// The set's equations solved with S's factor: S lam = b + B'c, v = B lam - c.
template <int N, int ME, int MI>
inline auto Solver<N, ME, MI>::solve_set_equations(int cols) noexcept -> void {
  const double* c = bcol(cols);
  double* v = hinted_v_.data();
  dense::gemv_t_chunks(bcol(0), kLd, n_padded_, cols, c, lam_.data());
  for (int j = 0; j < cols; ++j) lam_[j] += eq_rhs_[j];
  solve_gram(lam_.data(), cols);
  // v = B lam - c (stationarity holds by construction whatever lam's rounding), then
  // one refinement step, lam += S^-1 (b - B'v), v += B (that step): the normal
  // equations square B's conditioning, the corrected ones recover what a QR of B
  // would give. (Skipping it when b - B'v is already at 1e-14 of the rows' scale left
  // x 1e-12 off: rows of norm 1e3 |x| then violated by 1e-8 in the soak.)
  for (int j = 0; j < cols; ++j) step_[j] = -lam_[j];
  for (int i = 0; i < n_padded_; ++i) v[i] = -c[i];
  dense::gemv_sub_chunks(bcol(0), kLd, n_padded_, cols, step_.data(), v);
  dense::gemv_t_chunks(bcol(0), kLd, n_padded_, cols, v, step_.data());
  for (int j = 0; j < cols; ++j) step_[j] = eq_rhs_[j] - step_[j];
  solve_gram(step_.data(), cols);
  for (int j = 0; j < cols; ++j) {
    lam_[j] += step_[j];
    step_[j] = -step_[j];
  }
  dense::gemv_sub_chunks(bcol(0), kLd, n_padded_, cols, step_.data(), v);
}

// The answer on the set after one row joined it, from the answer before (lam_, hinted_v_ on
// the first j = cols - 1 columns, refined): with beta = L^-1 a the new column, s = B'beta
// (S's new row) and w = S^-1 s,
//   z = beta - B w   (beta's part outside B's range: B'z = 0),
//   v += t z,  t = (b_new - beta'v) / beta'z,   lam = [lam - t w; t],
// keeps the old rows met and v + c = B lam, and meets the new one. w costs one solve with
// the factor's transpose: append_gram_row left D^-2 U^-1 s in the factor's new row. One
// product with B here, against the four and two Gram solves of solve_set_equations; the
// answer passes the same checks (its rounding is the answer's before plus one step's).
template <int N, int ME, int MI>
inline auto Solver<N, ME, MI>::extend_solution(int cols) noexcept -> void {
  const int j = cols - 1;
  double* w = step_.data();
  for (int l = 0; l < j; ++l) w[l] = gcol(l)[j];
  std::fill(w + j, w + dense::padded(j), 0.0);  // the solve reads whole chunks
  dense::unit_backward_solve_transposed(gram_.data(), kLd, j, w);
  double* z = hinted_z_.data();
  const double* beta = bcol(j);
  std::copy_n(beta, n_padded_, z);
  dense::gemv_sub_chunks(bcol(0), kLd, n_padded_, j, w, z);
  double* v = hinted_v_.data();
  const double t = (eq_rhs_[j] - dense::dot_chunks(beta, v, n_padded_)) / dense::dot_chunks(beta, z, n_padded_);
  dense::axpy_chunks(t, z, v, n_padded_);
  for (int l = 0; l < j; ++l) lam_[l] -= t * w[l];
  lam_[j] = t;
}

// Row i of Ain is one of the hinted rows, columns me_ .. cols-1 of the block.
template <int N, int ME, int MI>
inline auto Solver<N, ME, MI>::hinted_row(int i, int cols) const noexcept -> bool {
  for (int k = me_; k < cols; ++k)
    if (eq_src_[k] == -1 - i) return true;
  return false;
}

// |a_i| read from Ain (a strided pass: for the few rows that need it).
template <int N, int ME, int MI>
inline auto Solver<N, ME, MI>::ain_row_norm(int i) const noexcept -> double {
  const double* a = p_->ain.data() + i;
  double sum = 0.0;
  for (int j = 0; j < n_; ++j) sum += a[idx(0, j, MI)] * a[idx(0, j, MI)];
  return std::sqrt(sum);
}

// y <- S^-1 y = (U D^2 U')^-1 y (the factor of solve_on_hinted_set); y padded
// to whole chunks.
template <int N, int ME, int MI>
inline auto Solver<N, ME, MI>::solve_gram(double* y, int cols) noexcept -> void {
  const int cp = dense::padded(cols);
  std::fill(y + cols, y + cp, 0.0);
  dense::unit_forward_solve_each(gram_.data(), kLd, cols, 1, [y](int) noexcept { return y; });
  dense::scale_chunks(gram_inv_diag_.data(), y, cp);
  dense::unit_backward_solve_transposed(gram_.data(), kLd, cols, y);
}

}  // namespace springbok::qp
