// One control-mode tick of springbok::control::RobotController, as the firmware's loop calls it,
// and the estimator's part of it:
//   BM_ControllerTick/isa:N  the whole tick: the base estimate (filter ekf, the default) from the
//                            IMU and the encoders, the dynamics, the whole-body controller (tasks,
//                            QP, torques), the joint commands
//   BM_BaseEstimatorUpdate/isa:N  est::BaseEstimator::update alone, as the tick calls it (the
//                            feet's kinematics, the EKF's prediction and updates)
// Both once per instruction-set level the binary holds and the CPU runs (isa_bench.hpp: the
// estimator, the dynamics and the WBC have per-level kernels).
// The robot stands still on its four feet, its IMU and encoders with white noise (1024
// precomputed ticks, cycled), 50 N pushing the hand. Run with repetitions for the spread:
//   bench_controller --benchmark_repetitions=20 --benchmark_report_aggregates_only=true
#include <benchmark/benchmark.h>

#include <memory>
#include <vector>

#include "isa_bench.hpp"
#include "standing_ticks.hpp"
#include "springbok/control/robot_controller.hpp"
#include "springbok/dynamics/dynamics.hpp"
#include "springbok/estimation/base_estimator.hpp"
#include "springbok/wbc/stand_controller.hpp"

namespace {
using namespace springbok;

constexpr double kDt_s = 0.001;
constexpr int kTicks = 1024;

// 50 N pushing the hand (sensor axes).
std::vector<hal::Measurements> pushed_standing_ticks() {
  std::vector<hal::Measurements> out = springbok::test::noisy_standing_ticks(kTicks, 3);
  for (hal::Measurements& m : out) m.wrist.force_n = Vec3(50.0, 0.0, 0.0);
  return out;
}

void BM_ControllerTick(benchmark::State& state) {
  const springbok::test::IsaLevelScope level(state);
  static const std::vector<hal::Measurements> ticks = pushed_standing_ticks();
  control::ControlParams params;
  params.tare_samples = 1;
  auto controller = std::make_unique<control::RobotController>(params);
  hal::Measurements first = ticks[0];
  first.wrist.force_n.setZero();
  controller->observe(first, kDt_s, true);  // the estimator started, the wrist tared
  hal::JointCommands cmd;
  for (int i = 0; i < 100; ++i) (void)controller->tick(ticks[static_cast<std::size_t>(i)], kDt_s, cmd);
  bool failed = false;
  int k = 0;
  for (auto _ : state) {
    failed = failed || controller->tick(ticks[static_cast<std::size_t>(k)], kDt_s, cmd) != control::TickStatus::ok;
    benchmark::DoNotOptimize(cmd.tau_ff_nm.data());
    k = (k + 1) % kTicks;
  }
  if (failed) state.SkipWithError("a tick failed");
}
BENCHMARK(BM_ControllerTick)->Apply(springbok::test::each_isa_level)->Unit(benchmark::kMicrosecond);

void BM_BaseEstimatorUpdate(benchmark::State& state) {
  const springbok::test::IsaLevelScope level(state);
  static const std::vector<hal::Measurements> ticks = pushed_standing_ticks();
  auto estimator = std::make_unique<est::BaseEstimator>(control::ControlParams{}.estimator);
  const Stance all{true, true, true, true};
  if (estimator->reset(ticks[0], all, Eigen::Vector2d::Zero()) != est::EstimateStatus::ok) {
    state.SkipWithError("reset failed");
    return;
  }
  bool failed = false;
  int k = 1;
  for (auto _ : state) {
    failed = failed || estimator->update(ticks[static_cast<std::size_t>(k)], all, kDt_s).status != est::EstimateStatus::ok;
    k = (k + 1) % kTicks;
  }
  if (failed) state.SkipWithError("an update failed");
}
BENCHMARK(BM_BaseEstimatorUpdate)->Apply(springbok::test::each_isa_level)->Unit(benchmark::kMicrosecond);

}  // namespace

BENCHMARK_MAIN();
