// bench_qp: Google Benchmark over the shared instance files (globbed at start-up).
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
#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include <Eigen/Cholesky>
#include <benchmark/benchmark.h>

#include "qp_file.hpp"
#include "springbok/qp/solver.hpp"

namespace {

namespace fs = std::filesystem;
using springbok::qpfile::Instance;

void report(benchmark::State& state, std::vector<double>& us) {
  if (us.empty()) return;
  std::sort(us.begin(), us.end());
  state.counters["median_us"] = us[us.size() / 2];
  state.counters["p99_us"] = us[std::min(us.size() - 1, static_cast<std::size_t>(std::ceil(0.99 * static_cast<double>(us.size()))) - 1)];
}

enum class Mode { cold, warm, warm_factor };

const char* mode_name(Mode mode) {
  return mode == Mode::cold ? "cold" : mode == Mode::warm ? "warm" : "warm-factor";
}

template <int N, int ME, int MI>
void bench_solve(benchmark::State& state, const Instance& in, Mode mode) {
  const bool warm = mode != Mode::cold;
  using S = springbok::qp::Solver<N, ME, MI>;
  auto solver = std::make_unique<S>();
  auto problem = std::make_unique<typename S::ProblemType>();
  auto result = std::make_unique<typename S::ResultType>();
  auto warm_set = std::make_unique<springbok::qp::ActiveSet<MI>>();
  springbok::qpfile::load_problem(in, *problem);
  solver->solve(*problem, *result);
  typename S::Hint hint;
  if (warm) hint.active_set = warm_set.get();
  hint.reuse_factor = mode == Mode::warm_factor;
  std::vector<double> us;
  us.reserve(1 << 16);
  for (auto _ : state) {
    if (warm) *warm_set = result->active;
    const auto t0 = std::chrono::steady_clock::now();
    benchmark::DoNotOptimize(solver->solve(*problem, *result, hint));
    const auto t1 = std::chrono::steady_clock::now();
    if (us.size() < us.capacity()) us.push_back(std::chrono::duration<double, std::micro>(t1 - t0).count());
  }
  state.counters["iterations"] = result->iterations;
  report(state, us);
}

void bench_eigen_llt(benchmark::State& state, const Instance& in) {
  Eigen::MatrixXd h(in.n, in.n);
  for (int i = 0; i < in.n; ++i)
    for (int j = 0; j < in.n; ++j) h(i, j) = in.H[static_cast<std::size_t>(i * in.n + j)];
  std::vector<double> us;
  us.reserve(1 << 16);
  for (auto _ : state) {
    const auto t0 = std::chrono::steady_clock::now();
    Eigen::LLT<Eigen::MatrixXd> llt(h);
    Eigen::MatrixXd inv_l = llt.matrixL().solve(Eigen::MatrixXd::Identity(in.n, in.n));
    benchmark::DoNotOptimize(inv_l.data());
    const auto t1 = std::chrono::steady_clock::now();
    if (us.size() < us.capacity()) us.push_back(std::chrono::duration<double, std::micro>(t1 - t0).count());
  }
  report(state, us);
}

std::vector<Instance>& instances() {
  static std::vector<Instance> all;
  return all;
}

}  // namespace

int main(int argc, char** argv) {
  const fs::path dir = fs::path(SPRINGBOK_SHARED_DIR) / "qp" / "instances";
  std::vector<std::string> files;
  for (const auto& e : fs::directory_iterator(dir))
    if (e.path().extension() == ".qp") files.push_back(e.path().string());
  std::sort(files.begin(), files.end());
  auto& all = instances();
  all.reserve(files.size());
  for (const auto& f : files) {
    std::string error;
    if (auto in = springbok::qpfile::read_instance(f, error)) all.push_back(std::move(*in));
  }
  for (const Instance& in : all) {
    const Instance* p = &in;
    for (const Mode m : {Mode::cold, Mode::warm, Mode::warm_factor}) {
      const std::string mode = mode_name(m);
      if (in.n <= 64 && in.meq <= 32 && in.mi <= 160) {
        benchmark::RegisterBenchmark(("qp/" + mode + "/fw/" + in.name).c_str(),
                                     [p, m](benchmark::State& s) { bench_solve<64, 32, 160>(s, *p, m); });
      } else {
        benchmark::RegisterBenchmark(("qp/" + mode + "/large/" + in.name).c_str(),
                                     [p, m](benchmark::State& s) { bench_solve<128, 128, 1024>(s, *p, m); });
      }
      if (in.family == "wbc" && in.n <= 40 && in.meq <= 12 && in.mi <= 62)
        benchmark::RegisterBenchmark(("qp/" + mode + "/wbc/" + in.name).c_str(),
                                     [p, m](benchmark::State& s) { bench_solve<40, 12, 62>(s, *p, m); });
    }
    if (in.family == "wbc")
      benchmark::RegisterBenchmark(("eigen_llt/" + in.name).c_str(), [p](benchmark::State& s) { bench_eigen_llt(s, *p); });
  }
  benchmark::Initialize(&argc, argv);
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
