// bench_qp's timed loops, compiled once per instruction-set level (springbok/isa/isa.hpp,
// toolchain/springbok_isa.cmake): each benchmark runs them at the level its name ends with,
// the QP and its Eigen LLT yardstick alike, so one run compares the levels.
#pragma once

#include <benchmark/benchmark.h>

#include "qp_file.hpp"
#include "springbok/isa/isa.hpp"

namespace springbok::qpbench {

enum class Mode { cold, warm, warm_factor };

// One level's loops: the solver at the firmware's limits (fw), beyond them (large), at the
// controller's size (wbc), and a dynamic-size Eigen LLT of H plus L^-1 (the yardstick).
struct Kernels {
  void (*solve_fw)(benchmark::State& state, const qpfile::Instance& in, Mode mode);
  void (*solve_large)(benchmark::State& state, const qpfile::Instance& in, Mode mode);
  void (*solve_wbc)(benchmark::State& state, const qpfile::Instance& in, Mode mode);
  void (*eigen_llt)(benchmark::State& state, const qpfile::Instance& in);
};

// The baseline's (bench_qp_kernels.cpp).
extern const Kernels kBaselineKernels;
SPRINGBOK_ISA_LEVEL_TABLES(Kernels)

}  // namespace springbok::qpbench
