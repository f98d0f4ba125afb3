// A stand controller with gravity compensation (springbok-sim settles the robot with it before
// the whole-body controller engages; the sim tests hold a stance with it): joint PD around a
// posture plus gravity compensation done right for a robot standing
// on its four feet,
//
//   tau = kp (q_des - q) - kd qd + g_j - J_st,j^T f,
//
// where the contact forces f (3 per foot, world axes) carry the floating base:
// J_st,b^T f = g_b (the 6 base rows of the static equilibrium M 0 + g = S^T tau
// + J_st^T f), solved in the minimum-norm least-squares sense over the 4 feet.
// The PD part goes to the drives (q_des, kp, kd), the model part is tau_ff.
#pragma once

#include <memory>

#include "springbok/dynamics/dynamics.hpp"
#include "springbok/hal/types.hpp"
#include "springbok/model/model.hpp"

namespace springbok::wbc {

// The robot file's stance_rad: legs and arm.
VecNj nominal_stance() noexcept;

struct StandGains {
  double kp_leg_nm_per_rad = 300.0;
  double kd_leg_nms_per_rad = 10.0;
  double kp_arm_nm_per_rad = 40.0;
  double kd_arm_nms_per_rad = 1.0;
};

// The feet's share of the base's weight: min ||f|| s.t. J_st,b^T f = g_b.
struct StanceForces {
  Vec<3 * kFeet> f_n = Vec<3 * kFeet>::Zero();   // [f_lf, f_rf, f_lh, f_rh], world axes
  VecNj tau_gravity_nm = VecNj::Zero();          // g_j - J_st,j^T f
};

class StandController {
 public:
  StandController(const StandGains& gains, const VecNj& posture_rad);

  // q, v: full generalized state (CONVENTIONS.md). rt: no alloc
  void tick(const VecNq& q, hal::JointCommands& out) noexcept;

  // The gravity compensation of the last tick.
  const StanceForces& stance_forces() const noexcept { return forces_; }

 private:
  dyn::Model model_;
  std::unique_ptr<dyn::Data> data_;
  StandGains gains_;
  VecNj posture_rad_;
  StanceForces forces_;
};

// rt: no alloc. Fills `forces` from the dynamics at q (gravity and foot Jacobians).
void stance_gravity_compensation(const dyn::Model& model, dyn::Data& data, const VecNq& q,
                                 StanceForces& forces) noexcept;

}  // namespace springbok::wbc
