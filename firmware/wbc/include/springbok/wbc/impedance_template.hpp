// The template the robot renders (paper eq. 3, SPEC section 2): per Cartesian
// axis a base mass and an end-effector mass,
//
//   M_b xdd_b = -K_b x_b - D_b xd_b + K_e (x_e - x_b) + D_e (xd_e - xd_b)
//   M_e xdd_e = -K_e (x_e - x_b) - D_e (xd_e - xd_b) + F_e
//
// with x_b, x_e the displacements from their desired (initial) positions.
// It is linear, so its response to a force that is constant over each tick
// (as the simulator and the wrist sensor deliver it) is integrated exactly:
// the zero-order-hold discretisation expm([[A, B], [0, 0]] dt), computed once.
//
// The rotational template (SPEC section 2 names it as ours; off by default) is the same
// two-body structure per axis of rotation: a rotational inertia, damping and stiffness
// for the trunk relative to its rest orientation and for the hand relative to the trunk,
// driven by the torque measured at the wrist:
//
//   I_b wd_b = -K_rb th_b - D_rb w_b + K_re th_be + D_re w_be
//   I_e wd_e = -K_re th_be - D_re w_be + T_e
//
// On SO(3) the displacements are rotation vectors (log map, world axes):
// th_b = log(R_b R_b0^T), th_be = log(R_e (R_b R_b0^T R_e0)^T) (the hand from where it
// would be had it turned with the trunk), and w_be = w_e - w_b. For small rotations
// th_be = th_e - th_b and the law is three independent copies of the translational
// axis (tests/wbc/test_rotational_template.cpp checks that on a rigid-body integration).
#pragma once

#include <array>
#include <complex>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "springbok/model/model.hpp"

namespace springbok::wbc {

// Diagonal desired mass [kg], damping [N s/m] and stiffness [N/m], per axis x y z. The
// defaults are the robot file's `template`.
struct TemplateParams {
  Eigen::Vector3d mass_base_kg = Eigen::Vector3d::Constant(robot::kTemplate.base.mass);
  Eigen::Vector3d damping_base_ns_per_m = Eigen::Vector3d::Constant(robot::kTemplate.base.damping);
  Eigen::Vector3d stiffness_base_n_per_m = Eigen::Vector3d::Constant(robot::kTemplate.base.stiffness);
  Eigen::Vector3d mass_ee_kg = Eigen::Vector3d::Constant(robot::kTemplate.ee.mass);
  Eigen::Vector3d damping_ee_ns_per_m = Eigen::Vector3d::Constant(robot::kTemplate.ee.damping);
  Eigen::Vector3d stiffness_ee_n_per_m = Eigen::Vector3d::Constant(robot::kTemplate.ee.stiffness);
};

// Diagonal desired rotational inertia [kg m^2], damping [N m s/rad] and stiffness
// [N m/rad] per axis of rotation x y z (world). A non-positive base inertia means "the
// robot's composite rotational inertia at the reference pose" (the WBC resolves it). The
// defaults are the robot file's `rotational_template`.
struct RotationalTemplateParams {
  Eigen::Vector3d inertia_base_kgm2 = Eigen::Vector3d::Zero();
  Eigen::Vector3d damping_base_nms_per_rad = Eigen::Vector3d::Constant(robot::kTemplate.base_rotation.damping);
  Eigen::Vector3d stiffness_base_nm_per_rad = Eigen::Vector3d::Constant(robot::kTemplate.base_rotation.stiffness);
  Eigen::Vector3d inertia_ee_kgm2 = Eigen::Vector3d::Constant(robot::kTemplate.ee_rotation.mass);
  Eigen::Vector3d damping_ee_nms_per_rad = Eigen::Vector3d::Constant(robot::kTemplate.ee_rotation.damping);
  Eigen::Vector3d stiffness_ee_nm_per_rad = Eigen::Vector3d::Constant(robot::kTemplate.ee_rotation.stiffness);
};

// One axis of either template: masses (or inertias), dampings, stiffnesses.
struct AxisParams {
  double mass_base, damping_base, stiffness_base;
  double mass_ee, damping_ee, stiffness_ee;
};
using TemplateAxes = std::array<AxisParams, 3>;

TemplateAxes template_axes(const TemplateParams& p);
// `base_inertia_kgm2`: the resolved I_b (the WBC's base_rotational_inertia_kgm2()).
TemplateAxes template_axes(const RotationalTemplateParams& p, const Eigen::Vector3d& base_inertia_kgm2);

// One axis of the template as a linear system: state s = [x_b, x_e, xd_b, xd_e], input F_e.
struct AxisSystem {
  Eigen::Matrix4d a;
  Eigen::Vector4d b;
};

AxisSystem axis_system(const AxisParams& p);
inline AxisSystem axis_system(const TemplateParams& p, int axis) {
  return axis_system(template_axes(p)[static_cast<std::size_t>(axis)]);
}

// The 4 poles of one axis [1/s].
std::array<std::complex<double>, 4> template_poles(const AxisParams& p);
inline std::array<std::complex<double>, 4> template_poles(const TemplateParams& p, int axis) {
  return template_poles(template_axes(p)[static_cast<std::size_t>(axis)]);
}

// Steady-state displacements under a constant force F: x_b = F / K_b, x_e = F / K_b + F / K_e.
inline Eigen::Vector3d steady_state_base_m(const TemplateParams& p, const Eigen::Vector3d& force_n) {
  return force_n.cwiseQuotient(p.stiffness_base_n_per_m);
}
inline Eigen::Vector3d steady_state_ee_m(const TemplateParams& p, const Eigen::Vector3d& force_n) {
  return force_n.cwiseQuotient(p.stiffness_base_n_per_m) + force_n.cwiseQuotient(p.stiffness_ee_n_per_m);
}
// The same for a constant torque T (small angles): th_b = T / K_rb, th_e = T / K_rb + T / K_re.
inline Eigen::Vector3d steady_state_base_rad(const RotationalTemplateParams& p, const Eigen::Vector3d& torque_nm) {
  return torque_nm.cwiseQuotient(p.stiffness_base_nm_per_rad);
}
inline Eigen::Vector3d steady_state_ee_rad(const RotationalTemplateParams& p, const Eigen::Vector3d& torque_nm) {
  return torque_nm.cwiseQuotient(p.stiffness_base_nm_per_rad) + torque_nm.cwiseQuotient(p.stiffness_ee_nm_per_rad);
}

// The rotational template's law at the robot's orientations (world axes): the torque the
// template's springs and dampers put on the trunk (K_rb, D_rb towards the rest
// orientation, K_re, D_re from the hand) and the hand's template angular acceleration.
// The rest orientations move with a walking rest pose (the trunk's angular velocity w_rest)
// and a hand pose command (the hand's w_ee_rest).
struct RotationalTemplateState {
  Eigen::Vector3d base_rad;           // th_b
  Eigen::Vector3d ee_from_base_rad;   // th_be
  Eigen::Vector3d base_rate_rad_s;    // w_b - w_rest
  Eigen::Vector3d ee_from_base_rate_rad_s;  // (w_e - w_e,rest) - (w_b - w_rest)
};
RotationalTemplateState rotational_template_state(const Eigen::Matrix3d& r_base, const Eigen::Matrix3d& r_base_rest,
                                                  const Eigen::Matrix3d& r_ee, const Eigen::Matrix3d& r_ee_rest,
                                                  const Eigen::Vector3d& w_base, const Eigen::Vector3d& w_rest,
                                                  const Eigen::Vector3d& w_ee, const Eigen::Vector3d& w_ee_rest) noexcept;
// The rotation vector of r (the log map of SO(3), robust near 0 and pi). rt: no alloc
Eigen::Vector3d so3_log(const Eigen::Matrix3d& r) noexcept;

// The left Jacobian of SO(3): the angular velocity of exp(phi), in the axes phi is in, is
// J_l(phi) d phi / dt. rt: no alloc
Eigen::Matrix3d so3_left_jacobian(const Eigen::Vector3d& phi) noexcept;
// (d/dt J_l(phi)) d phi / dt, the rest of the angular acceleration J_l phi'' + (d/dt J_l) phi'. rt: no alloc
Eigen::Vector3d so3_left_jacobian_rate(const Eigen::Vector3d& phi, const Eigen::Vector3d& phi_rate) noexcept;

inline Eigen::Vector3d rotational_template_base_torque_nm(const RotationalTemplateParams& p,
                                                          const RotationalTemplateState& s) noexcept {
  return -p.stiffness_base_nm_per_rad.cwiseProduct(s.base_rad) - p.damping_base_nms_per_rad.cwiseProduct(s.base_rate_rad_s) +
         p.stiffness_ee_nm_per_rad.cwiseProduct(s.ee_from_base_rad) +
         p.damping_ee_nms_per_rad.cwiseProduct(s.ee_from_base_rate_rad_s);
}
inline Eigen::Vector3d rotational_template_ee_acceleration_rad_s2(const RotationalTemplateParams& p,
                                                                  const RotationalTemplateState& s,
                                                                  const Eigen::Vector3d& torque_nm) noexcept {
  return (-p.stiffness_ee_nm_per_rad.cwiseProduct(s.ee_from_base_rad) -
          p.damping_ee_nms_per_rad.cwiseProduct(s.ee_from_base_rate_rad_s) + torque_nm)
      .cwiseQuotient(p.inertia_ee_kgm2);
}

// The template's reference response, advanced one tick at a time.
class TemplateReference {
 public:
  // Start-up: discretises the three axes for step dt_s (matrix exponential).
  TemplateReference(const TemplateAxes& axes, double dt_s);
  TemplateReference(const TemplateParams& params, double dt_s) : TemplateReference(template_axes(params), dt_s) {}

  void reset() noexcept {
    for (auto& s : state_) s.setZero();
  }

  // Advances by one tick with the force held constant over it. rt: no alloc
  void step(const Eigen::Vector3d& force_n) noexcept {
    for (int axis = 0; axis < 3; ++axis) {
      const Eigen::Vector4d next = ad_[axis] * state_[axis] + bd_[axis] * force_n[axis];
      state_[axis] = next;
    }
  }

  Eigen::Vector3d base_m() const noexcept { return {state_[0][0], state_[1][0], state_[2][0]}; }
  Eigen::Vector3d ee_m() const noexcept { return {state_[0][1], state_[1][1], state_[2][1]}; }
  Eigen::Vector3d base_velocity_m_s() const noexcept { return {state_[0][2], state_[1][2], state_[2][2]}; }
  Eigen::Vector3d ee_velocity_m_s() const noexcept { return {state_[0][3], state_[1][3], state_[2][3]}; }

 private:
  std::array<Eigen::Matrix4d, 3> ad_;
  std::array<Eigen::Vector4d, 3> bd_;
  std::array<Eigen::Vector4d, 3> state_;
};

}  // namespace springbok::wbc
