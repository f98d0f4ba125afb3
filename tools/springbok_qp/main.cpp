// springbok-qp [--solution DIR] [--bench REPS] [--warm | --warm-factor] FILE...
//
// Solves each instance file (tests/data/qp/FORMAT.md) with springbok::qp::Solver and
// prints one line per file:  <name> <status> <objective> <iterations> [<median_us> <p99_us>]
// Status words: optimal infeasible error maxiter size. Firmware-sized instances
// (n <= 64, m_eq <= 32, m_in <= 160) use Solver<64, 32, 160>; larger ones a
// Solver<128, 128, 1024> allocated at start-up; beyond that: size.
// --warm: each timed solve starts from the active set of the previous solve when that
// solve was optimal (as the WBC does); after another status it starts cold.
// --warm-factor: also reuses the previous solve's Cholesky factor of the same H
// (StartHint::reuse_factor; the solver checks that H is unchanged).
// With --bench, a last line on stderr sums up the run: the median of the per-instance
// medians, the p99 of all timed solves pooled, and the same two for a dense Eigen LLT
// of H plus L^-1 timed in the same run (the reference the QP issue gives the
// libraries' figures against: best library ~2x that LLT's median).
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include <Eigen/Cholesky>
#include <Eigen/Core>

#include "qp_file.hpp"
#include "springbok/qp/solver.hpp"

namespace {

using springbok::qp::Solver;
namespace qpfile = springbok::qpfile;

struct Args {
  std::string solution_dir;
  int bench_reps = 0;
  bool warm = false;
  bool warm_factor = false;  // --warm-factor: warm active set and the previous factor of H
  std::vector<std::string> files;
};

void usage() {
  std::fprintf(stderr, "usage: springbok-qp [--solution DIR] [--bench REPS] [--warm | --warm-factor] FILE...\n");
}

bool parse_args(int argc, char** argv, Args& args) {
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--solution" || a == "--bench") {
      if (i + 1 >= argc) {
        std::fprintf(stderr, "springbok-qp: %s needs a value\n", a.c_str());
        return false;
      }
      const std::string value = argv[++i];
      if (a == "--solution") {
        args.solution_dir = value;
      } else {
        char* end = nullptr;
        const long reps = std::strtol(value.c_str(), &end, 10);
        if (end == value.c_str() || *end != '\0' || reps < 1 || reps > 100000000) {
          std::fprintf(stderr, "springbok-qp: --bench needs a positive integer, got '%s'\n", value.c_str());
          return false;
        }
        args.bench_reps = static_cast<int>(reps);
      }
    } else if (a == "--warm") {
      args.warm = true;
    } else if (a == "--warm-factor") {
      args.warm = true;
      args.warm_factor = true;
    } else if (a.size() > 1 && a[0] == '-') {
      std::fprintf(stderr, "springbok-qp: unknown option '%s'\n", a.c_str());
      return false;
    } else {
      args.files.push_back(a);
    }
  }
  if (args.files.empty()) {
    std::fprintf(stderr, "springbok-qp: no instance files given\n");
    return false;
  }
  return true;
}

double median_of(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  const std::size_t count = v.size();
  return count % 2 == 1 ? v[count / 2] : 0.5 * (v[count / 2 - 1] + v[count / 2]);
}

double p99_of(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  const auto rank = static_cast<std::size_t>(std::ceil(0.99 * static_cast<double>(v.size())));
  return v[std::max<std::size_t>(rank, 1) - 1];
}

// Every timed solve of the run, and the per-instance medians (for the summary).
struct BenchLog {
  std::vector<double> solve_us, solve_medians, llt_us, llt_medians;
};

// A dense Eigen LLT of H plus L^-1 (heap-sized, as a generic library would), timed reps times.
std::vector<double> time_eigen_llt(const qpfile::Instance& in, int reps) {
  Eigen::MatrixXd h(in.n, in.n);
  for (int i = 0; i < in.n; ++i)
    for (int j = 0; j < in.n; ++j) h(i, j) = in.H[static_cast<std::size_t>(i * in.n + j)];
  std::vector<double> us(static_cast<std::size_t>(reps));
  double sink = 0.0;
  for (auto& t : us) {
    const auto start = std::chrono::steady_clock::now();
    const Eigen::LLT<Eigen::MatrixXd> llt(h);
    const Eigen::MatrixXd inv_l = llt.matrixL().solve(Eigen::MatrixXd::Identity(in.n, in.n));
    const auto stop = std::chrono::steady_clock::now();
    sink += inv_l(in.n - 1, 0);
    t = std::chrono::duration<double, std::micro>(stop - start).count();
  }
  if (!std::isfinite(sink)) us.assign(us.size(), NAN);  // keeps the work observable
  return us;
}

struct Outcome {
  std::string status = "error";
  double objective = NAN;
  int iterations = 0;
  double median_us = NAN, p99_us = NAN;
  std::vector<double> x, lambda_eq, lambda_in;
};

// One solver size: the solver, its problem and result, allocated once at start-up.
template <int N, int ME, int MI>
struct Slot {
  using S = Solver<N, ME, MI>;
  std::unique_ptr<S> solver = std::make_unique<S>();
  std::unique_ptr<typename S::ProblemType> problem = std::make_unique<typename S::ProblemType>();
  std::unique_ptr<typename S::ResultType> result = std::make_unique<typename S::ResultType>();
  std::unique_ptr<springbok::qp::ActiveSet<MI>> warm_set = std::make_unique<springbok::qp::ActiveSet<MI>>();

  bool fits(const qpfile::Instance& in) const { return in.n <= N && in.meq <= ME && in.mi <= MI; }

  Outcome run(const qpfile::Instance& in, const Args& args, BenchLog& log) {
    *problem = typename S::ProblemType{};
    qpfile::load_problem(in, *problem);
    auto& r = *result;
    solver->solve(*problem, r);
    Outcome out;
    if (args.bench_reps > 0) {
      std::vector<double> times_us(static_cast<std::size_t>(args.bench_reps));
      for (auto& t : times_us) {
        typename S::Hint hint;
        if (args.warm) {
          // As the WBC does: the previous solve's active set when it was optimal; after
          // any other status (whose active set is cleared) no set at all. An empty set
          // would be a hint too, that no row is active, and its repairs and the full
          // method from them cost the infeasible instances 13-19 % over a cold start.
          if (r.status == springbok::qp::Status::optimal) {
            *warm_set = r.active;
            hint.active_set = warm_set.get();
          }
          hint.reuse_factor = args.warm_factor;
        }
        const auto start = std::chrono::steady_clock::now();
        solver->solve(*problem, r, hint);
        const auto stop = std::chrono::steady_clock::now();
        t = std::chrono::duration<double, std::micro>(stop - start).count();
      }
      out.median_us = median_of(times_us);
      out.p99_us = p99_of(times_us);
      log.solve_us.insert(log.solve_us.end(), times_us.begin(), times_us.end());
      log.solve_medians.push_back(out.median_us);
      const std::vector<double> llt_us = time_eigen_llt(in, args.bench_reps);
      log.llt_us.insert(log.llt_us.end(), llt_us.begin(), llt_us.end());
      log.llt_medians.push_back(median_of(llt_us));
    }
    out.status = qpfile::status_word(r.status);
    out.iterations = r.iterations;
    if (r.status == springbok::qp::Status::optimal) {
      out.objective = r.objective;
      out.x.assign(r.x.begin(), r.x.begin() + in.n);
      out.lambda_eq.assign(r.lambda_eq.begin(), r.lambda_eq.begin() + in.meq);
      out.lambda_in.assign(r.lambda_in.begin(), r.lambda_in.begin() + in.mi);
    }
    return out;
  }
};

void print_line(const std::string& name, const Outcome& o, bool bench) {
  std::printf("%s %s %.17g %d", name.c_str(), o.status.c_str(), o.objective, o.iterations);
  if (bench) std::printf(" %.3f %.3f", o.median_us, o.p99_us);
  std::printf("\n");
}

}  // namespace

int main(int argc, char** argv) {
  Args args;
  if (!parse_args(argc, argv, args)) {
    usage();
    return 2;
  }
  if (!args.solution_dir.empty() && !std::filesystem::is_directory(args.solution_dir)) {
    std::fprintf(stderr, "springbok-qp: --solution: '%s' is not a directory\n", args.solution_dir.c_str());
    return 2;
  }
  Slot<64, 32, 160> firmware_size;
  Slot<128, 128, 1024> large_size;
  int exit_code = 0;
  const bool bench = args.bench_reps > 0;
  BenchLog log;
  for (const std::string& file : args.files) {
    std::string error;
    const auto instance = qpfile::read_instance(file, error);
    if (!instance) {
      std::fprintf(stderr, "springbok-qp: %s\n", error.c_str());
      print_line(std::filesystem::path(file).stem().string(), Outcome{}, bench);
      std::fflush(stdout);
      exit_code = 1;
      continue;
    }
    Outcome outcome;
    if (firmware_size.fits(*instance)) {
      outcome = firmware_size.run(*instance, args, log);
    } else if (large_size.fits(*instance)) {
      outcome = large_size.run(*instance, args, log);
    } else {
      outcome.status = "size";
    }
    print_line(instance->name, outcome, bench);
    std::fflush(stdout);
    if (!args.solution_dir.empty()) {
      const qpfile::Solution sol{instance->name, outcome.status, outcome.x, outcome.lambda_eq, outcome.lambda_in};
      if (!qpfile::write_solution(args.solution_dir, sol)) {
        std::fprintf(stderr, "springbok-qp: cannot write %s/%s.sol\n", args.solution_dir.c_str(),
                     instance->name.c_str());
        exit_code = 1;
      }
    }
  }
  if (bench && !log.solve_medians.empty()) {
    std::fprintf(stderr,
                 "springbok-qp: summary: %zu instances x %d solves (%s): median of medians %.3f us, pooled p99 %.3f us; "
                 "eigen LLT+L^-1 same run: median of medians %.3f us, pooled p99 %.3f us\n",
                 log.solve_medians.size(), args.bench_reps, args.warm_factor ? "warm+factor" : args.warm ? "warm" : "cold",
                 median_of(log.solve_medians), p99_of(log.solve_us), median_of(log.llt_medians), p99_of(log.llt_us));
  }
  return exit_code;
}
