// Sine and cosine of a batch of angles at once (the joint angles of one tick), written
// so that the compiler vectorises it: 19 calls of libm's sincos cost ~120 ns a tick, the
// batch a fraction of that (SSE2 two lanes, AVX-512 eight).
//
// The method, branch-free: k = round(x 2/pi) by the 1.5 2^52 trick, r = x - k pi/2 in
// four parts (Cody-Waite, fdlibm's split of pi/2), then Cephes' minimax polynomials
// (S. Moshier, sin.c) on [-pi/4, pi/4] and the quadrant k mod 4 to pick and sign them. Error: within 2 ulp of
// the correctly rounded result for |x| <= kBatchSinCosMaxAbs (tests/dynamics/
// test_sincos.cpp measures it against libm over 10^6 angles); larger, non-finite or NaN
// angles are handed to libm, so every input gets libm's answer or one within 2 ulp of it.
#pragma once

#include <cmath>
#include <cstdint>
#include <cstring>

namespace springbok::dyn {

inline constexpr double kBatchSinCosMaxAbs = 1e5;

// s[i] = sin(x[i]), c[i] = cos(x[i]) for i < N. rt: no alloc
template <int N>
inline void sincos_batch(const double* x, double* s, double* c) noexcept {
  // pi/2 = kPio2A + kPio2B + kPio2C + kPio2D to ~1e-47 (fdlibm's pio2_1, pio2_2, pio2_3, pio2_3t):
  // the first three have at most 33 significant bits, so k times each is exact for |k| < 2^20,
  // and the subtractions are exact down to the last one's rounding (Cody-Waite).
  constexpr double kPio2A = 1.57079632673412561417e+00;
  constexpr double kPio2B = 6.07710050630396597660e-11;
  constexpr double kPio2C = 2.02226624871116645580e-21;
  constexpr double kPio2D = 8.47842766036889956997e-32;
  constexpr double kTwoOverPi = 0.63661977236758134308;
  constexpr double kRound = 6755399441055744.0;  // 1.5 2^52: adding it rounds to an integer
  constexpr double kS[6] = {1.58962301576546568060e-10, -2.50507477628578072866e-8, 2.75573136213857245213e-6,
                            -1.98412698295895385996e-4, 8.33333333332211858878e-3,  -1.66666666666666307295e-1};
  constexpr double kC[6] = {-1.13585365213876817300e-11, 2.08757008419747316778e-9, -2.75573141792967388112e-7,
                            2.48015872888517045348e-5,   -1.38888888888730564116e-3, 4.16666666666665929218e-2};
  int outside = 0;  // angles for libm
  for (int i = 0; i < N; ++i) {
    const double xi = x[i];
    const double shifted = xi * kTwoOverPi + kRound;
    const double k = shifted - kRound;
    std::uint64_t quadrant;  // k mod 4: the low bits of the shifted mantissa
    std::memcpy(&quadrant, &shifted, sizeof quadrant);
    const double r = (((xi - k * kPio2A) - k * kPio2B) - k * kPio2C) - k * kPio2D;
    const double z = r * r;
    const double ps = ((((kS[0] * z + kS[1]) * z + kS[2]) * z + kS[3]) * z + kS[4]) * z + kS[5];
    const double pc = ((((kC[0] * z + kC[1]) * z + kC[2]) * z + kC[3]) * z + kC[4]) * z + kC[5];
    const double sin_r = r + r * z * ps;
    const double cos_r = 1.0 - 0.5 * z + z * z * pc;
    // quadrant 0: (sin r, cos r); 1: (cos r, -sin r); 2: (-sin r, -cos r); 3: (-cos r, sin r).
    // Picked and signed with bit masks, not branches: the quadrants of a tick's angles are
    // random, and this way the loop vectorises.
    std::uint64_t sin_bits, cos_bits;
    std::memcpy(&sin_bits, &sin_r, sizeof sin_bits);
    std::memcpy(&cos_bits, &cos_r, sizeof cos_bits);
    const std::uint64_t odd = 0 - (quadrant & 1);  // all ones in quadrants 1 and 3
    const std::uint64_t s_bits = ((odd & cos_bits) | (~odd & sin_bits)) ^ ((quadrant & 2) << 62);
    const std::uint64_t c_bits = ((odd & sin_bits) | (~odd & cos_bits)) ^ (((quadrant + 1) & 2) << 62);
    std::memcpy(&s[i], &s_bits, sizeof s_bits);
    std::memcpy(&c[i], &c_bits, sizeof c_bits);
    outside += std::abs(xi) <= kBatchSinCosMaxAbs ? 0 : 1;
  }
  if (outside != 0) {  // huge, infinite or NaN angles: libm's answer
    for (int i = 0; i < N; ++i) {
      if (!(std::abs(x[i]) <= kBatchSinCosMaxAbs)) {
        s[i] = std::sin(x[i]);
        c[i] = std::cos(x[i]);
      }
    }
  }
}

}  // namespace springbok::dyn
