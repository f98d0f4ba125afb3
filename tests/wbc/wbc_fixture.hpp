// The whole-body controller's test rig: the robot standing on its nominal stance with the
// arm bent away from singularity, a controller engaged there, one tick on that tick's
// dynamics (as springbok::control computes them), and the residual of the equations of
// motion that every solution must satisfy.
#pragma once

#include <memory>

#include <gtest/gtest.h>

#include "alloc_trap.hpp"
#include "springbok/wbc/stand_controller.hpp"
#include "springbok/wbc/whole_body_controller.hpp"

namespace springbok::test {

inline constexpr double kStanceHeight_m = 0.61233 + kFootRadius_m;

// The arm bent forward so that it is far from singular.
inline wbc::VecArm arm_pose() {
  wbc::VecArm a;
  a << 0.0, 0.6, 0.0, 1.9, 0.0, 0.9, 0.0;
  return a;
}

inline VecNq standing_q() {
  VecNq q = VecNq::Zero();
  q[2] = kStanceHeight_m;
  q[6] = 1.0;  // identity quaternion (x y z w)
  q.segment<kNj>(7) = wbc::nominal_stance();
  q.segment<wbc::kArmDofs>(7 + kFirstArmJoint) = arm_pose();
  return q;
}

struct WbcFixture : ::testing::Test {
  wbc::WbcParams params;
  std::unique_ptr<wbc::WholeBodyController> wbc;
  dyn::Model model;
  std::unique_ptr<dyn::Data> data = std::make_unique<dyn::Data>();
  wbc::WbcInput in;

  void SetUp() override {
    // These tests check the equations of motion with the foot-frame Jacobians of
    // springbok::dyn, so the controller must use the same points (the sphere centres).
    params.foot_contact_radius_m = 0.0;
    in.state.q = standing_q();
    in.state.set_rotation_from_q();
    wbc = std::make_unique<wbc::WholeBodyController>(params);
    wbc->set_reference(in.state.q, *data);
    dyn::compute_tick(model, *data, in.state.q, in.state.v);
  }

  // One controller tick on this tick's dynamics (as springbok::control computes them).
  const wbc::WbcOutput& tick(wbc::WholeBodyController& c) {
    dyn::compute_tick(model, *data, in.state.q, in.state.v);
    return c.tick(in, *data);
  }
  const wbc::WbcOutput& tick() { return tick(*wbc); }

  // Generalized force balance: M udot + h = S^T tau + J_st^T F + J_e^T W_e.
  VecNv dynamics_residual(const wbc::WbcOutput& out, const Vec6& wrench_world) const {
    VecNv gen = VecNv::Zero();
    gen.tail<kNj>() = out.tau_nm;
    for (int f = 0; f < kFeet; ++f) gen += data->J_feet[f].transpose() * out.foot_force_n[f];
    gen += data->J_ee.transpose() * wrench_world;
    return data->M * out.udot + data->nle - gen;
  }

  // One tick with the allocation trap armed; what it counted in `allocations`.
  wbc::WbcOutput tick_counting_allocations(std::size_t& allocations) {
    AllocationTrap trap;
    const wbc::WbcOutput out = tick();
    allocations = trap.disarm();
    return out;
  }

  // One tick that must allocate nothing and solve its QP (a fatal failure otherwise); `out`: its output.
  void tick_solved_without_allocating(wbc::WbcOutput& out) {
    std::size_t allocations = 0;
    out = tick_counting_allocations(allocations);
    EXPECT_EQ(allocations, 0u);
    ASSERT_EQ(out.qp_status, qp::Status::optimal);
  }

  // Allocations over 20 ticks with a wrist wrench and changing stance sets (after a warm-up tick).
  std::size_t allocations_over_ticks() {
    tick();
    std::size_t n = 0;
    {
      AllocationTrap trap;
      for (int i = 0; i < 20; ++i) {
        in.state.stance = {true, i % 2 == 0, true, i % 3 != 0};
        tick();
      }
      n = trap.disarm();
    }
    return n;
  }
};

}  // namespace springbok::test
