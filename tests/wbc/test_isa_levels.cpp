// The kernels of every instruction-set level this binary holds and this CPU runs
// (springbok/isa/isa.hpp) against the baseline's: the dynamics, the whole-body controller's
// tick and the base estimator's update give the same numbers (to rounding: FMA contracts
// differently), allocate nothing, and the level is one the CPU can run.
#include <gtest/gtest.h>

#include <cstdlib>
#include <random>
#include <vector>

#include "alloc_trap.hpp"
#include "random_state.hpp"
#include "standing_ticks.hpp"
#include "springbok/estimation/base_estimator.hpp"
#include "springbok/isa/isa.hpp"
#include "wbc_fixture.hpp"

namespace springbok::test {
namespace {

using isa::Level;

std::vector<Level> runnable_levels() {
  std::vector<Level> levels;
  for (int l = 0; l < isa::kLevels; ++l) {
    const auto level = static_cast<Level>(l);
    if (isa::compiled(level) && isa::cpu_supports(level)) levels.push_back(level);
  }
  return levels;
}

// Puts the start-up level back after a test that selects others.
struct LevelGuard {
  Level saved = isa::active();
  ~LevelGuard() { (void)isa::select(saved); }
};

TEST(IsaLevels, NamesParseBackAndTheStartUpLevelIsTheBestTheCpuRuns) {
  for (int l = 0; l < isa::kLevels; ++l) {
    const auto level = static_cast<Level>(l);
    ASSERT_EQ(isa::parse(isa::name(level)), level) << isa::name(level);
  }
  EXPECT_FALSE(isa::parse("x86-64-v5"));
  EXPECT_FALSE(isa::parse(""));
  EXPECT_TRUE(isa::cpu_supports(Level::baseline));
  if (isa::environment_error().empty() && std::getenv("SPRINGBOK_ISA") == nullptr) {
    EXPECT_EQ(isa::active(), isa::best());
  }
  // Under an emulated CPU (tests/wbc/CMakeLists.txt: qemu's Nehalem, Haswell) the level it must pick.
  if (const char* expected = std::getenv("SPRINGBOK_EXPECT_ISA")) {
    EXPECT_STREQ(isa::name(isa::active()), expected);
  }
  EXPECT_TRUE(isa::cpu_supports(isa::active()));
  EXPECT_TRUE(isa::compiled(isa::active()));
  const std::string line = isa::describe();
  EXPECT_EQ(line.rfind(std::string("kernels ") + isa::name(isa::active()) + " (compiled: ", 0), 0u) << line;
#ifdef SPRINGBOK_ISA_VARIANTS
  EXPECT_NE(line.find("x86-64 x86-64-v3 x86-64-v4;"), std::string::npos) << line;
#endif
}

TEST(IsaLevels, ALevelTheCpuCannotRunOrTheBuildLacksIsRefused) {
  LevelGuard guard;
  for (int l = 0; l < isa::kLevels; ++l) {
    const auto level = static_cast<Level>(l);
    const Level before = isa::active();
    const bool runnable = isa::compiled(level) && isa::cpu_supports(level);
    EXPECT_EQ(isa::select(level), runnable) << isa::name(level);
    EXPECT_EQ(isa::active(), runnable ? level : before) << isa::name(level);
  }
}

TEST(IsaLevels, EveryRunnableLevelComputesTheBaselinesDynamics) {
  LevelGuard guard;
  const dyn::Model model;
  auto base = std::make_unique<dyn::Data>();
  auto other = std::make_unique<dyn::Data>();
  std::mt19937_64 rng(48);
  for (int k = 0; k < 20; ++k) {
    const RandomState s = random_state(rng);
    const VecNv tau = VecNv::Random();
    ASSERT_TRUE(isa::select(Level::baseline));
    dyn::compute_tick(model, *base, s.q, s.v);
    const VecNv rnea_base = dyn::rnea(model, *base, s.q, s.v, s.vdot);
    const VecNv aba_base = dyn::aba(model, *base, s.q, s.v, tau);
    const MatNv crba_base = dyn::crba(model, *base, s.q);
    for (const Level level : runnable_levels()) {
      ASSERT_TRUE(isa::select(level));
      dyn::compute_tick(model, *other, s.q, s.v);
      const double scale = 1.0 + base->M.cwiseAbs().maxCoeff();
      EXPECT_LT((other->M - base->M).cwiseAbs().maxCoeff(), 1e-12 * scale) << isa::name(level);
      EXPECT_LT((other->nle - base->nle).cwiseAbs().maxCoeff(), 1e-12 * (1.0 + base->nle.cwiseAbs().maxCoeff()))
          << isa::name(level);
      for (int f = 0; f < kFeet; ++f) {
        EXPECT_LT((other->J_feet[f] - base->J_feet[f]).cwiseAbs().maxCoeff(), 1e-12) << isa::name(level);
      }
      EXPECT_LT((dyn::rnea(model, *other, s.q, s.v, s.vdot) - rnea_base).cwiseAbs().maxCoeff(),
                1e-12 * (1.0 + rnea_base.cwiseAbs().maxCoeff()))
          << isa::name(level);
      EXPECT_LT((dyn::aba(model, *other, s.q, s.v, tau) - aba_base).cwiseAbs().maxCoeff(),
                1e-9 * (1.0 + aba_base.cwiseAbs().maxCoeff()))
          << isa::name(level);
      EXPECT_LT((dyn::crba(model, *other, s.q) - crba_base).cwiseAbs().maxCoeff(), 1e-12 * scale) << isa::name(level);
    }
  }
}

struct IsaWbc : WbcFixture {
  LevelGuard guard;
};

// The same controller ticked at one level, then again from the same state at another:
// the torques, accelerations and contact forces agree, and the equations of motion hold.
TEST_F(IsaWbc, EveryRunnableLevelTicksTheWholeBodyControllerAsTheBaselineDoes) {
  in.wrist_force_world_n = Vec3(20.0, -10.0, 5.0);
  for (int k = 0; k < 3; ++k) {
    in.state.v.setZero();
    in.state.v[3 + k] = 0.1;
    ASSERT_TRUE(isa::select(Level::baseline));
    auto base_wbc = std::make_unique<wbc::WholeBodyController>(params);
    base_wbc->set_reference(standing_q(), *data);
    const wbc::WbcOutput base = tick(*base_wbc);
    ASSERT_FALSE(base.failed);
    for (const Level level : runnable_levels()) {
      ASSERT_TRUE(isa::select(level));
      auto level_wbc = std::make_unique<wbc::WholeBodyController>(params);
      level_wbc->set_reference(standing_q(), *data);
      const wbc::WbcOutput out = tick(*level_wbc);
      ASSERT_FALSE(out.failed) << isa::name(level);
      EXPECT_LT((out.tau_nm - base.tau_nm).cwiseAbs().maxCoeff(), 1e-6) << isa::name(level);
      EXPECT_LT((out.udot - base.udot).cwiseAbs().maxCoeff(), 1e-6) << isa::name(level);
      for (int f = 0; f < kFeet; ++f) {
        EXPECT_LT((out.foot_force_n[f] - base.foot_force_n[f]).cwiseAbs().maxCoeff(), 1e-6) << isa::name(level);
      }
      Vec6 wrench = Vec6::Zero();
      wrench.head<3>() = in.wrist_force_world_n;
      EXPECT_LT(dynamics_residual(out, wrench).cwiseAbs().maxCoeff(), 1e-6) << isa::name(level);
    }
  }
}

TEST_F(IsaWbc, WholeTicksAllocateNothingAtEveryRunnableLevel) {
  for (const Level level : runnable_levels()) {
    ASSERT_TRUE(isa::select(level));
    EXPECT_EQ(allocations_over_ticks(), 0u) << isa::name(level);
  }
}

// The same 500 ticks through an estimator at each level (filter ekf, the default): the same
// pose and velocity, and no allocation in the updates.
TEST(IsaEstimator, EveryRunnableLevelUpdatesTheBaseEstimatorAsTheBaselineDoes) {
  const LevelGuard guard;
  const std::vector<hal::Measurements> ticks = noisy_standing_ticks(500, 11);
  const Stance all{true, true, true, true};
  const auto run = [&](Level level, std::size_t& allocations) {
    EXPECT_TRUE(isa::select(level));
    auto estimator = std::make_unique<est::BaseEstimator>();
    EXPECT_EQ(estimator->reset(ticks[0], all, Eigen::Vector2d::Zero()), est::EstimateStatus::ok);
    AllocationTrap trap;
    for (std::size_t k = 1; k < ticks.size(); ++k) {
      EXPECT_EQ(estimator->update(ticks[k], all, 1e-3).status, est::EstimateStatus::ok) << k;
    }
    allocations = trap.disarm();
    return estimator->estimate();
  };
  std::size_t allocations = 0;
  const est::BaseEstimate base = run(Level::baseline, allocations);
  EXPECT_EQ(allocations, 0u);
  for (const Level level : runnable_levels()) {
    const est::BaseEstimate e = run(level, allocations);
    EXPECT_EQ(allocations, 0u) << isa::name(level);
    EXPECT_LT((e.q - base.q).cwiseAbs().maxCoeff(), 1e-9) << isa::name(level);
    EXPECT_LT((e.v - base.v).cwiseAbs().maxCoeff(), 1e-9) << isa::name(level);
  }
}

}  // namespace
}  // namespace springbok::test
