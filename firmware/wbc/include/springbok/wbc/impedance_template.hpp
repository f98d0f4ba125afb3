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
#pragma once

#include <array>
#include <complex>

#include <Eigen/Core>

namespace springbok::wbc {

// Diagonal desired mass [kg], damping [N s/m] and stiffness [N/m], per axis x y z.
struct TemplateParams {
  Eigen::Vector3d mass_base_kg{92.0, 92.0, 92.0};
  Eigen::Vector3d damping_base_ns_per_m{610.0, 610.0, 610.0};
  Eigen::Vector3d stiffness_base_n_per_m{1000.0, 1000.0, 1000.0};
  Eigen::Vector3d mass_ee_kg{4.0, 4.0, 4.0};
  Eigen::Vector3d damping_ee_ns_per_m{90.0, 90.0, 90.0};
  Eigen::Vector3d stiffness_ee_n_per_m{500.0, 500.0, 500.0};
};

// One axis of the template as a linear system: state s = [x_b, x_e, xd_b, xd_e], input F_e.
struct AxisSystem {
  Eigen::Matrix4d a;
  Eigen::Vector4d b;
};

AxisSystem axis_system(const TemplateParams& p, int axis);

// The 4 poles of one axis [1/s].
std::array<std::complex<double>, 4> template_poles(const TemplateParams& p, int axis);

// Steady-state displacements under a constant force F: x_b = F / K_b, x_e = F / K_b + F / K_e.
inline Eigen::Vector3d steady_state_base_m(const TemplateParams& p, const Eigen::Vector3d& force_n) {
  return force_n.cwiseQuotient(p.stiffness_base_n_per_m);
}
inline Eigen::Vector3d steady_state_ee_m(const TemplateParams& p, const Eigen::Vector3d& force_n) {
  return force_n.cwiseQuotient(p.stiffness_base_n_per_m) + force_n.cwiseQuotient(p.stiffness_ee_n_per_m);
}

// The template's reference response, advanced one tick at a time.
class TemplateReference {
 public:
  // Start-up: discretises the three axes for step dt_s (matrix exponential).
  TemplateReference(const TemplateParams& params, double dt_s);

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
  const TemplateParams& params() const noexcept { return params_; }

 private:
  TemplateParams params_;
  std::array<Eigen::Matrix4d, 3> ad_;
  std::array<Eigen::Vector4d, 3> bd_;
  std::array<Eigen::Vector4d, 3> state_;
};

}  // namespace springbok::wbc
