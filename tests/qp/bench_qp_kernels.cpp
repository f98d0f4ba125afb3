// bench_qp's timed loops (bench_qp_kernels.hpp).
#include "bench_qp_kernels.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <memory>
#include <vector>

#include <Eigen/Cholesky>

#include "springbok/qp/solver.hpp"

namespace springbok::qpbench {
namespace {

using qpfile::Instance;

void report(benchmark::State& state, std::vector<double>& us) {
  if (us.empty()) return;
  std::sort(us.begin(), us.end());
  state.counters["median_us"] = us[us.size() / 2];
  state.counters["p99_us"] = us[std::min(us.size() - 1, static_cast<std::size_t>(std::ceil(0.99 * static_cast<double>(us.size()))) - 1)];
}

template <int N, int ME, int MI>
void bench_solve(benchmark::State& state, const Instance& in, Mode mode) {
  const bool warm = mode != Mode::cold;
  using S = springbok::qp::Solver<N, ME, MI>;
  auto solver = std::make_unique<S>();
  auto problem = std::make_unique<typename S::ProblemType>();
  auto result = std::make_unique<typename S::ResultType>();
  auto warm_set = std::make_unique<springbok::qp::ActiveSet<MI>>();
  qpfile::load_problem(in, *problem);
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

constexpr Kernels kThisLevel{&bench_solve<64, 32, 160>, &bench_solve<128, 128, 1024>, &bench_solve<40, 12, 62>,
                             &bench_eigen_llt};

}  // namespace

#ifdef SPRINGBOK_ISA_NAMESPACE
// Compiled into one level's object (toolchain/springbok_isa.cmake): its table.
namespace SPRINGBOK_ISA_NAMESPACE {
extern const Kernels kKernels;
const Kernels kKernels = kThisLevel;
}  // namespace SPRINGBOK_ISA_NAMESPACE
#else
const Kernels kBaselineKernels = kThisLevel;
#endif

}  // namespace springbok::qpbench
