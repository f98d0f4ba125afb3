// Property tests on thousands of random QPs:
//  - optimal ones built from chosen KKT conditions (x*, multipliers with the right
//    signs, active / inactive / degenerate / dependent / duplicated rows, lb == ub
//    rows, redundant equalities), so x* is known exactly: g = -(H x* + Aeq'le + Ain'li);
//  - infeasible ones with a Farkas certificate built in (contradictory combinations,
//    conflicting equalities, lb > ub);
//  - bad inputs (NaN, inf, indefinite H, sizes out of range, garbage warm starts)
//    that must be reported, never crash, never return a non-finite "solution".
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "kkt_check.hpp"
#include "springbok/qp/solver.hpp"

namespace {

using springbok::qp::Side;
using springbok::qp::Status;
using springbok::qp::test::DenseQp;
using springbok::qp::test::kkt_check;

constexpr int kN = 24, kME = 12, kMI = 48;
using Solver = springbok::qp::Solver<kN, kME, kMI>;
using Problem = Solver::ProblemType;
using Result = Solver::ResultType;
constexpr double kInf = std::numeric_limits<double>::infinity();

struct Rng {
  std::mt19937_64 engine;
  explicit Rng(std::uint64_t seed) : engine(seed) {}
  double normal() { return std::normal_distribution<double>(0.0, 1.0)(engine); }
  double uniform(double a, double b) { return std::uniform_real_distribution<double>(a, b)(engine); }
  int integer(int a, int b) { return std::uniform_int_distribution<int>(a, b)(engine); }
  bool chance(double p) { return uniform(0.0, 1.0) < p; }
};

double row_dot(const std::vector<double>& a, int row, int n, const std::vector<double>& x) {
  double s = 0.0;
  for (int j = 0; j < n; ++j) s += a[static_cast<std::size_t>(row * n + j)] * x[static_cast<std::size_t>(j)];
  return s;
}

// Random SPD H = M M' + delta I, sometimes badly scaled (D H D).
std::vector<double> random_spd(Rng& rng, int n) {
  std::vector<double> m(static_cast<std::size_t>(n * n)), h(static_cast<std::size_t>(n * n), 0.0), d(static_cast<std::size_t>(n), 1.0);
  for (double& v : m) v = rng.normal();
  const double delta = std::pow(10.0, rng.uniform(-2.0, 1.0));
  if (rng.chance(0.3))
    for (double& v : d) v = std::pow(10.0, rng.uniform(-1.5, 1.5));
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j) {
      double s = i == j ? delta : 0.0;
      for (int k = 0; k < n; ++k) s += m[static_cast<std::size_t>(i * n + k)] * m[static_cast<std::size_t>(j * n + k)];
      h[static_cast<std::size_t>(i * n + j)] = s * d[static_cast<std::size_t>(i)] * d[static_cast<std::size_t>(j)];
    }
  // Often some variables are separable (no coupling in H, as the WBC's contact forces):
  // the solver orders them last and factors only the coupled block. Zeroing a
  // variable's off-diagonal entries keeps H positive definite.
  if (rng.chance(0.5)) {
    for (int j = 0; j < n; ++j) {
      if (!rng.chance(0.6)) continue;
      for (int i = 0; i < n; ++i)
        if (i != j) h[static_cast<std::size_t>(i * n + j)] = h[static_cast<std::size_t>(j * n + i)] = 0.0;
    }
  }
  return h;
}

struct Generated {
  DenseQp qp;
  std::vector<double> xstar;
};

// An optimal QP with known solution, from chosen KKT conditions.
Generated make_optimal(Rng& rng) {
  Generated out;
  DenseQp& q = out.qp;
  q.n = rng.integer(1, kN);
  const int n = q.n;
  q.meq = rng.integer(0, std::min(kME, n));
  q.mi = rng.integer(0, kMI);
  q.H = random_spd(rng, n);
  const double x_scale = std::pow(10.0, rng.uniform(-1.0, 1.0));
  std::vector<double>& x = out.xstar;
  x.resize(static_cast<std::size_t>(n));
  for (double& v : x) v = x_scale * rng.normal();
  std::vector<double> le(static_cast<std::size_t>(q.meq)), li(static_cast<std::size_t>(q.mi), 0.0);
  q.Aeq.assign(static_cast<std::size_t>(q.meq * n), 0.0);
  q.beq.resize(static_cast<std::size_t>(q.meq));
  const int independent = rng.integer(0, std::min(q.meq, n - 1));
  for (int k = 0; k < q.meq; ++k) {
    if (k < independent || k == 0) {
      for (int j = 0; j < n; ++j) q.Aeq[static_cast<std::size_t>(k * n + j)] = rng.normal();
    } else {  // redundant: a scaled duplicate or a combination of earlier rows
      const int a = rng.integer(0, k - 1), b = rng.integer(0, k - 1);
      const double ca = rng.uniform(-3.0, 3.0), cb = rng.chance(0.5) ? 0.0 : rng.uniform(-3.0, 3.0);
      for (int j = 0; j < n; ++j)
        q.Aeq[static_cast<std::size_t>(k * n + j)] =
            ca * q.Aeq[static_cast<std::size_t>(a * n + j)] + cb * q.Aeq[static_cast<std::size_t>(b * n + j)];
    }
    q.beq[static_cast<std::size_t>(k)] = row_dot(q.Aeq, k, n, x);
    le[static_cast<std::size_t>(k)] = rng.chance(0.2) ? 0.0 : rng.normal();
  }
  q.Ain.assign(static_cast<std::size_t>(q.mi * n), 0.0);
  q.lb.resize(static_cast<std::size_t>(q.mi));
  q.ub.resize(static_cast<std::size_t>(q.mi));
  std::vector<int> active_rows;
  for (int i = 0; i < q.mi; ++i) {
    const int kind = rng.integer(0, 9);
    auto row = [&](int j) -> double& { return q.Ain[static_cast<std::size_t>(i * n + j)]; };
    if (kind == 7 && !active_rows.empty()) {  // dependent on (a copy or combination of) active rows
      const int a = active_rows[static_cast<std::size_t>(rng.integer(0, static_cast<int>(active_rows.size()) - 1))];
      const int b = active_rows[static_cast<std::size_t>(rng.integer(0, static_cast<int>(active_rows.size()) - 1))];
      const double ca = rng.chance(0.5) ? 1.0 : rng.uniform(0.1, 3.0), cb = rng.chance(0.5) ? 0.0 : rng.uniform(-2.0, 2.0);
      for (int j = 0; j < n; ++j)
        row(j) = ca * q.Ain[static_cast<std::size_t>(a * n + j)] + cb * q.Ain[static_cast<std::size_t>(b * n + j)];
    } else if (kind == 8) {  // zero row, 0 inside the bounds
      for (int j = 0; j < n; ++j) row(j) = 0.0;
    } else {
      const double row_scale = rng.chance(0.2) ? std::pow(10.0, rng.uniform(-3.0, 3.0)) : 1.0;
      for (int j = 0; j < n; ++j) row(j) = row_scale * rng.normal();
    }
    const double ax = row_dot(q.Ain, i, n, x);
    const double gap1 = rng.uniform(0.01, 2.0) * (1.0 + std::abs(ax)), gap2 = rng.uniform(0.01, 2.0) * (1.0 + std::abs(ax));
    double& lo = q.lb[static_cast<std::size_t>(i)];
    double& hi = q.ub[static_cast<std::size_t>(i)];
    double& lam = li[static_cast<std::size_t>(i)];
    const bool degenerate = rng.chance(0.15);
    if (kind == 8) {
      lo = -gap1;
      hi = rng.chance(0.5) ? gap2 : 0.0;
    } else if (kind <= 2 || kind == 7) {  // active at the lower bound
      lo = ax;
      hi = rng.chance(0.3) ? (rng.chance(0.5) ? kInf : 1e20) : ax + gap2;
      lam = degenerate ? 0.0 : -rng.uniform(0.01, 3.0);
      active_rows.push_back(i);
    } else if (kind <= 4) {  // active at the upper bound
      hi = ax;
      lo = rng.chance(0.3) ? (rng.chance(0.5) ? -kInf : -1e20) : ax - gap1;
      lam = degenerate ? 0.0 : rng.uniform(0.01, 3.0);
      active_rows.push_back(i);
    } else if (kind == 5) {  // lb == ub row
      lo = hi = ax;
      lam = rng.normal();
    } else if (kind == 6 && rng.chance(0.3)) {  // free row
      lo = -kInf;
      hi = kInf;
    } else {  // inactive
      lo = rng.chance(0.2) ? -kInf : ax - gap1;
      hi = rng.chance(0.2) ? kInf : ax + gap2;
    }
  }
  q.g.resize(static_cast<std::size_t>(n));
  for (int j = 0; j < n; ++j) {
    double s = 0.0;
    for (int k = 0; k < n; ++k) s += q.H[static_cast<std::size_t>(j * n + k)] * x[static_cast<std::size_t>(k)];
    for (int k = 0; k < q.meq; ++k) s += q.Aeq[static_cast<std::size_t>(k * n + j)] * le[static_cast<std::size_t>(k)];
    for (int k = 0; k < q.mi; ++k) s += q.Ain[static_cast<std::size_t>(k * n + j)] * li[static_cast<std::size_t>(k)];
    q.g[static_cast<std::size_t>(j)] = -s;
  }
  return out;
}

double max_abs(const std::vector<double>& v) {
  double m = 0.0;
  for (double e : v) m = std::max(m, std::abs(e));
  return m;
}

// The generator's x* (to 1e-6 of its scale) and the KKT conditions met.
::testing::AssertionResult is_known_answer(const Generated& gen, const Result& r) {
  const DenseQp& q = gen.qp;
  double err = 0.0;
  for (int i = 0; i < q.n; ++i)
    err = std::max(err, std::abs(r.x[static_cast<std::size_t>(i)] - gen.xstar[static_cast<std::size_t>(i)]));
  if (!(err <= 1e-6 * std::max(1.0, max_abs(gen.xstar)))) return ::testing::AssertionFailure() << "|x - x*| " << err;
  const auto kkt = kkt_check(q, r.x.data(), r.lambda_eq.data(), r.lambda_in.data());
  if (!(kkt.primal <= 1e-8 && kkt.stationarity <= 1e-7 && kkt.wrong_sign <= 1e-8 && kkt.complementarity <= 1e-8))
    return ::testing::AssertionFailure() << "KKT: primal " << kkt.primal << " stationarity " << kkt.stationarity
                                         << " wrong sign " << kkt.wrong_sign << " complementarity " << kkt.complementarity;
  return ::testing::AssertionSuccess();
}

void load(const DenseQp& q, Problem& p) {
  p = Problem{};
  p.resize(q.n, q.meq, q.mi);
  for (int i = 0; i < q.n; ++i) {
    for (int j = 0; j < q.n; ++j) p.H()(i, j) = q.H[static_cast<std::size_t>(i * q.n + j)];
    p.g()(i) = q.g[static_cast<std::size_t>(i)];
  }
  for (int k = 0; k < q.meq; ++k) {
    for (int j = 0; j < q.n; ++j) p.Aeq()(k, j) = q.Aeq[static_cast<std::size_t>(k * q.n + j)];
    p.beq()(k) = q.beq[static_cast<std::size_t>(k)];
  }
  for (int k = 0; k < q.mi; ++k) {
    for (int j = 0; j < q.n; ++j) p.Ain()(k, j) = q.Ain[static_cast<std::size_t>(k * q.n + j)];
    p.lb()(k) = q.lb[static_cast<std::size_t>(k)];
    p.ub()(k) = q.ub[static_cast<std::size_t>(k)];
  }
}

struct QpProperties : ::testing::Test {
  std::unique_ptr<Solver> solver = std::make_unique<Solver>();
  std::unique_ptr<Problem> problem = std::make_unique<Problem>();
  std::unique_ptr<Result> result = std::make_unique<Result>();
};

TEST_F(QpProperties, RandomKktConstructedQpsAreSolvedExactly) {
  Rng rng(20240611);
  int warm_checked = 0, warm_without_change = 0, warm_from_hint = 0;
  for (int trial = 0; trial < 3000; ++trial) {
    const Generated gen = make_optimal(rng);
    const DenseQp& q = gen.qp;
    load(q, *problem);
    const Status status = solver->solve(*problem, *result);
    ASSERT_EQ(status, Status::optimal) << "trial " << trial << " n " << q.n << " meq " << q.meq << " mi " << q.mi;
    const double xs = max_abs(gen.xstar);
    ASSERT_TRUE(is_known_answer(gen, *result)) << "trial " << trial;
    // Warm start from the found set: same x, (nearly always) no active-set change.
    const auto warm = result->active;
    Solver::Hint hint;
    hint.active_set = &warm;
    const std::array<double, kN> cold_x = result->x;
    ASSERT_EQ(solver->solve(*problem, *result, hint), Status::optimal) << "trial " << trial;
    if (result->iterations == 0) ++warm_without_change;
    if (result->from_hint) ++warm_from_hint;
    for (int i = 0; i < q.n; ++i)
      ASSERT_NEAR(result->x[static_cast<std::size_t>(i)], cold_x[static_cast<std::size_t>(i)], 1e-8 * std::max(1.0, xs));
    const auto warm_kkt = kkt_check(q, result->x.data(), result->lambda_eq.data(), result->lambda_in.data());
    ASSERT_LE(warm_kkt.primal, 1e-8) << "trial " << trial;
    ASSERT_LE(warm_kkt.stationarity, 1e-7) << "trial " << trial;
    ASSERT_LE(warm_kkt.wrong_sign, 1e-8) << "trial " << trial;
    ASSERT_LE(warm_kkt.complementarity, 1e-8) << "trial " << trial;
    ++warm_checked;
  }
  EXPECT_EQ(warm_checked, 3000);
  // The found set, given back, is solved on directly (the shortcut) unless its rows are
  // dependent or nearly so: the generator makes most draws degenerate on purpose (more
  // equality rows than variables, duplicated rows, active sets that fill the space);
  // those take the full method. This seed: 940 direct.
  std::printf("warm from the found set: %d of 3000 solved on the hint directly, %d without a change\n", warm_from_hint,
              warm_without_change);
  EXPECT_GE(warm_from_hint, 800);
  // Degenerate vertices (zero multipliers, dependent rows) may cost a step or two;
  // nearly always the found set is taken as is.
  EXPECT_GE(warm_without_change, 2900);
}

// The found set with rows left out: the shortcut adds them back one repair each, extending the
// last answer by the row added (solver_warm_start.hpp: extend_solution) rather than solving the
// set again. The answer is the generator's x* and meets the KKT conditions as a cold solve's
// does, on coupled H, equalities and rows of mixed scale.
TEST_F(QpProperties, AHintShortOfRowsIsRepairedToTheKnownAnswer) {
  Rng rng(20261202);
  int repaired = 0, several = 0;
  for (int trial = 0; trial < 3000; ++trial) {
    const Generated gen = make_optimal(rng);
    const DenseQp& q = gen.qp;
    load(q, *problem);
    ASSERT_EQ(solver->solve(*problem, *result), Status::optimal) << "trial " << trial;
    const auto found = result->active;
    springbok::qp::ActiveSet<kMI> hint_set;
    const int leave_out = rng.integer(1, 3);
    int left_out = 0;
    for (int e = 0; e < found.size; ++e) {
      const auto k = static_cast<std::size_t>(e);
      if (found.side[k] != Side::equal && left_out < leave_out && rng.chance(0.5)) {
        ++left_out;
        continue;
      }
      hint_set.push(found.row[k], found.side[k]);
    }
    if (left_out == 0) continue;
    Solver::Hint hint;
    hint.active_set = &hint_set;
    ASSERT_EQ(solver->solve(*problem, *result, hint), Status::optimal) << "trial " << trial;
    ASSERT_TRUE(is_known_answer(gen, *result)) << "trial " << trial;
    if (result->from_hint && result->iterations >= 1) ++repaired;
    if (result->from_hint && result->iterations >= 2) ++several;
  }
  // This seed: 550 repaired, 386 of them twice or more; the degenerate draws take the full
  // method (as in the test above). A wrong extension fails the shortcut's own checks and falls
  // back (the answer stays right): these counts are what sees it (a wrong step: 9 and 0).
  std::printf("hint short of rows: %d repaired in the shortcut, %d of them with two or more repairs\n", repaired,
              several);
  EXPECT_GE(repaired, 500);
  EXPECT_GE(several, 340);
}

// Opt-in soak (not run by CI): SPRINGBOK_QP_SOAK_SEEDS=S and SPRINGBOK_QP_SOAK_TRIALS=T
// solve T random KKT-constructed QPs for each of S seeds from SPRINGBOK_QP_SOAK_FIRST
// (default 1), cold. A solve fails when it is not optimal or its own KKT residuals miss
// the instance criteria (primal 1e-8, stationarity 1e-7, wrong sign 1e-8), or when a warm
// start from a junk active set disagrees with it (status, or its own KKT residuals); one that
// satisfies KKT but lies farther than 1e-6 from x* is counted apart (an ill-conditioned
// draw: the KKT point is the minimiser, x* is only known to rounding).
TEST_F(QpProperties, SoakRandomKktConstructedQps) {
  const char* seeds_env = std::getenv("SPRINGBOK_QP_SOAK_SEEDS");
  const char* trials_env = std::getenv("SPRINGBOK_QP_SOAK_TRIALS");
  if (seeds_env == nullptr || trials_env == nullptr) GTEST_SKIP() << "set SPRINGBOK_QP_SOAK_SEEDS and _TRIALS to soak";
  const int seeds = std::atoi(seeds_env), trials = std::atoi(trials_env);
  const char* first_env = std::getenv("SPRINGBOK_QP_SOAK_FIRST");
  const int first = first_env != nullptr ? std::atoi(first_env) : 1;
  int failures = 0, far_from_xstar = 0, from_hint = 0;
  for (int seed = first; seed < first + seeds; ++seed) {
    Rng rng(static_cast<std::uint64_t>(seed));
    for (int trial = 0; trial < trials; ++trial) {
      const Generated gen = make_optimal(rng);
      load(gen.qp, *problem);
      const Status status = solver->solve(*problem, *result);
      const auto kkt = kkt_check(gen.qp, result->x.data(), result->lambda_eq.data(), result->lambda_in.data());
      double xs = 0.0, err = 0.0;
      for (int i = 0; i < gen.qp.n; ++i) {
        xs = std::max(xs, std::abs(gen.xstar[static_cast<std::size_t>(i)]));
        err = std::max(err, std::abs(result->x[static_cast<std::size_t>(i)] - gen.xstar[static_cast<std::size_t>(i)]));
      }
      const bool kkt_ok = kkt.primal <= 1e-8 && kkt.stationarity <= 1e-7 && kkt.wrong_sign <= 1e-8;
      if (status != Status::optimal || !kkt_ok) {
        ++failures;
        ADD_FAILURE() << "seed " << seed << " trial " << trial << " status " << springbok::qp::to_string(status)
                      << " err " << err << " n " << gen.qp.n << " meq " << gen.qp.meq << " mi " << gen.qp.mi
                      << " kkt primal " << kkt.primal << " stationarity " << kkt.stationarity << " wrong_sign "
                      << kkt.wrong_sign;
      } else if (!(err <= 1e-6 * std::max(1.0, xs))) {
        ++far_from_xstar;
      }
      const std::array<double, kN> cold_x = result->x;
      // Warm-started from its own active set (the shortcut's case): the same status and
      // its own KKT residuals within the criteria.
      if (status == Status::optimal) {
        const springbok::qp::ActiveSet<kMI> own = result->active;
        Solver::Hint own_hint;
        own_hint.active_set = &own;
        const Status own_status = solver->solve(*problem, *result, own_hint);
        const auto own_kkt = kkt_check(gen.qp, result->x.data(), result->lambda_eq.data(), result->lambda_in.data());
        if (own_status != status || !(own_kkt.primal <= 1e-8 && own_kkt.stationarity <= 1e-7 && own_kkt.wrong_sign <= 1e-8)) {
          ++failures;
          ADD_FAILURE() << "seed " << seed << " trial " << trial << " warm from its own set: "
                        << springbok::qp::to_string(own_status) << " (from hint " << result->from_hint << "), kkt primal "
                        << own_kkt.primal << " stationarity " << own_kkt.stationarity << " wrong_sign " << own_kkt.wrong_sign;
        }
        if (result->from_hint) ++from_hint;
      }
      // The same QP warm-started from a junk active set must agree with the cold solve.
      springbok::qp::ActiveSet<kMI> junk;
      for (int k = 0; k < 10; ++k) junk.push(rng.integer(0, std::max(0, gen.qp.mi - 1)), static_cast<Side>(rng.integer(0, 1)));
      Solver::Hint hint;
      hint.active_set = &junk;
      const Status warm_status = solver->solve(*problem, *result, hint);
      double warm_diff = 0.0;
      for (int i = 0; i < gen.qp.n; ++i)
        warm_diff = std::max(warm_diff, std::abs(result->x[static_cast<std::size_t>(i)] - cold_x[static_cast<std::size_t>(i)]));
      const auto warm_kkt = kkt_check(gen.qp, result->x.data(), result->lambda_eq.data(), result->lambda_in.data());
      const bool warm_kkt_ok = warm_kkt.primal <= 1e-8 && warm_kkt.stationarity <= 1e-7 && warm_kkt.wrong_sign <= 1e-8;
      if (warm_status != status || (status == Status::optimal && !warm_kkt_ok)) {
        ++failures;
        ADD_FAILURE() << "seed " << seed << " trial " << trial << " warm from junk: " << springbok::qp::to_string(warm_status)
                      << " (cold " << springbok::qp::to_string(status) << "), x differs by " << warm_diff
                      << ", its kkt primal " << warm_kkt.primal << " stationarity " << warm_kkt.stationarity;
      }
    }
  }
  std::printf("soak: %d seeds x %d trials: %d failures, %d KKT points farther than 1e-6 from x*, %d warm starts from "
              "their own set solved on it directly\n", seeds, trials, failures, far_from_xstar, from_hint);
}

// Appends a contradiction to an otherwise feasible random QP.
DenseQp make_infeasible(Rng& rng, int trial) {
  DenseQp q = make_optimal(rng).qp;
  const int n = q.n;
  std::vector<double> x0(static_cast<std::size_t>(n));
  for (double& v : x0) v = rng.normal();
  auto add_row = [&](const std::vector<double>& a, double lo, double hi) {
    q.Ain.insert(q.Ain.end(), a.begin(), a.end());
    q.lb.push_back(lo);
    q.ub.push_back(hi);
    ++q.mi;
  };
  if (q.mi > kMI - 4) {
    q.mi = kMI - 4;
    q.Ain.resize(static_cast<std::size_t>(q.mi * n));
    q.lb.resize(static_cast<std::size_t>(q.mi));
    q.ub.resize(static_cast<std::size_t>(q.mi));
  }
  const int kind = trial % 4;
  if (kind == 0) {  // Farkas: a_1..a_k x >= a_i x0, -(sum c_i a_i) x >= -(sum c_i a_i x0) + eps
    const int k = rng.integer(1, 3);
    std::vector<double> combo(static_cast<std::size_t>(n), 0.0);
    double rhs = 0.0;
    for (int r = 0; r < k; ++r) {
      std::vector<double> a(static_cast<std::size_t>(n));
      for (double& v : a) v = rng.normal();
      double ax0 = 0.0;
      for (int j = 0; j < n; ++j) ax0 += a[static_cast<std::size_t>(j)] * x0[static_cast<std::size_t>(j)];
      const double c = rng.uniform(0.2, 2.0);
      for (int j = 0; j < n; ++j) combo[static_cast<std::size_t>(j)] -= c * a[static_cast<std::size_t>(j)];
      rhs -= c * ax0;
      add_row(a, ax0, rng.chance(0.5) ? kInf : ax0 + 1.0);
    }
    const double eps = 1e-3 * (1.0 + std::abs(rhs));
    if (rng.chance(0.5)) {
      add_row(combo, rhs + eps, kInf);
    } else {  // the same constraint written as an upper bound
      for (double& v : combo) v = -v;
      add_row(combo, -kInf, -rhs - eps);
    }
  } else if (kind == 1) {  // lb > ub
    std::vector<double> a(static_cast<std::size_t>(n));
    for (double& v : a) v = rng.normal();
    add_row(a, 1.0, 1.0 - 1e-3);
  } else if (kind == 2 && q.meq > 0 && q.meq < kME) {  // conflicting scaled duplicate equality
    const int src = rng.integer(0, q.meq - 1);
    const double c = rng.uniform(0.5, 2.0);
    for (int j = 0; j < n; ++j) q.Aeq.push_back(c * q.Aeq[static_cast<std::size_t>(src * n + j)]);
    q.beq.push_back(c * q.beq[static_cast<std::size_t>(src)] + 1e-3 * (1.0 + std::abs(q.beq[static_cast<std::size_t>(src)])));
    ++q.meq;
  } else {  // a row pinned (lb == ub) away from an equal inequality's bounds: a x = b and a x <= b - eps
    std::vector<double> a(static_cast<std::size_t>(n));
    for (double& v : a) v = rng.normal();
    add_row(a, 0.5, 0.5);
    add_row(a, -kInf, 0.5 - 1e-3);
  }
  return q;
}

TEST_F(QpProperties, RandomInfeasibleQpsAreDetected) {
  Rng rng(777);
  for (int trial = 0; trial < 600; ++trial) {
    const DenseQp q = make_infeasible(rng, trial);
    load(q, *problem);
    EXPECT_EQ(solver->solve(*problem, *result), Status::infeasible) << "trial " << trial << " kind " << trial % 4;
  }
}

// Ain is first read together with the first Ain x: its checks must still come first
// whatever else ends the solve early, and zero rows must still be settled.
TEST_F(QpProperties, ConstraintRowChecksHoldOnEveryExit) {
  Rng rng(777);
  for (int trial = 0; trial < 200; ++trial) {
    const DenseQp base = make_optimal(rng).qp;
    if (base.mi < 2) continue;
    const int row = rng.integer(0, base.mi - 1), other = (row + 1) % base.mi;
    auto solve = [&](const DenseQp& q) {
      load(q, *problem);
      return solver->solve(*problem, *result);
    };
    DenseQp q = base;
    q.Ain[static_cast<std::size_t>(row * q.n + rng.integer(0, q.n - 1))] = std::nan("");
    EXPECT_EQ(solve(q), Status::bad_input) << "trial " << trial;
    q.lb[static_cast<std::size_t>(other)] = 1.0;  // crossed bounds elsewhere: still bad input
    q.ub[static_cast<std::size_t>(other)] = -1.0;
    EXPECT_EQ(solve(q), Status::bad_input) << "trial " << trial;
    q = base;
    q.Ain[static_cast<std::size_t>(row * q.n + rng.integer(0, q.n - 1))] = kInf;
    for (int i = 0; i < q.n; ++i) q.H[static_cast<std::size_t>(i * q.n + i)] = -1.0;  // and H indefinite
    EXPECT_EQ(solve(q), Status::bad_input) << "trial " << trial;
    // A zero row: harmless when 0 lies within its bounds (also as an equality), a
    // proof of infeasibility when it does not.
    q = base;
    std::fill_n(q.Ain.begin() + row * q.n, q.n, 0.0);
    q.lb[static_cast<std::size_t>(row)] = -1.0;
    q.ub[static_cast<std::size_t>(row)] = 2.0;
    EXPECT_EQ(solve(q), Status::optimal) << "trial " << trial;
    q.lb[static_cast<std::size_t>(row)] = q.ub[static_cast<std::size_t>(row)] = 0.0;
    EXPECT_EQ(solve(q), Status::optimal) << "trial " << trial;
    q.lb[static_cast<std::size_t>(row)] = 0.5;
    q.ub[static_cast<std::size_t>(row)] = rng.chance(0.5) ? 0.5 : kInf;
    EXPECT_EQ(solve(q), Status::infeasible) << "trial " << trial;
  }
}

TEST_F(QpProperties, RandomBadInputsNeverCrash) {
  Rng rng(4242);
  const double poison[] = {std::nan(""), kInf, -kInf};
  for (int trial = 0; trial < 600; ++trial) {
    DenseQp q = make_optimal(rng).qp;
    const int what = trial % 6;
    Status expected = Status::bad_input;
    const double bad = poison[rng.integer(0, 2)];
    auto pick = [&](std::vector<double>& v) -> double& { return v[static_cast<std::size_t>(rng.integer(0, static_cast<int>(v.size()) - 1))]; };
    if (what == 0) {
      pick(q.H) = bad;
    } else if (what == 1) {
      pick(q.g) = bad;
    } else if (what == 2 && q.meq > 0) {
      (rng.chance(0.5) ? pick(q.Aeq) : pick(q.beq)) = bad;
    } else if (what == 3 && q.mi > 0) {
      if (rng.chance(0.5)) pick(q.Ain) = bad;
      else (rng.chance(0.5) ? pick(q.lb) : pick(q.ub)) = std::nan("");
    } else if (what == 4) {  // indefinite H
      for (int i = 0; i < q.n; ++i) q.H[static_cast<std::size_t>(i * q.n + i)] -= 1e3 * (1.0 + std::abs(q.H[static_cast<std::size_t>(i * q.n + i)]));
      expected = Status::not_positive_definite;
    } else {  // absurd magnitudes: anything but a crash or a non-finite "optimal"
      pick(q.H) *= 1e300;
      pick(q.g) = 1e300;
      expected = Status::optimal;  // placeholder: checked below
    }
    load(q, *problem);
    // Garbage warm start on every other trial.
    springbok::qp::ActiveSet<kMI> junk;
    for (int k = 0; k < 10; ++k) junk.push(rng.integer(-5, kMI + 5), static_cast<Side>(rng.integer(0, 2)));
    Solver::Hint hint;
    if (trial % 2 == 1) hint.active_set = &junk;
    const Status s = solver->solve(*problem, *result, hint);
    if (what == 5 || (what == 2 && q.meq == 0) || (what == 3 && q.mi == 0)) {
      if (s == Status::optimal) {
        for (int i = 0; i < q.n; ++i) ASSERT_TRUE(std::isfinite(result->x[static_cast<std::size_t>(i)])) << "trial " << trial;
      }
    } else {
      EXPECT_EQ(s, expected) << "trial " << trial << " what " << what;
    }
  }
}

// A hint a few rows off is repaired in the shortcut (solver.hpp: kShortcutRepairs): a missing
// active row is added, a row whose multiplier has the wrong sign is dropped, and the answer is
// the cold one (a hint further off: the next test).
// min 1/2 |x|^2 - 2 (x0 + x1 + x2)  s.t.  x0 <= 1, x1 <= 1, x2 <= 5, x0 + x1 + x2 >= -10:
// x* = (1, 1, 2), the first two rows active with multipliers 1.
TEST(QpHint, AHintOneRowOffIsRepairedInTheShortcut) {
  using Small = springbok::qp::Solver<3, 0, 4>;
  auto [solver, problem, result] = springbok::qp::test::on_heap<Small>();
  problem->resize(3, 0, 4);
  for (int i = 0; i < 3; ++i) problem->H()(i, i) = 1.0;
  problem->g() << -2.0, -2.0, -2.0;
  problem->Ain() << 1.0, 0.0, 0.0,  //
      0.0, 1.0, 0.0,                //
      0.0, 0.0, 1.0,                //
      1.0, 1.0, 1.0;
  const double inf = springbok::qp::kInfiniteBound;
  problem->lb() << -inf, -inf, -inf, -10.0;
  problem->ub() << 1.0, 1.0, 5.0, inf;
  const auto expect_optimum = [&](const char* what) {
    EXPECT_NEAR(result->x[0], 1.0, 1e-12) << what;
    EXPECT_NEAR(result->x[1], 1.0, 1e-12) << what;
    EXPECT_NEAR(result->x[2], 2.0, 1e-12) << what;
    EXPECT_NEAR(std::abs(result->lambda_in[0]), 1.0, 1e-12) << what;
    EXPECT_NEAR(std::abs(result->lambda_in[1]), 1.0, 1e-12) << what;
    EXPECT_EQ(result->lambda_in[2], 0.0) << what;
    EXPECT_EQ(result->lambda_in[3], 0.0) << what;
  };
  ASSERT_EQ(solver->solve(*problem, *result), Status::optimal);
  expect_optimum("cold");
  springbok::qp::ActiveSet<4> set;
  Small::Hint hint;
  hint.active_set = &set;

  set.push(0, Side::upper);  // row 1 missing: added
  ASSERT_EQ(solver->solve(*problem, *result, hint), Status::optimal);
  EXPECT_TRUE(result->from_hint);
  EXPECT_EQ(result->iterations, 1);
  expect_optimum("row 1 added");

  set.push(1, Side::upper);
  set.push(2, Side::upper);  // x2 <= 5 held active pulls x2 up: its multiplier's sign is wrong
  ASSERT_EQ(solver->solve(*problem, *result, hint), Status::optimal);
  EXPECT_TRUE(result->from_hint);
  EXPECT_EQ(result->iterations, 1);
  expect_optimum("row 2 dropped");

  set.clear();
  set.push(2, Side::upper);  // three repairs away: drop 2, add 0, add 1
  ASSERT_EQ(solver->solve(*problem, *result, hint), Status::optimal);
  EXPECT_TRUE(result->from_hint);
  EXPECT_EQ(result->iterations, 3);
  expect_optimum("three repairs");
}

// kShortcutRepairs rows short of the answer: repaired in the shortcut; one more, and the full
// method runs (from the rows the repairs reached); the answer is the same either way.
// min 1/2 |x|^2 - 2 sum x  s.t.  x_i <= 1 (i < 16): x* = 1, every row active (multipliers 1).
TEST(QpHint, AHintFurtherThanTheRepairsGoesToTheFullMethod) {
  using Sixteen = springbok::qp::Solver<16, 0, 16>;
  constexpr int kRepairs = Sixteen::kShortcutRepairs;
  static_assert(kRepairs < 16, "the hint must be able to be more repairs away than the shortcut makes");
  auto [solver, problem, result] = springbok::qp::test::on_heap<Sixteen>();
  problem->resize(16, 0, 16);
  for (int i = 0; i < 16; ++i) {
    problem->H()(i, i) = 1.0;
    problem->g()[i] = -2.0;
    problem->Ain()(i, i) = 1.0;
    problem->lb()[i] = -springbok::qp::kInfiniteBound;
    problem->ub()[i] = 1.0;
  }
  const auto expect_optimum = [&](const char* what) {
    for (int i = 0; i < 16; ++i) {
      EXPECT_NEAR(result->x[static_cast<std::size_t>(i)], 1.0, 1e-12) << what;
      EXPECT_NEAR(std::abs(result->lambda_in[static_cast<std::size_t>(i)]), 1.0, 1e-12) << what;
    }
  };
  springbok::qp::ActiveSet<16> set;
  Sixteen::Hint hint;
  hint.active_set = &set;
  for (int i = 0; i < 16 - kRepairs; ++i) set.push(i, Side::upper);
  ASSERT_EQ(solver->solve(*problem, *result, hint), Status::optimal);
  EXPECT_TRUE(result->from_hint);
  EXPECT_EQ(result->iterations, kRepairs);
  expect_optimum("repaired");

  set.clear();
  for (int i = 0; i < 15 - kRepairs; ++i) set.push(i, Side::upper);
  ASSERT_EQ(solver->solve(*problem, *result, hint), Status::optimal);
  EXPECT_FALSE(result->from_hint);
  expect_optimum("one row further: the full method");

  set.clear();
  ASSERT_EQ(solver->solve(*problem, *result, hint), Status::optimal);
  EXPECT_FALSE(result->from_hint);
  expect_optimum("no row");
}

// A hint that repeats a row (here as often as the hint holds entries) on a solver whose
// equality block has no room for more rows than ME + MI: the shortcut must see the
// dependence (or the lack of room) and leave it to the full method, which skips repeats.
TEST(QpHint, RepeatedRowsInTheHintAreHarmless) {
  using Tiny = springbok::qp::Solver<4, 1, 2>;
  auto [solver, problem, result] = springbok::qp::test::on_heap<Tiny>();
  problem->resize(4, 1, 2);
  for (int i = 0; i < 4; ++i) problem->H()(i, i) = 1.0 + i;
  problem->g() << 1.0, -2.0, 0.5, 3.0;
  problem->Aeq() << 1.0, 1.0, 0.0, 0.0;
  problem->beq() << 1.0;
  problem->Ain() << 0.0, 0.0, 1.0, 1.0,  // lb == ub: in the equality block
      1.0, 0.0, 0.0, -1.0;               // x0 - x3 >= 2: active at the optimum
  problem->lb() << 0.5, 2.0;
  problem->ub() << 0.5, springbok::qp::kInfiniteBound;
  ASSERT_EQ(solver->solve(*problem, *result), Status::optimal);
  const std::array<double, 4> cold_x = result->x;
  springbok::qp::ActiveSet<2> hint_set;
  hint_set.push(1, Side::lower);
  hint_set.push(1, Side::lower);
  Tiny::Hint hint;
  hint.active_set = &hint_set;
  ASSERT_EQ(solver->solve(*problem, *result, hint), Status::optimal);
  EXPECT_FALSE(result->from_hint);
  for (int i = 0; i < 4; ++i) EXPECT_NEAR(result->x[static_cast<std::size_t>(i)], cold_x[static_cast<std::size_t>(i)], 1e-12);
  // The same row once: the shortcut holds and agrees.
  hint_set.clear();
  hint_set.push(1, Side::lower);
  ASSERT_EQ(solver->solve(*problem, *result, hint), Status::optimal);
  EXPECT_TRUE(result->from_hint);
  for (int i = 0; i < 4; ++i) EXPECT_NEAR(result->x[static_cast<std::size_t>(i)], cold_x[static_cast<std::size_t>(i)], 1e-12);
}

TEST_F(QpProperties, SizesOutOfRangeAreBadInput) {
  problem->resize(kN + 1, 0, 0);
  EXPECT_EQ(solver->solve(*problem, *result), Status::bad_input);
  problem->resize(0, 0, 0);
  EXPECT_EQ(solver->solve(*problem, *result), Status::bad_input);
  problem->resize(3, kME + 1, 0);
  EXPECT_EQ(solver->solve(*problem, *result), Status::bad_input);
  problem->resize(3, 0, -1);
  EXPECT_EQ(solver->solve(*problem, *result), Status::bad_input);
}

// Closed form: min 1/2|x|^2 - c'x with x_0 + x_1 = 1 and x_0 <= 0.2 (one-sided, huge lb).
TEST_F(QpProperties, SmallClosedForm) {
  *problem = Problem{};
  problem->resize(2, 1, 1);
  problem->H() << 1, 0, 0, 1;
  problem->g() << -1, -2;
  problem->Aeq() << 1, 1;
  problem->beq() << 1;
  problem->Ain() << 1, 0;
  problem->lb() << -1e20;
  problem->ub() << 0.2;
  ASSERT_EQ(solver->solve(*problem, *result), Status::optimal);
  // Without the bound: x = (0, 1). With x0 <= 0.2 inactive at x0 = 0: same.
  EXPECT_NEAR(result->x[0], 0.0, 1e-14);
  EXPECT_NEAR(result->x[1], 1.0, 1e-14);
  problem->ub() << -0.5;  // now active: x = (-0.5, 1.5), lambda_in = -(x0 - 1) - lambda_eq ...
  ASSERT_EQ(solver->solve(*problem, *result), Status::optimal);
  EXPECT_NEAR(result->x[0], -0.5, 1e-14);
  EXPECT_NEAR(result->x[1], 1.5, 1e-14);
  // Stationarity: x1 - 2 + le = 0 -> le = 0.5; x0 - 1 + le + li = 0 -> li = 1.0 (>= 0 at the upper bound).
  EXPECT_NEAR(result->lambda_eq[0], 0.5, 1e-14);
  EXPECT_NEAR(result->lambda_in[0], 1.0, 1e-14);
  ASSERT_EQ(result->active.size, 1);
  EXPECT_EQ(result->active.side[0], Side::upper);
}

// The solver reads H's lower triangle (types.hpp): an H given by its lower triangle alone,
// zeros above the diagonal, is the same QP. Random KKT-constructed problems (half of them
// with separable variables, which the solver orders apart from the coupled ones) against
// their known x*. Telling couplings from H's rows alone missed a variable coupled only
// below its diagonal: solved as separable, it came back "optimal" and wrong (n 3, H with
// h_20 alone off the diagonal: x0 -0.5 for the true -0.174).
TEST_F(QpProperties, AHessianGivenByItsLowerTriangleIsTheSameQp) {
  Rng rng(31);
  int coupled_trials = 0;
  for (int trial = 0; trial < 300; ++trial) {
    const Generated gen = make_optimal(rng);
    DenseQp lower = gen.qp;
    const int n = lower.n;
    bool coupled = false;
    for (int i = 0; i < n; ++i)
      for (int j = i + 1; j < n; ++j) {  // row i, column j > i: above the diagonal
        coupled = coupled || lower.H[static_cast<std::size_t>(i * n + j)] != 0.0;
        lower.H[static_cast<std::size_t>(i * n + j)] = 0.0;
      }
    coupled_trials += coupled ? 1 : 0;
    load(lower, *problem);
    ASSERT_EQ(solver->solve(*problem, *result), Status::optimal) << "trial " << trial;
    double xs = 0.0;
    for (int k = 0; k < n; ++k) xs = std::max(xs, std::abs(gen.xstar[static_cast<std::size_t>(k)]));
    for (int k = 0; k < n; ++k)
      ASSERT_NEAR(result->x[static_cast<std::size_t>(k)], gen.xstar[static_cast<std::size_t>(k)], 1e-6 * std::max(1.0, xs))
          << "trial " << trial << " variable " << k;
  }
  EXPECT_GT(coupled_trials, 200);
  // The smallest case, by hand: h = [2 0 1.5; 0 3 0; 1.5 0 4] from its lower triangle,
  // g = (1, -1, 2), no constraints: x = -H^-1 g = (-4/23, 1/3, -10/23).
  *problem = Problem{};
  problem->resize(3, 0, 0);
  problem->H() << 2, 0, 0, 0, 3, 0, 1.5, 0, 4;
  problem->g() << 1, -1, 2;
  ASSERT_EQ(solver->solve(*problem, *result), Status::optimal);
  EXPECT_NEAR(result->x[0], -4.0 / 23.0, 1e-14);
  EXPECT_NEAR(result->x[1], 1.0 / 3.0, 1e-14);
  EXPECT_NEAR(result->x[2], -10.0 / 23.0, 1e-14);
}

// reuse_factor must only reuse the factor of an identical H: a sequence of problems
// where H repeats, changes in one diagonal entry, or changes size, solved with the
// hint, against the known x* of each (a changed H left on the old factor misses it).
TEST_F(QpProperties, ReusedFactorOnlyForAnUnchangedHessian) {
  Rng rng(77);
  Solver::Hint hint;
  hint.reuse_factor = true;
  for (int trial = 0; trial < 200; ++trial) {
    Generated gen = make_optimal(rng);
    const int n = gen.qp.n;
    for (int repeat = 0; repeat < 3; ++repeat) {
      if (repeat == 2) {  // raise one diagonal entry (H stays positive definite), keep x*
        const int i = rng.integer(0, n - 1);
        const double delta = 0.5 * gen.qp.H[static_cast<std::size_t>(i * n + i)];
        gen.qp.H[static_cast<std::size_t>(i * n + i)] += delta;
        gen.qp.g[static_cast<std::size_t>(i)] -= delta * gen.xstar[static_cast<std::size_t>(i)];
      }
      load(gen.qp, *problem);
      ASSERT_EQ(solver->solve(*problem, *result, hint), Status::optimal) << "trial " << trial << " repeat " << repeat;
      double xs = 0.0;
      for (int k = 0; k < n; ++k) xs = std::max(xs, std::abs(gen.xstar[static_cast<std::size_t>(k)]));
      for (int k = 0; k < n; ++k)
        ASSERT_NEAR(result->x[static_cast<std::size_t>(k)], gen.xstar[static_cast<std::size_t>(k)], 1e-6 * std::max(1.0, xs))
            << "trial " << trial << " repeat " << repeat;
    }
  }
}

TEST_F(QpProperties, CallerFactorGivesTheSameAnswer) {
  Rng rng(99);
  for (int trial = 0; trial < 50; ++trial) {
    const Generated gen = make_optimal(rng);
    load(gen.qp, *problem);
    ASSERT_EQ(solver->solve(*problem, *result), Status::optimal);
    const std::array<double, kN> x_cold = result->x;
    // Cholesky by hand, independent of the solver's kernel.
    const int n = gen.qp.n;
    std::array<double, kN * kN> l{};
    for (int j = 0; j < n; ++j)
      for (int i = j; i < n; ++i) {
        double s = gen.qp.H[static_cast<std::size_t>(i * n + j)];
        for (int k = 0; k < j; ++k) s -= l[static_cast<std::size_t>(k * kN + i)] * l[static_cast<std::size_t>(k * kN + j)];
        l[static_cast<std::size_t>(j * kN + i)] = i == j ? std::sqrt(s) : s / l[static_cast<std::size_t>(j * kN + j)];
      }
    Solver::Hint hint;
    hint.cholesky_lower = l.data();
    ASSERT_EQ(solver->solve(*problem, *result, hint), Status::optimal);
    double xs = 0.0;
    for (int i = 0; i < n; ++i) xs = std::max(xs, std::abs(x_cold[static_cast<std::size_t>(i)]));
    for (int i = 0; i < n; ++i) EXPECT_NEAR(result->x[static_cast<std::size_t>(i)], x_cold[static_cast<std::size_t>(i)], 1e-8 * std::max(1.0, xs));
  }
  std::array<double, kN * kN> broken{};  // zero diagonal: rejected
  Solver::Hint hint;
  hint.cholesky_lower = broken.data();
  EXPECT_EQ(solver->solve(*problem, *result, hint), Status::bad_input);
  // A factor of another matrix, told by its couplings: H's diagonal alone (positive,
  // finite, but H couples its variables), and H's factor on an H that gained an entry.
  const Generated gen = make_optimal(rng);
  load(gen.qp, *problem);
  const int n = gen.qp.n;
  ASSERT_GE(n, 2);
  std::array<double, kN * kN> diagonal{};
  for (int i = 0; i < n; ++i) diagonal[static_cast<std::size_t>(i * kN + i)] = std::sqrt(gen.qp.H[static_cast<std::size_t>(i * n + i)]);
  hint.cholesky_lower = diagonal.data();
  EXPECT_EQ(solver->solve(*problem, *result, hint), Status::bad_input);
  DenseQp separable = gen.qp;  // a diagonal H, factored by hand; then H gains a coupling
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j)
      if (i != j) separable.H[static_cast<std::size_t>(i * n + j)] = 0.0;
  load(separable, *problem);
  ASSERT_EQ(solver->solve(*problem, *result, hint), Status::optimal);
  separable.H[static_cast<std::size_t>(0 * n + 1)] = separable.H[static_cast<std::size_t>(1 * n + 0)] = 1e-3;
  load(separable, *problem);
  EXPECT_EQ(solver->solve(*problem, *result, hint), Status::bad_input);
}

}  // namespace
