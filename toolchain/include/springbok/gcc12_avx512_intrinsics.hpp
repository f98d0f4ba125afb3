// Force-included (-include) into every springbok translation unit by the top
// CMakeLists.txt, and only for GCC < 13 compiling for an ISA with AVX-512.
//
// Why: GCC 12's AVX-512 intrinsics build their "don't care" merge operands with
// the self-initialisation `__m512d __Y = __Y;` (_mm512_undefined_pd and friends).
// Inlined into a caller (Eigen's packet code: gebp_kernel, the 8-wide reductions),
// -Wuninitialized / -Wmaybe-uninitialized report that line of GCC's own header
// (avx512fintrin.h) as an error under -Werror. GCC bug 105593, fixed in GCC 13.
//
// GCC 12 checks a middle-end warning against the diagnostic pragmas at every
// location of its inlining stack, so ignoring the two warnings over the
// intrinsic headers' own lines silences exactly those reports: the same warnings
// in our code, inlined or not, stay errors.
#pragma once

#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wuninitialized"
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
#include <immintrin.h>
#pragma GCC diagnostic pop
