// One lockstep tick of springbok-sim's stand scenario: the Bullet robot standing
// on its four feet under the joint-PD stand controller (read -> controller ->
// write -> step), and the physics step alone. Realtime factor = 1 ms / tick time.
// Median and p99 over repetitions, e.g.
//   bench_sim --benchmark_repetitions=20 --benchmark_report_aggregates_only=true
#include <benchmark/benchmark.h>

#include <memory>

#include "springbok/sim_hal/bullet_robot.hpp"
#include "springbok/wbc/stand_controller.hpp"

namespace {
using namespace springbok;

constexpr int kSettleTicks = 500;

// The stand.yaml set-up: nominal stance, feet touching the ground, settled.
struct StandingRobot {
  std::unique_ptr<sim::BulletRobot> robot;
  wbc::StandController stand{wbc::StandGains{}, wbc::nominal_stance()};
  hal::Measurements measurements;
  hal::JointCommands commands;

  explicit StandingRobot(int solver_iterations) {
    sim::SimConfig config;
    config.solver_iterations = solver_iterations;
    config.initial_q[2] = 0.65;
    config.initial_q.tail<kNj>() = wbc::nominal_stance();
    {
      sim::BulletRobot probe(config);
      if (!probe.configure().ok) return;
      config.initial_q[2] -= probe.lowest_foot_clearance_m();
    }
    robot = std::make_unique<sim::BulletRobot>(config);
    if (!robot->configure().ok || !robot->activate().ok) {
      robot.reset();
      return;
    }
    for (int k = 0; k < kSettleTicks; ++k) tick();
  }
  void tick() noexcept {
    robot->read(measurements);
    stand.tick(robot->ground_truth().q, commands);
    robot->write(commands);
    robot->step();
  }
};

void BM_SimStandTick(benchmark::State& state) {
  StandingRobot s(static_cast<int>(state.range(0)));
  if (!s.robot) {
    state.SkipWithError("the simulated robot did not configure");
    return;
  }
  for (auto _ : state) s.tick();
  if (s.robot->ground_truth().non_foot_ground_contact) state.SkipWithError("the robot fell");
}
BENCHMARK(BM_SimStandTick)->ArgName("solver_iterations")->Arg(3)->Arg(5)->Arg(10)->Unit(benchmark::kMicrosecond);

void BM_SimStep(benchmark::State& state) {
  StandingRobot s(sim::SimConfig{}.solver_iterations);
  if (!s.robot) {
    state.SkipWithError("the simulated robot did not configure");
    return;
  }
  for (auto _ : state) s.robot->step();  // the last command holds
}
BENCHMARK(BM_SimStep)->Unit(benchmark::kMicrosecond);

}  // namespace

BENCHMARK_MAIN();
