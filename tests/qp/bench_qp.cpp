// bench_qp: Google Benchmark over the QP instance files (tests/support/test_data.hpp, globbed
// at start-up).
//   qp/cold/<size>/<name>  one cold solve per iteration
//   qp/warm/<size>/<name>  one solve warm-started from the previous solve's active set
//   qp/warm-factor/<size>/<name>  the same, also reusing the previous solve's factor of H
//                                 (StartHint::reuse_factor)
// Sizes: fw = Solver<64, 32, 160> (firmware limits), wbc = Solver<40, 12, 62> (the
// controller's QP sized near its real dimensions; WBC-shaped instances only),
// large = Solver<128, 128, 1024> (instances beyond the firmware limits).
// Each benchmark also reports the per-solve median and p99 in microseconds.
// Calibration: eigen_llt/<name> = a dynamic-size Eigen LLT of H plus L^-1 (the
// issue's reference "bare LLT of H plus L^-T", ~16 us on these machines).
// Each runs once per instruction-set level the binary holds and the CPU runs, the name
// ending /isa:<level> (bench_qp_kernels.hpp): the QP and its yardstick at the same level.
#include <memory>
#include <string>
#include <vector>

#include <benchmark/benchmark.h>

#include "bench_qp_kernels.hpp"
#include "isa_bench.hpp"
#include "qp_file.hpp"
#include "test_data.hpp"

namespace {

using springbok::qpfile::Instance;
using springbok::qpbench::Mode;

const char* mode_name(Mode mode) {
  return mode == Mode::cold ? "cold" : mode == Mode::warm ? "warm" : "warm-factor";
}

// The loops of the benchmark's level (its last argument, isa_bench.hpp).
const springbok::qpbench::Kernels& kernels() {
  using namespace springbok::qpbench;
  return SPRINGBOK_ISA_ACTIVE_TABLE(kBaselineKernels);
}

// Registers `name`/isa:<level> for each level this binary holds and the CPU runs.
template <class Run>
void register_per_level(const std::string& name, Run run) {
  benchmark::RegisterBenchmark(name.c_str(), [run](benchmark::State& s) {
    const springbok::test::IsaLevelScope level(s);
    run(s, kernels());
  })->Apply(springbok::test::each_isa_level);
}

std::vector<Instance>& instances() {
  static std::vector<Instance> all;
  return all;
}

}  // namespace

int main(int argc, char** argv) {
  const std::vector<std::string> files = springbok::test::qp_instance_files();
  auto& all = instances();
  all.reserve(files.size());
  for (const auto& f : files) {
    std::string error;
    if (auto in = springbok::qpfile::read_instance(f, error)) all.push_back(std::move(*in));
  }
  using springbok::qpbench::Kernels;
  for (const Instance& in : all) {
    const Instance* p = &in;
    for (const Mode m : {Mode::cold, Mode::warm, Mode::warm_factor}) {
      const std::string mode = mode_name(m);
      if (in.n <= 64 && in.meq <= 32 && in.mi <= 160) {
        register_per_level("qp/" + mode + "/fw/" + in.name,
                           [p, m](benchmark::State& s, const Kernels& k) { k.solve_fw(s, *p, m); });
      } else {
        register_per_level("qp/" + mode + "/large/" + in.name,
                           [p, m](benchmark::State& s, const Kernels& k) { k.solve_large(s, *p, m); });
      }
      if (in.family == "wbc" && in.n <= 40 && in.meq <= 12 && in.mi <= 62) {
        register_per_level("qp/" + mode + "/wbc/" + in.name,
                           [p, m](benchmark::State& s, const Kernels& k) { k.solve_wbc(s, *p, m); });
      }
    }
    if (in.family == "wbc") {
      register_per_level("eigen_llt/" + in.name, [p](benchmark::State& s, const Kernels& k) { k.eigen_llt(s, *p); });
    }
  }
  benchmark::Initialize(&argc, argv);
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
