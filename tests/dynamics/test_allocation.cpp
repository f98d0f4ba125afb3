// The dynamics allocate nothing: a full controller tick and every algorithm
// under the allocation trap (operator new counted, Eigen malloc aborts).
#include <gtest/gtest.h>

#include <memory>

#include "alloc_trap.hpp"
#include "random_state.hpp"

namespace {
using namespace springbok;

TEST(DynamicsAllocation, FullTickAndEveryAlgorithmAllocateNothing) {
  const dyn::Model model;
  auto data = std::make_unique<dyn::Data>();
  std::mt19937_64 rng{7};
  const auto s = springbok::test::random_state(rng);
  double sink = 0.0;
  springbok::test::AllocationTrap trap;
  dyn::compute_tick(model, *data, s.q, s.v);
  sink += data->M(6, 6) + data->nle[7] + data->J_feet[0](0, 6) + data->dJv_ee[0];
  sink += dyn::crba(model, *data, s.q)(0, 0);
  sink += dyn::rnea(model, *data, s.q, s.v, s.vdot)[0];
  sink += dyn::nonlinear_effects(model, *data, s.q, s.v)[0];
  sink += dyn::gravity(model, *data, s.q)[0];
  sink += dyn::aba(model, *data, s.q, s.v, s.vdot)[0];
  dyn::forward_kinematics(model, *data, s.q);
  dyn::point_jacobians(model, *data, s.q);
  dyn::point_jacobians_dot_times_v(model, *data, s.q, s.v);
  sink += dyn::center_of_mass(model, *data, s.q)[0];
  sink += dyn::jacobian_center_of_mass(model, *data, s.q)(0, 0);
  sink += dyn::composite_inertia(model, *data, s.q)(0, 0);
  const std::size_t allocations = trap.disarm();
  EXPECT_EQ(allocations, 0u);
  EXPECT_TRUE(std::isfinite(sink));
}

}  // namespace
