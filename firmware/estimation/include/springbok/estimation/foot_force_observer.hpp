// The ground's force on each foot from the leg's own measurements (joint torques
// and the motion they produced), for touch-down detection (springbok::gait).
//
// The three rows of the equations of motion of a leg's joints,
//     M_leg udot + h_leg = tau_leg - c qd_leg + J_leg^T f,
// hold f, the force on that leg's foot (world axes), alone: the other contacts and
// the hand's wrench act on the leg's joints only through the base's motion, which
// udot carries. J_leg, the foot's Jacobian on its own three joints, is square, so
//     f = J_leg^-T (M_leg udot + h_leg - tau_leg + c qd_leg).
// udot is the finite difference of two ticks' velocities: this is the discrete
// generalized-momentum observer (De Luca and Mattone, ICRA 2005: p_k - p_{k-1} =
// dt (tau - h + J^T f) + (M_k - M_{k-1}) u_k, with M_{k-1} taken as M_k), low-pass
// filtered with time constant filter_s. Torque control makes the torques alone blind
// to a contact (the drive applies what it is told); the motion is what changes.
//
// The base's six rows of the same equations hold the whole robot's momentum balance: their
// force part, R (M_base,lin udot + h_base,lin), is the sum of every external force but gravity
// (the feet's, the hand's, and pushes anywhere else), world axes (external_force_world_n).
//
// Conventions are springbok::dyn's: v = [v_B, w_B (trunk frame), joint rates],
// udot the derivative of those components, point Jacobians world-aligned.
#pragma once

#include <array>

#include "springbok/dynamics/dynamics.hpp"
#include "springbok/model/model.hpp"

namespace springbok::est {

struct FootForceParams {
  double filter_s = 0.004;  // first-order low-pass time constant of the estimate
  // |det J_leg| below this (a straight knee): the foot's force is not observable
  // from its joints; the estimate holds its last value.
  double min_jacobian_det = 1e-6;
};

class FootForceObserver {
 public:
  explicit FootForceObserver(const FootForceParams& params = {}) noexcept : params_(params) {}

  // Forget the last velocity (the next update only primes the difference). rt: no alloc
  void reset() noexcept { primed_ = false; }

  // `d` holds dyn::compute_tick at (q, v); rotation_wb the trunk's orientation (trunk to
  // world axes); tau_nm the measured joint torques and friction_nm the joints' friction at
  // their speed (c qd: what the motor spends on it). rt: no alloc
  void update(const dyn::Data& d, const VecNv& v, const Mat3& rotation_wb, const VecNj& tau_nm,
              const VecNj& friction_nm, double dt_s) noexcept;

  // World axes, N. Zero until two updates have run.
  const std::array<Vec3, kFeet>& force_world_n() const noexcept { return force_n_; }
  // The sum of the external forces on the robot but gravity (feet, hand, pushes), world axes,
  // N, filtered as the feet's. Zero until two updates have run.
  const Vec3& external_force_world_n() const noexcept { return external_n_; }
  bool ready() const noexcept { return ready_; }

 private:
  FootForceParams params_;
  VecNv v_last_ = VecNv::Zero();
  std::array<Vec3, kFeet> force_n_{};
  Vec3 external_n_ = Vec3::Zero();
  bool primed_ = false;
  bool ready_ = false;
};

}  // namespace springbok::est
