// Benchmarks once per instruction-set level (springbok/isa/isa.hpp) that this binary holds
// and this CPU runs, in one run, so the levels compare on the same machine and moment:
//
//   BENCHMARK(BM_WbcTick)->Apply(springbok::test::each_isa_level);
//   void BM_WbcTick(benchmark::State& state) { springbok::test::IsaLevelScope level(state); ... }
//
// The benchmark's name ends with /isa:<n> (0 the baseline, 1 x86-64-v3, 2 x86-64-v4) and
// its label names the level.
#pragma once

#include <benchmark/benchmark.h>

#include "springbok/isa/isa.hpp"

namespace springbok::test {

inline void each_isa_level(benchmark::internal::Benchmark* b) {
  b->ArgName("isa");
  for (int l = 0; l < isa::kLevels; ++l) {
    const auto level = static_cast<isa::Level>(l);
    if (isa::compiled(level) && isa::cpu_supports(level)) b->Arg(l);
  }
}

// Runs the kernels at the benchmark's level while it lives (before its set-up, so the
// set-up's warm start runs there too).
class IsaLevelScope {
 public:
  explicit IsaLevelScope(benchmark::State& state) {
    const auto level = static_cast<isa::Level>(state.range(0));
    if (!isa::select(level)) state.SkipWithError("level not runnable here");
    state.SetLabel(isa::name(level));
  }
  ~IsaLevelScope() { (void)isa::select(saved_); }
  IsaLevelScope(const IsaLevelScope&) = delete;
  IsaLevelScope& operator=(const IsaLevelScope&) = delete;

 private:
  isa::Level saved_ = isa::active();
};

}  // namespace springbok::test
