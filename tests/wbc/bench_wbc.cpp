// One full whole-body controller tick (dynamics + tasks + QP + torques) at the
// standing state with 50 N pushing the hand along world x, warm-started as in
// closed loop. Run with repetitions to read median and p99, e.g.
//   bench_wbc --benchmark_repetitions=20 --benchmark_report_aggregates_only=true
// (per-iteration p99: the springbok-sim summary's tick_us over a closed-loop run).
// Once per instruction-set level the binary holds and the CPU runs (isa_bench.hpp).
#include <benchmark/benchmark.h>

#include <memory>

#include "isa_bench.hpp"
#include "springbok/dynamics/dynamics.hpp"
#include "springbok/wbc/stand_controller.hpp"
#include "springbok/wbc/whole_body_controller.hpp"

namespace {
using namespace springbok;

void BM_WbcTick(benchmark::State& state) {
  const springbok::test::IsaLevelScope level(state);
  VecNq q = VecNq::Zero();
  q[2] = 0.6;
  q[6] = 1.0;
  for (int j = 0; j < kNj; ++j) q[7 + j] = robot::kStance_rad[static_cast<std::size_t>(j)];  // the arm bent
  wbc::WbcParams params;
  params.foot_contact_radius_m = kFootRadius_m;
  auto controller = std::make_unique<wbc::WholeBodyController>(params);
  dyn::Model model;
  auto data = std::make_unique<dyn::Data>();
  controller->set_reference(q, *data);
  wbc::WbcInput in;
  in.state.q = q;
  in.state.set_rotation_from_q();
  in.wrist_force_world_n = Vec3(50.0, 0.0, 0.0);
  dyn::compute_tick(model, *data, q, in.state.v);
  controller->tick(in, *data);  // warm start, as every tick after the first
  for (auto _ : state) {  // the dynamics (computed once per tick by springbok::control) and the controller
    dyn::compute_tick(model, *data, q, in.state.v);
    const wbc::WbcOutput& out = controller->tick(in, *data);
    benchmark::DoNotOptimize(out.tau_nm.data());
  }
  if (controller->qp_failures() != 0) state.SkipWithError("QP failed");
}
BENCHMARK(BM_WbcTick)->Apply(springbok::test::each_isa_level)->Unit(benchmark::kMicrosecond);

}  // namespace

BENCHMARK_MAIN();
