// bench_dynamics: the dynamics kernels one controller tick needs.
//   BM_FullTick  compute_tick: FK + M + h + 5 point Jacobians + 5 Jdot*v
//   BM_Crba, BM_Rnea, BM_Aba
// Each cycles through 64 random states. Run with repetitions for the spread:
//   bench_dynamics --benchmark_repetitions=30 --benchmark_report_aggregates_only=true
// Each runs once per instruction-set level the binary holds and the CPU runs (isa_bench.hpp).
// Besides the per-repetition aggregates (mean, median, stddev, p99 of the
// repetition means), each benchmark reports the per-call latency median and
// 99th percentile of 20000 individually timed calls (counters call_p50_us,
// call_p99_us; steady_clock overhead of a few tens of ns included).
#include <benchmark/benchmark.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <memory>
#include <vector>

#include "isa_bench.hpp"
#include "random_state.hpp"

namespace {
using namespace springbok;

constexpr int kStates = 64;

struct Fixture {
  Fixture() {
    std::mt19937_64 rng{42};
    for (auto& s : states) s = springbok::test::random_state(rng);
  }
  const dyn::Model model{Rotors::none};  // the URDF alone, as the reference states (and Pinocchio)
  std::unique_ptr<dyn::Data> data = std::make_unique<dyn::Data>();
  std::array<springbok::test::RandomState, kStates> states;
};

Fixture& fixture() {
  static Fixture f;
  return f;
}

template <class Kernel>
void run(benchmark::State& state, Kernel kernel) {
  const springbok::test::IsaLevelScope level(state);
  Fixture& f = fixture();
  int k = 0;
  for (auto _ : state) {
    kernel(f, f.states[static_cast<std::size_t>(k)]);
    benchmark::ClobberMemory();
    k = (k + 1) % kStates;
  }
  // After the timed loop (timing has stopped): individually timed calls.
  std::vector<double> us(20000);
  for (std::size_t n = 0; n < us.size(); ++n) {
    const auto t0 = std::chrono::steady_clock::now();
    kernel(f, f.states[n % kStates]);
    benchmark::ClobberMemory();
    us[n] = std::chrono::duration<double, std::micro>(std::chrono::steady_clock::now() - t0).count();
  }
  std::sort(us.begin(), us.end());
  state.counters["call_p50_us"] = us[us.size() / 2];
  state.counters["call_p99_us"] = us[us.size() * 99 / 100];
}

void BM_FullTick(benchmark::State& state) {
  run(state, [](Fixture& f, const auto& s) { dyn::compute_tick(f.model, *f.data, s.q, s.v); });
}
void BM_Crba(benchmark::State& state) {
  run(state, [](Fixture& f, const auto& s) { dyn::crba(f.model, *f.data, s.q); });
}
void BM_Rnea(benchmark::State& state) {
  run(state, [](Fixture& f, const auto& s) { dyn::rnea(f.model, *f.data, s.q, s.v, s.vdot); });
}
void BM_Aba(benchmark::State& state) {
  run(state, [](Fixture& f, const auto& s) { dyn::aba(f.model, *f.data, s.q, s.v, s.vdot); });
}

double p99(const std::vector<double>& v) {
  std::vector<double> s = v;
  std::sort(s.begin(), s.end());
  return s[std::min(s.size() - 1, s.size() * 99 / 100)];
}

BENCHMARK(BM_FullTick)->Apply(springbok::test::each_isa_level)->ComputeStatistics("p99", p99)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_Crba)->Apply(springbok::test::each_isa_level)->ComputeStatistics("p99", p99)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_Rnea)->Apply(springbok::test::each_isa_level)->ComputeStatistics("p99", p99)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_Aba)->Apply(springbok::test::each_isa_level)->ComputeStatistics("p99", p99)->Unit(benchmark::kMicrosecond);

}  // namespace

BENCHMARK_MAIN();
