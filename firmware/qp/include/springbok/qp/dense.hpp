// Small dense kernels on raw column-major storage, written so that g++ -O3
// vectorises them (axpy loops, dot products with independent accumulators).
// Sizes are the live ones; storage and leading dimensions are the caller's.
// rt: no alloc, no block, noexcept.
#pragma once

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <limits>

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

// The kernels below work on whole aligned chunks of four doubles: every vector
// is zero-padded to padded(n) entries and every loop starts at a multiple of
// four, so a chunk is always loaded where it was stored (store-to-load
// forwarding never stalls on a chunk shifted by one, which made the textbook
// loops of shrinking length several times slower at n ~ 40).
inline constexpr int padded(int n) noexcept { return (n + 3) & ~3; }
inline constexpr int chunk_start(int i) noexcept { return i & ~3; }

// Whole chunks of four as one value (GCC/Clang vector extension: AVX2 on x86-64,
// two NEON registers on aarch64), moved by memcpy so no alignment is assumed. Chunks
// never cross a function boundary (that would depend on the ABI's vector support).
using Chunk = double __attribute__((vector_size(32)));
inline constexpr Chunk kZeroChunk = {0.0, 0.0, 0.0, 0.0};
using ChunkBits = std::uint64_t __attribute__((vector_size(32)));

// True when no entry is NaN or +-inf: x * 0 is 0 for every finite x and NaN
// otherwise, and a sum with a NaN in it is NaN (IEEE semantics; the build never uses
// -ffast-math). Whole chunks, then the tail.
inline bool all_finite(const double* v, int count) noexcept {
  Chunk acc = kZeroChunk, c;
  int i = 0;
  for (; i + 4 <= count; i += 4) {
    std::memcpy(&c, v + i, sizeof c);
    acc += c * 0.0;
  }
  double tail = 0.0;
  for (; i < count; ++i) tail += v[i] * 0.0;
  return ((acc[0] + acc[1]) + (acc[2] + acc[3])) + tail == 0.0;
}

// Bound pairs four at a time (comparisons give lane masks): lo_eff/hi_eff the bound a
// row can violate on each side (-inf/+inf where it has none, or lower == upper),
// lo_abs/hi_abs their magnitudes (0 where none), kind 0 dead, 1 lower, 2 upper,
// 3 both, 4 equal; a bound beyond +-big is none. nan_bound / infeasible are set
// non-zero for a NaN bound / a bound at +-infinity on the wrong side or crossed
// bounds (never cleared).
inline void classify_bounds(const double* lower, const double* upper, int m, double big, double* lo_eff,
                            double* hi_eff, double* lo_abs, double* hi_abs, std::uint8_t* kind, int& nan_bound,
                            int& infeasible) noexcept {
  using Mask = std::int64_t __attribute__((vector_size(32)));
  constexpr double inf = std::numeric_limits<double>::infinity();
  const Chunk pbig = {big, big, big, big}, nbig = -pbig, pinf = {inf, inf, inf, inf}, ninf = -pinf;
  constexpr std::int64_t magnitude = std::numeric_limits<std::int64_t>::max();
  Mask pinf_bits, ninf_bits, nan_acc = {0, 0, 0, 0}, bad_acc = nan_acc;
  std::memcpy(&pinf_bits, &pinf, sizeof pinf_bits);
  std::memcpy(&ninf_bits, &ninf, sizeof ninf_bits);
  int i = 0;
  for (; i + 4 <= m; i += 4) {
    Chunk lo, hi;
    std::memcpy(&lo, lower + i, sizeof lo);
    std::memcpy(&hi, upper + i, sizeof hi);
    const Mask has_lo = lo > nbig, has_hi = hi < pbig, both = has_lo & has_hi, equal = both & (lo == hi);
    nan_acc |= (lo != lo) | (hi != hi);
    bad_acc |= (lo >= pbig) | (hi <= nbig) | (both & (lo > hi));
    const Mask lower_side = has_lo & ~equal, upper_side = has_hi & ~equal;
    Mask lo_bits, hi_bits;
    std::memcpy(&lo_bits, &lo, sizeof lo_bits);
    std::memcpy(&hi_bits, &hi, sizeof hi_bits);
    const Mask le = (lower_side & lo_bits) | (~lower_side & ninf_bits);
    const Mask he = (upper_side & hi_bits) | (~upper_side & pinf_bits);
    const Mask la = lower_side & lo_bits & magnitude, ha = upper_side & hi_bits & magnitude;
    std::memcpy(lo_eff + i, &le, sizeof le);
    std::memcpy(hi_eff + i, &he, sizeof he);
    std::memcpy(lo_abs + i, &la, sizeof la);
    std::memcpy(hi_abs + i, &ha, sizeof ha);
    const Mask k = (equal & 4) | (~equal & ((has_lo & 1) | (has_hi & 2)));
    for (int l = 0; l < 4; ++l) kind[i + l] = static_cast<std::uint8_t>(k[l]);
  }
  for (int l = 0; l < 4; ++l) {
    nan_bound |= static_cast<int>(nan_acc[l] != 0);
    infeasible |= static_cast<int>(bad_acc[l] != 0);
  }
  for (; i < m; ++i) {
    const double lo = lower[i], hi = upper[i];
    const bool has_lo = lo > -big, has_hi = hi < big;
    const bool equal = has_lo & has_hi & (lo == hi);
    nan_bound |= static_cast<int>((lo != lo) | (hi != hi));
    infeasible |= static_cast<int>((lo >= big) | (hi <= -big) | (has_lo & has_hi & (lo > hi)));
    const bool lower_side = has_lo & !equal, upper_side = has_hi & !equal;
    lo_eff[i] = lower_side ? lo : -inf;
    hi_eff[i] = upper_side ? hi : inf;
    lo_abs[i] = lower_side ? std::abs(lo) : 0.0;
    hi_abs[i] = upper_side ? std::abs(hi) : 0.0;
    kind[i] = static_cast<std::uint8_t>(equal ? 4 : static_cast<int>(has_lo) + 2 * static_cast<int>(has_hi));
  }
}

// out = the bits of c shifted left by one: its magnitude bits, the sign dropped (so
// out == 0 exactly for a zero of either sign). References: no vector crosses the ABI.
inline void magnitude_bits(const Chunk& c, ChunkBits& out) noexcept {
  std::memcpy(&out, &c, sizeof out);
  out <<= 1;
}

// all_finite over the lower triangle (diagonal included) of a column-major n x n
// matrix with leading dimension ld; coupled[j] = 1 when column j has a non-zero
// entry below the diagonal or row j one left of it. Rows in whole chunks of four
// (the same row indices in every column, so a chunk of row_bits is stored and
// reloaded whole), the diagonal's chunk masked; the rows past the last whole chunk
// one by one (nothing is read past row n - 1 of a column).
inline bool scan_lower_triangle(const double* a, int ld, int n, std::uint64_t* __restrict row_bits,
                                std::uint8_t* __restrict coupled) noexcept {
  using Bits = ChunkBits;
  constexpr std::uint64_t ones = ~std::uint64_t{0};
  // Lanes of the diagonal's chunk at or below it (finiteness), strictly below (couplings).
  const Bits from_diagonal[4] = {Bits{ones, ones, ones, ones}, Bits{0, ones, ones, ones}, Bits{0, 0, ones, ones},
                                 Bits{0, 0, 0, ones}};
  const Bits below_diagonal[4] = {Bits{0, ones, ones, ones}, Bits{0, 0, ones, ones}, Bits{0, 0, 0, ones},
                                  Bits{0, 0, 0, 0}};
  const Bits all = {ones, ones, ones, ones};
  const int whole = n & ~3;
  for (int i = 0; i < whole; i += 4) std::memset(row_bits + i, 0, 4 * sizeof(std::uint64_t));
  for (int i = whole; i < n; ++i) row_bits[i] = 0;
  Bits bad = {0, 0, 0, 0};
  std::uint64_t bad_tail = 0;
  for (int j = 0; j < n; ++j) {
    const double* col = a + static_cast<std::ptrdiff_t>(j) * ld;
    Bits col_bits = {0, 0, 0, 0};
    for (int i = chunk_start(j); i < whole; i += 4) {
      Bits v, b;
      std::memcpy(&v, col + i, sizeof v);
      const bool diagonal = i == chunk_start(j);
      bad |= ((((v >> 52) & 0x7ffu) + 1u) >> 11) & (diagonal ? from_diagonal[j & 3] : all);
      const Bits m = (v << 1) & (diagonal ? below_diagonal[j & 3] : all);
      std::memcpy(&b, row_bits + i, sizeof b);
      b |= m;
      std::memcpy(row_bits + i, &b, sizeof b);
      col_bits |= m;
    }
    std::uint64_t col_any = (col_bits[0] | col_bits[1]) | (col_bits[2] | col_bits[3]);
    for (int i = j > whole ? j : whole; i < n; ++i) {
      std::uint64_t bits;
      std::memcpy(&bits, col + i, sizeof bits);
      bad_tail |= (((bits >> 52) & 0x7ffu) + 1u) >> 11;
      if (i == j) continue;
      row_bits[i] |= bits << 1;
      col_any |= bits << 1;
    }
    coupled[j] = (row_bits[j] | col_any) != 0 ? 1 : 0;  // row j's left part: columns before j, all done
  }
  return ((bad[0] | bad[1]) | (bad[2] | bad[3]) | bad_tail) == 0;
}

// y[0..3] = {a, b, c, d} as one chunk store.
inline void store4(double* y, double a, double b, double c, double d) noexcept {
  const Chunk v = {a, b, c, d};
  std::memcpy(y, &v, sizeof v);
}

// y + l * ystep <- {a0[l], a1[l], a2[l], a3[l]} for l = 0..3: a 4 x 4 block of four
// columns stored as rows (one chunk load per column, one chunk store per row).
inline void copy_transposed4(const double* a0, const double* a1, const double* a2, const double* a3, double* y,
                             std::ptrdiff_t ystep) noexcept {
  Chunk a, b, c, d;
  std::memcpy(&a, a0, sizeof a);
  std::memcpy(&b, a1, sizeof b);
  std::memcpy(&c, a2, sizeof c);
  std::memcpy(&d, a3, sizeof d);
  const Chunk ab_even = __builtin_shufflevector(a, b, 0, 4, 2, 6), ab_odd = __builtin_shufflevector(a, b, 1, 5, 3, 7);
  const Chunk cd_even = __builtin_shufflevector(c, d, 0, 4, 2, 6), cd_odd = __builtin_shufflevector(c, d, 1, 5, 3, 7);
  const Chunk r0 = __builtin_shufflevector(ab_even, cd_even, 0, 1, 4, 5);
  const Chunk r1 = __builtin_shufflevector(ab_odd, cd_odd, 0, 1, 4, 5);
  const Chunk r2 = __builtin_shufflevector(ab_even, cd_even, 2, 3, 6, 7);
  const Chunk r3 = __builtin_shufflevector(ab_odd, cd_odd, 2, 3, 6, 7);
  std::memcpy(y, &r0, sizeof r0);
  std::memcpy(y + ystep, &r1, sizeof r1);
  std::memcpy(y + 2 * ystep, &r2, sizeof r2);
  std::memcpy(y + 3 * ystep, &r3, sizeof r3);
}

// Rows [i, i + 4) of four adjacent columns (the first at a, leading dimension step).
inline void load_four_columns(const double* a, std::ptrdiff_t step, int i, Chunk& c0, Chunk& c1, Chunk& c2,
                              Chunk& c3) noexcept {
  std::memcpy(&c0, a + i, sizeof c0);
  std::memcpy(&c1, a + step + i, sizeof c1);
  std::memcpy(&c2, a + 2 * step + i, sizeof c2);
  std::memcpy(&c3, a + 3 * step + i, sizeof c3);
}

// y[0..3] += v (one chunk load and store).
inline void add_chunk(double* y, const Chunk& v) noexcept {
  Chunk c;
  std::memcpy(&c, y, sizeof c);
  c += v;
  std::memcpy(y, &c, sizeof c);
}

// ---- column passes over a matrix of the problem --------------------------------
// One pass over a column-major m x n matrix A (leading dimension ld), four columns at a
// time by whole chunks of four rows, so each chunk of the outputs is loaded and stored
// once per four columns. The outputs are assigned, not accumulated; they hold the
// first whole_rows(m, ld) >= m entries, rows past m being the storage of A below its
// live rows (read, used only in their own lanes, never in a live row's). Rows a whole
// chunk would read past the column (ld not a multiple of four) go one by one.
inline constexpr int whole_rows(int m, int ld) noexcept { return padded(m) < (ld & ~3) ? padded(m) : (ld & ~3); }

// y = A x (kProduct) and/or sq[i] = sum_j a_ij^2 (kSquares).
template <bool kProduct, bool kSquares>
inline void column_pass(const double* a, int ld, int m, int n, const double* x, double* __restrict y,
                        double* __restrict sq) noexcept {
  const int whole = whole_rows(m, ld);
  const std::ptrdiff_t step = ld;
  for (int i = 0; i < whole; i += 4) {
    if constexpr (kProduct) std::memcpy(y + i, &kZeroChunk, sizeof kZeroChunk);
    if constexpr (kSquares) std::memcpy(sq + i, &kZeroChunk, sizeof kZeroChunk);
  }
  int j = 0;
  for (; j + 4 <= n; j += 4) {
    Chunk x0 = kZeroChunk, x1 = x0, x2 = x0, x3 = x0;
    if constexpr (kProduct) x0 += x[j], x1 += x[j + 1], x2 += x[j + 2], x3 += x[j + 3];
    for (int i = 0; i < whole; i += 4) {
      Chunk c0, c1, c2, c3;
      load_four_columns(a + j * step, step, i, c0, c1, c2, c3);
      if constexpr (kProduct) add_chunk(y + i, (c0 * x0 + c1 * x1) + (c2 * x2 + c3 * x3));
      if constexpr (kSquares) add_chunk(sq + i, (c0 * c0 + c1 * c1) + (c2 * c2 + c3 * c3));
    }
  }
  for (; j < n; ++j) {
    const double* aj = a + j * step;
    Chunk xj = kZeroChunk;
    if constexpr (kProduct) xj += x[j];
    for (int i = 0; i < whole; i += 4) {
      Chunk c;
      std::memcpy(&c, aj + i, sizeof c);
      if constexpr (kProduct) add_chunk(y + i, c * xj);
      if constexpr (kSquares) add_chunk(sq + i, c * c);
    }
  }
  for (int i = whole; i < m; ++i) {  // ld not a multiple of four: the last rows
    double yi = 0.0, si = 0.0;
    for (int jj = 0; jj < n; ++jj) {
      const double v = a[jj * step + i];
      if constexpr (kProduct) yi += v * x[jj];
      if constexpr (kSquares) si += v * v;
    }
    if constexpr (kProduct) y[i] = yi;
    if constexpr (kSquares) sq[i] = si;
  }
}

// y = A x.
inline void gemv(const double* a, int ld, int m, int n, const double* x, double* y) noexcept {
  column_pass<true, false>(a, ld, m, n, x, y, nullptr);
}

// sq[i] = sum_j a_ij^2 (row sums of squares: a finite one proves the row finite).
inline void row_squares(const double* a, int ld, int m, int n, double* sq) noexcept {
  column_pass<false, true>(a, ld, m, n, nullptr, nullptr, sq);
}

// y = A x and sq[i] = sum_j a_ij^2 in one pass over A.
inline void gemv_and_row_squares(const double* a, int ld, int m, int n, const double* x, double* y,
                                 double* sq) noexcept {
  column_pass<true, true>(a, ld, m, n, x, y, sq);
}

// For a column-major n x n matrix A (leading dimension ld), as row_squares, with
// bits[i] = the OR over j != i of the magnitude bits of a_ij (sign dropped), so
// bits[i] == 0 exactly when row i has no non-zero entry off the diagonal (a zero of
// either sign is zero), and column[j] = 1 when column j has one. Outputs as column_pass
// (whole_rows(n, ld) entries), column n entries. A variable whose row and column are
// both zero off the diagonal is coupled to no other by A's lower triangle, or its upper.
inline void row_squares_and_offdiagonal_bits(const double* a, int ld, int n, double* __restrict sq,
                                             std::uint64_t* __restrict bits,
                                             std::uint8_t* __restrict column) noexcept {
  using Bits = ChunkBits;
  // keep[l]: every lane but lane l (the diagonal entry of a column in its own chunk).
  constexpr std::uint64_t ones = ~std::uint64_t{0};
  const Bits keep[4] = {Bits{0, ones, ones, ones}, Bits{ones, 0, ones, ones}, Bits{ones, ones, 0, ones},
                        Bits{ones, ones, ones, 0}};
  const Bits all = {ones, ones, ones, ones};
  const int whole = whole_rows(n, ld);
  Bits live_last = all;  // the lanes of the chunk [whole - 4, whole) above row n
  for (int l = 0; l < 4; ++l)
    if (whole - 4 + l >= n) live_last[l] = 0;
  const std::ptrdiff_t step = ld;
  for (int i = 0; i < whole; i += 4) {
    std::memcpy(sq + i, &kZeroChunk, sizeof kZeroChunk);
    std::memset(bits + i, 0, 4 * sizeof(std::uint64_t));
  }
  auto any = [](const Bits& v) noexcept { return static_cast<std::uint8_t>(((v[0] | v[1]) | (v[2] | v[3])) != 0); };
  int j = 0;
  for (; j + 4 <= n; j += 4) {
    Bits d0 = {0, 0, 0, 0}, d1 = d0, d2 = d0, d3 = d0;
    for (int i = 0; i < whole; i += 4) {
      Chunk c0, c1, c2, c3;
      load_four_columns(a + j * step, step, i, c0, c1, c2, c3);
      Bits m0, m1, m2, m3, b;
      magnitude_bits(c0, m0);
      magnitude_bits(c1, m1);
      magnitude_bits(c2, m2);
      magnitude_bits(c3, m3);
      const bool diagonal = i == j;  // the chunk holding the four diagonal entries (j is a chunk start)
      const Bits live = i + 4 <= n ? all : live_last;
      m0 &= (diagonal ? keep[0] : all) & live;
      m1 &= (diagonal ? keep[1] : all) & live;
      m2 &= (diagonal ? keep[2] : all) & live;
      m3 &= (diagonal ? keep[3] : all) & live;
      add_chunk(sq + i, (c0 * c0 + c1 * c1) + (c2 * c2 + c3 * c3));
      std::memcpy(&b, bits + i, sizeof b);
      b |= (m0 | m1) | (m2 | m3);
      std::memcpy(bits + i, &b, sizeof b);
      d0 |= m0;
      d1 |= m1;
      d2 |= m2;
      d3 |= m3;
    }
    column[j] = any(d0);
    column[j + 1] = any(d1);
    column[j + 2] = any(d2);
    column[j + 3] = any(d3);
  }
  for (; j < n; ++j) {
    const double* aj = a + j * step;
    Bits d = {0, 0, 0, 0};
    for (int i = 0; i < whole; i += 4) {
      Chunk c;
      std::memcpy(&c, aj + i, sizeof c);
      Bits m, b;
      magnitude_bits(c, m);
      m &= (i == chunk_start(j) ? keep[j & 3] : all) & (i + 4 <= n ? all : live_last);
      add_chunk(sq + i, c * c);
      std::memcpy(&b, bits + i, sizeof b);
      b |= m;
      std::memcpy(bits + i, &b, sizeof b);
      d |= m;
    }
    column[j] = any(d);
  }
  for (int i = whole; i < n; ++i) {  // ld not a multiple of four: the last rows
    double si = 0.0;
    std::uint64_t bi = 0;
    for (int jj = 0; jj < n; ++jj) {
      const double v = a[jj * step + i];
      si += v * v;
      std::uint64_t vb;
      std::memcpy(&vb, &v, sizeof vb);
      if (jj == i) continue;
      bi |= vb << 1;
      if ((vb << 1) != 0) column[jj] = 1;
    }
    sq[i] = si;
    bits[i] = bi;
  }
}

// a . b over n entries, n a multiple of four (padded vectors from a chunk start).
inline double dot_chunks(const double* a, const double* b, int n) noexcept {
  Chunk s0 = {0.0, 0.0, 0.0, 0.0}, s1 = s0, x, y, u, v;
  int i = 0;
  for (; i + 8 <= n; i += 8) {
    std::memcpy(&x, a + i, sizeof x);
    std::memcpy(&y, b + i, sizeof y);
    std::memcpy(&u, a + i + 4, sizeof u);
    std::memcpy(&v, b + i + 4, sizeof v);
    s0 += x * y;
    s1 += u * v;
  }
  if (i < n) {
    std::memcpy(&x, a + i, sizeof x);
    std::memcpy(&y, b + i, sizeof y);
    s0 += x * y;
  }
  s0 += s1;
  return (s0[0] + s0[1]) + (s0[2] + s0[3]);
}

// sum_{i >= from} c[i]^2 over a padded vector (np entries): scalar head to the next
// chunk, then whole chunks.
inline double tail_squared_norm(const double* c, int from, int np) noexcept {
  const int aligned = chunk_start(from + 3);
  double head = 0.0;
  for (int i = from; i < aligned && i < np; ++i) head += c[i] * c[i];
  return aligned < np ? head + dot_chunks(c + aligned, c + aligned, np - aligned) : head;
}

// y[i] = i > k ? x[i] * scale : (i == k ? diag : 0) over the padded range [chunk_start(k),
// np): the chunk holding k through a lane mask (a bitwise and, so whatever the lanes
// through k held leaves no NaN behind), the rest whole chunks. (x may be y.)
inline void scaled_below(const double* x, int k, int np, double scale, double diag, double* y) noexcept {
  constexpr std::uint64_t ones = ~std::uint64_t{0};
  static constexpr ChunkBits kLanesAfter[4] = {ChunkBits{0, ones, ones, ones}, ChunkBits{0, 0, ones, ones},
                                               ChunkBits{0, 0, 0, ones}, ChunkBits{0, 0, 0, 0}};
  const int start = chunk_start(k);
  const Chunk s = {scale, scale, scale, scale};
  Chunk c;
  ChunkBits b;
  std::memcpy(&b, x + start, sizeof b);
  b &= kLanesAfter[k - start];
  std::memcpy(&c, &b, sizeof c);
  c *= s;
  std::memcpy(y + start, &c, sizeof c);
  y[k] = diag;
  for (int i = start + 4; i < np; i += 4) {
    std::memcpy(&c, x + i, sizeof c);
    c *= s;
    std::memcpy(y + i, &c, sizeof c);
  }
}

// y += alpha x over n entries, n a multiple of four.
inline void axpy_chunks(double alpha, const double* x, double* y, int n) noexcept {
  const Chunk a = {alpha, alpha, alpha, alpha};
  Chunk xc, yc;
  for (int i = 0; i < n; i += 4) {
    std::memcpy(&xc, x + i, sizeof xc);
    std::memcpy(&yc, y + i, sizeof yc);
    yc += a * xc;
    std::memcpy(y + i, &yc, sizeof yc);
  }
}

// y[i] -= (c0[i] e0 + c1[i] e1) + (c2[i] e2 + c3[i] e3) for i in [from, np), from a
// chunk start, np a multiple of four: a rank-4 update by whole chunks.
inline void sub_rank4_chunks(const double* c0, const double* c1, const double* c2, const double* c3, double e0,
                             double e1, double e2, double e3, double* y, int from, int np) noexcept {
  const Chunk f0 = {e0, e0, e0, e0}, f1 = {e1, e1, e1, e1}, f2 = {e2, e2, e2, e2}, f3 = {e3, e3, e3, e3};
  Chunk yc, a0, a1, a2, a3;
  for (int i = from; i < np; i += 4) {
    std::memcpy(&yc, y + i, sizeof yc);
    std::memcpy(&a0, c0 + i, sizeof a0);
    std::memcpy(&a1, c1 + i, sizeof a1);
    std::memcpy(&a2, c2 + i, sizeof a2);
    std::memcpy(&a3, c3 + i, sizeof a3);
    yc -= (a0 * f0 + a1 * f1) + (a2 * f2 + a3 * f3);
    std::memcpy(y + i, &yc, sizeof yc);
  }
}

// Right-looking Cholesky of the lower triangle of a (column-major, leading
// dimension ld >= padded(n), rows [n, padded(n)) zero), in panels of four
// columns with one rank-4 update of the trailing columns per panel, as H = U D^2 U'
// with U unit lower (L = U D). On return column k of a holds U's strict lower part
// from row k+1 on and zeros from the start of its chunk of four through row k (what
// unit_forward_solve_each and unit_backward_solve_transposed read); inv_diag[k] =
// 1/L_kk. False when a pivot is not above min_pivot, or min_pivots[k] for column k when
// given (or is NaN).
inline bool cholesky_lower(double* a, int ld, int n, double min_pivot, double* inv_diag,
                           const double* min_pivots = nullptr) noexcept {
  const int np = padded(n);
  for (int k0 = 0; k0 < n; k0 += 4) {
    const int k1 = k0 + 4 < n ? k0 + 4 : n;
    double pivots[4] = {0.0, 0.0, 0.0, 0.0};
    for (int k = k0; k < k1; ++k) {  // the panel
      double* col_k = a + k * ld;
      const double pivot = col_k[k];
      if (!(pivot > (min_pivots != nullptr ? min_pivots[k] : min_pivot))) return false;
      pivots[k - k0] = pivot;
      // The panel's next columns are updated from the unscaled column with
      // a_ik a_jk / pivot = l_ik l_jk, so the next pivot waits on one division,
      // not on a square root; the scaling runs alongside.
      const double inv_pivot = 1.0 / pivot;
      for (int j = k + 1; j < k1; ++j) {
        double* col_j = a + j * ld;
        const double a_jk = col_k[j] * inv_pivot;
        axpy_chunks(-a_jk, col_k + chunk_start(j), col_j + chunk_start(j), np - chunk_start(j));
      }
      inv_diag[k] = 1.0 / std::sqrt(pivot);
      scaled_below(col_k, k, np, inv_pivot, 0.0, col_k);  // u_ik = a_ik / pivot, zeros through row k
    }
    // Trailing update with l_ik l_jk = u_ik (u_jk pivot_k); missing panel columns (n
    // not a multiple of 4) count as zero.
    const double* c0 = a + k0 * ld;
    const double* c1 = k0 + 1 < k1 ? c0 + ld : c0;
    const double* c2 = k0 + 2 < k1 ? c0 + 2 * ld : c0;
    const double* c3 = k0 + 3 < k1 ? c0 + 3 * ld : c0;
    for (int j = k1; j < n; ++j) {
      double* col_j = a + j * ld;
      const double l0 = c0[j] * pivots[0], l1 = c1[j] * pivots[1], l2 = c2[j] * pivots[2], l3 = c3[j] * pivots[3];
      sub_rank4_chunks(c0, c1, c2, c3, l0, l1, l2, l3, col_j, chunk_start(j), np);
    }
  }
  return true;
}

// y <- U^-1 y for cols vectors (padded) at once, U unit lower (L = U D): forward
// substitution with the strict lower part of U in panels of four columns (the
// panel's own chunk by scalar steps, the rows below by one rank-4 update, so
// each chunk of y is loaded and stored once per panel). The columns' dependency
// chains are independent and overlap. column(c) gives the c-th vector; D^-1 is
// the caller's (one pass over whole chunks).
template <class Column>
inline void unit_forward_solve_each(const double* lower, int ld, int n, int cols, Column column) noexcept {
  const int np = padded(n);
  for (int k0 = 0; k0 < n; k0 += 4) {
    // The panel's unit lower triangle; entries of columns past n count as zero
    // (rows past n are zero padding in lower and in y).
    const double* __restrict c0 = lower + k0 * ld;
    const double* __restrict c1 = lower + (k0 + 1) * ld;
    const double* __restrict c2 = lower + (k0 + 2) * ld;
    const double* __restrict c3 = lower + (k0 + 3) * ld;
    const double l10 = c0[k0 + 1], l20 = c0[k0 + 2], l30 = c0[k0 + 3];
    const double l21 = k0 + 1 < n ? c1[k0 + 2] : 0.0, l31 = k0 + 1 < n ? c1[k0 + 3] : 0.0;
    const double l32 = k0 + 2 < n ? c2[k0 + 3] : 0.0;
    const bool below = k0 + 4 < n;  // a full panel with rows below it
    for (int c = 0; c < cols; ++c) {
      double* __restrict yc = column(c);
      const double y0 = yc[k0];
      const double y1 = yc[k0 + 1] - l10 * y0;
      const double y2 = yc[k0 + 2] - (l20 * y0 + l21 * y1);
      const double y3 = yc[k0 + 3] - ((l30 * y0 + l31 * y1) + l32 * y2);
      yc[k0 + 1] = y1;
      yc[k0 + 2] = y2;
      yc[k0 + 3] = y3;
      if (!below) continue;
      sub_rank4_chunks(c0, c1, c2, c3, y0, y1, y2, y3, yc, k0 + 4, np);
    }
  }
}

// [a; b] <- [c s; -s c] [a; b] entrywise over n entries, n a multiple of four.
inline void rotate_chunks(double c, double s, double* a, double* b, int n) noexcept {
  const Chunk cc = {c, c, c, c}, sc = {s, s, s, s};
  Chunk ac, bc;
  for (int i = 0; i < n; i += 4) {
    std::memcpy(&ac, a + i, sizeof ac);
    std::memcpy(&bc, b + i, sizeof bc);
    const Chunk na = cc * ac + sc * bc, nb = cc * bc - sc * ac;
    std::memcpy(a + i, &na, sizeof na);
    std::memcpy(b + i, &nb, sizeof nb);
  }
}

// y[i] *= s[i] over n entries, n a multiple of four.
inline void scale_chunks(const double* s, double* y, int n) noexcept {
  Chunk sc, yc;
  for (int i = 0; i < n; i += 4) {
    std::memcpy(&sc, s + i, sizeof sc);
    std::memcpy(&yc, y + i, sizeof yc);
    yc *= sc;
    std::memcpy(y + i, &yc, sizeof yc);
  }
}

// out[c] = a_c . x over the entries [from, to) (chunk starts) of the four columns
// a_c = a + c ld: one pass, so each chunk of x is loaded once for the four.
inline void four_column_dots(const double* a, std::ptrdiff_t ld, int from, int to, const double* x,
                             double* out) noexcept {
  const double* a0 = a;
  const double* a1 = a0 + ld;
  const double* a2 = a1 + ld;
  const double* a3 = a2 + ld;
  Chunk s0 = kZeroChunk, s1 = s0, s2 = s0, s3 = s0, xc, c;
  for (int i = from; i < to; i += 4) {
    std::memcpy(&xc, x + i, sizeof xc);
    std::memcpy(&c, a0 + i, sizeof c);
    s0 += c * xc;
    std::memcpy(&c, a1 + i, sizeof c);
    s1 += c * xc;
    std::memcpy(&c, a2 + i, sizeof c);
    s2 += c * xc;
    std::memcpy(&c, a3 + i, sizeof c);
    s3 += c * xc;
  }
  // out[c] = (s_c[0] + s_c[1]) + (s_c[2] + s_c[3]) for the four at once: pairs, then
  // the pairs' sums (the same additions as four horizontal sums, in fewer shuffles).
  const Chunk p01 = __builtin_shufflevector(s0, s1, 0, 4, 2, 6) + __builtin_shufflevector(s0, s1, 1, 5, 3, 7);
  const Chunk p23 = __builtin_shufflevector(s2, s3, 0, 4, 2, 6) + __builtin_shufflevector(s2, s3, 1, 5, 3, 7);
  const Chunk sums = __builtin_shufflevector(p01, p23, 0, 1, 4, 5) + __builtin_shufflevector(p01, p23, 2, 3, 6, 7);
  std::memcpy(out, &sums, sizeof sums);
}

// out[j] = a_j . x for the first ncols columns a_j of a column-major matrix (leading
// dimension ld), over n entries (a multiple of four): four columns per pass.
inline void gemv_t_chunks(const double* a, int ld, int n, int ncols, const double* x, double* out) noexcept {
  int j = 0;
  for (; j + 4 <= ncols; j += 4) four_column_dots(a + static_cast<std::ptrdiff_t>(j) * ld, ld, 0, n, x, out + j);
  for (; j < ncols; ++j) out[j] = dot_chunks(a + static_cast<std::ptrdiff_t>(j) * ld, x, n);
}

// y <- U^-T y for U unit lower (its strict lower part in the zero-padded columns
// of lower, n of them), y padded: backward substitution by panels of four columns,
// last panel first. A panel's four dot products with the rows below it share each
// chunk of y (one pass, as gemv_t_chunks); its own unit triangle is solved by scalar
// steps. Only the last panel can be partial, and it has no rows below it; entries of
// columns past n count as zero (rows past n are zero padding in lower and in y).
inline void unit_backward_solve_transposed(const double* lower, int ld, int n, double* y) noexcept {
  const int np = padded(n);
  for (int k0 = chunk_start(n - 1); k0 >= 0; k0 -= 4) {
    const double* c0 = lower + static_cast<std::ptrdiff_t>(k0) * ld;
    const double* c1 = c0 + ld;
    const double* c2 = c1 + ld;
    double s[4];
    four_column_dots(c0, ld, k0 + 4, np, y, s);  // a full panel's rows below it (none for a partial one)
    const double l10 = c0[k0 + 1], l20 = c0[k0 + 2], l30 = c0[k0 + 3];
    const double l21 = k0 + 1 < n ? c1[k0 + 2] : 0.0, l31 = k0 + 1 < n ? c1[k0 + 3] : 0.0;
    const double l32 = k0 + 2 < n ? c2[k0 + 3] : 0.0;
    const double y3 = y[k0 + 3] - s[3];
    const double y2 = y[k0 + 2] - s[2] - l32 * y3;
    const double y1 = y[k0 + 1] - s[1] - (l21 * y2 + l31 * y3);
    const double y0 = y[k0] - s[0] - ((l10 * y1 + l20 * y2) + l30 * y3);
    y[k0] = y0;
    y[k0 + 1] = y1;
    y[k0 + 2] = y2;
    y[k0 + 3] = y3;
  }
}

// y -= sum_j e[j] a_j over the first ncols columns (as gemv_t_chunks), n a multiple
// of four: four columns per pass, so each chunk of y is loaded and stored once per four.
inline void gemv_sub_chunks(const double* a, int ld, int n, int ncols, const double* e, double* y) noexcept {
  int j = 0;
  for (; j + 4 <= ncols; j += 4) {
    const double* a0 = a + static_cast<std::ptrdiff_t>(j) * ld;
    const double* a1 = a0 + ld;
    const double* a2 = a1 + ld;
    const double* a3 = a2 + ld;
    const Chunk e0 = {e[j], e[j], e[j], e[j]}, e1 = {e[j + 1], e[j + 1], e[j + 1], e[j + 1]},
                e2 = {e[j + 2], e[j + 2], e[j + 2], e[j + 2]}, e3 = {e[j + 3], e[j + 3], e[j + 3], e[j + 3]};
    Chunk yc, c0, c1, c2, c3;
    for (int i = 0; i < n; i += 4) {
      std::memcpy(&yc, y + i, sizeof yc);
      std::memcpy(&c0, a0 + i, sizeof c0);
      std::memcpy(&c1, a1 + i, sizeof c1);
      std::memcpy(&c2, a2 + i, sizeof c2);
      std::memcpy(&c3, a3 + i, sizeof c3);
      yc -= (c0 * e0 + c1 * e1) + (c2 * e2 + c3 * e3);
      std::memcpy(y + i, &yc, sizeof yc);
    }
  }
  for (; j < ncols; ++j) axpy_chunks(-e[j], a + static_cast<std::ptrdiff_t>(j) * ld, y, n);
}

// a_j -= coef[j] v for the first ncols columns a_j of a column-major matrix (leading
// dimension ld), over n entries (a multiple of four): a rank-1 update, four columns
// per pass sharing each chunk of v.
inline void sub_outer_chunks(const double* v, int n, int ncols, const double* coef, double* a, int ld) noexcept {
  int j = 0;
  for (; j + 4 <= ncols; j += 4) {
    double* a0 = a + static_cast<std::ptrdiff_t>(j) * ld;
    double* a1 = a0 + ld;
    double* a2 = a1 + ld;
    double* a3 = a2 + ld;
    const Chunk e0 = {coef[j], coef[j], coef[j], coef[j]}, e1 = {coef[j + 1], coef[j + 1], coef[j + 1], coef[j + 1]},
                e2 = {coef[j + 2], coef[j + 2], coef[j + 2], coef[j + 2]},
                e3 = {coef[j + 3], coef[j + 3], coef[j + 3], coef[j + 3]};
    Chunk vc, c;
    for (int i = 0; i < n; i += 4) {
      std::memcpy(&vc, v + i, sizeof vc);
      std::memcpy(&c, a0 + i, sizeof c);
      c -= e0 * vc;
      std::memcpy(a0 + i, &c, sizeof c);
      std::memcpy(&c, a1 + i, sizeof c);
      c -= e1 * vc;
      std::memcpy(a1 + i, &c, sizeof c);
      std::memcpy(&c, a2 + i, sizeof c);
      c -= e2 * vc;
      std::memcpy(a2 + i, &c, sizeof c);
      std::memcpy(&c, a3 + i, sizeof c);
      c -= e3 * vc;
      std::memcpy(a3 + i, &c, sizeof c);
    }
  }
  for (; j < ncols; ++j) axpy_chunks(-coef[j], v, a + static_cast<std::ptrdiff_t>(j) * ld, n);
}

// Householder reflector P = I - tau v v' with v = [1; scale * x[1..]] so that
// P x = [beta; 0], given tail2 = |x[1..]|^2. Only x[0] changes (to beta): the
// caller writes the scaled tail where it wants it. Returns tau (0: P = I, scale 0).
inline double make_householder(double* x, double tail2, double& scale) noexcept {
  const double alpha = x[0];
  scale = 0.0;
  if (tail2 == 0.0) return 0.0;  // already reduced: P = I
  const double beta = (alpha >= 0.0 ? -1.0 : 1.0) * std::sqrt(alpha * alpha + tail2);
  scale = 1.0 / (alpha - beta);
  x[0] = beta;
  return (beta - alpha) / beta;
}

// Givens rotation (c, s) with [c s; -s c] [a; b] = [r; 0]; returns r >= 0.
inline double givens(double a, double b, double& c, double& s) noexcept {
  const double big = std::fmax(std::abs(a), std::abs(b));
  // sqrt(a^2 + b^2) cannot overflow or lose the small one to underflow in this range;
  // hypot (several times slower) outside it.
  const double r = big < 1e150 && big > 1e-150 ? std::sqrt(a * a + b * b) : std::hypot(a, b);
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
