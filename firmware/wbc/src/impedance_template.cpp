// Start-up parts of the template: the continuous system, its poles and its
// exact zero-order-hold discretisation (kept out of the header: Eigen's
// matrix functions are heavy to compile).
#include "springbok/wbc/impedance_template.hpp"

#include <cmath>

#include <Eigen/Eigenvalues>
#include <unsupported/Eigen/MatrixFunctions>

namespace springbok::wbc {

Eigen::Vector3d so3_log(const Eigen::Matrix3d& r) noexcept {
  const Eigen::AngleAxisd aa(r);
  return aa.angle() * aa.axis();
}

TemplateAxes template_axes(const TemplateParams& p) {
  TemplateAxes axes{};
  for (int i = 0; i < 3; ++i) {
    axes[static_cast<std::size_t>(i)] = {p.mass_base_kg[i], p.damping_base_ns_per_m[i], p.stiffness_base_n_per_m[i],
                                         p.mass_ee_kg[i],   p.damping_ee_ns_per_m[i],   p.stiffness_ee_n_per_m[i]};
  }
  return axes;
}

TemplateAxes template_axes(const RotationalTemplateParams& p, const Eigen::Vector3d& base_inertia_kgm2) {
  TemplateAxes axes{};
  for (int i = 0; i < 3; ++i) {
    axes[static_cast<std::size_t>(i)] = {base_inertia_kgm2[i], p.damping_base_nms_per_rad[i], p.stiffness_base_nm_per_rad[i],
                                         p.inertia_ee_kgm2[i], p.damping_ee_nms_per_rad[i],   p.stiffness_ee_nm_per_rad[i]};
  }
  return axes;
}

RotationalTemplateState rotational_template_state(const Eigen::Matrix3d& r_base, const Eigen::Matrix3d& r_base_rest,
                                                  const Eigen::Matrix3d& r_ee, const Eigen::Matrix3d& r_ee_rest,
                                                  const Eigen::Vector3d& w_base, const Eigen::Vector3d& w_rest,
                                                  const Eigen::Vector3d& w_ee, const Eigen::Vector3d& w_ee_rest) noexcept {
  const Eigen::Matrix3d base_turn = r_base * r_base_rest.transpose();
  RotationalTemplateState s;
  s.base_rad = so3_log(base_turn);
  s.ee_from_base_rad = so3_log(r_ee * (base_turn * r_ee_rest).transpose());
  s.base_rate_rad_s = w_base - w_rest;
  s.ee_from_base_rate_rad_s = (w_ee - w_ee_rest) - (w_base - w_rest);
  return s;
}

Eigen::Matrix3d so3_left_jacobian(const Eigen::Vector3d& phi) noexcept {
  const double theta2 = phi.squaredNorm();
  const double theta = std::sqrt(theta2);
  // (1 - cos t) / t^2 and (t - sin t) / t^3, by their series below 1e-4 rad.
  const double a = theta < 1e-4 ? 0.5 - theta2 / 24.0 : (1.0 - std::cos(theta)) / theta2;
  const double b = theta < 1e-4 ? 1.0 / 6.0 - theta2 / 120.0 : (theta - std::sin(theta)) / (theta2 * theta);
  Eigen::Matrix3d skew;
  skew << 0.0, -phi.z(), phi.y(), phi.z(), 0.0, -phi.x(), -phi.y(), phi.x(), 0.0;
  return Eigen::Matrix3d::Identity() + a * skew + b * skew * skew;
}

Eigen::Vector3d so3_left_jacobian_rate(const Eigen::Vector3d& phi, const Eigen::Vector3d& phi_rate) noexcept {
  // J_l = I + a(t) S + b(t) S^2 with S = [phi]x, t = |phi|; along phi' (and [phi']x phi' = 0):
  //   (d/dt J_l) phi' = (phi . phi') (a'/t  phi x phi' + b'/t  phi x (phi x phi')) + b phi' x (phi x phi').
  const double theta2 = phi.squaredNorm();
  const double theta = std::sqrt(theta2);
  // Below 1e-2 the closed forms cancel: their series to t^2 (and no sin, cos: a hand that does
  // not turn, phi = 0, costs no transcendental call).
  double b = 1.0 / 6.0 - theta2 / 120.0, da = -1.0 / 12.0 + theta2 / 180.0, db = -1.0 / 60.0 + theta2 / 1260.0;
  if (theta >= 1e-4) {
    const double s = std::sin(theta), c = std::cos(theta);
    b = (theta - s) / (theta2 * theta);
    if (theta >= 1e-2) {
      da = (theta * s - 2.0 * (1.0 - c)) / (theta2 * theta2);
      db = (theta * (1.0 - c) - 3.0 * (theta - s)) / (theta2 * theta2 * theta);
    }
  }
  const Eigen::Vector3d cross = phi.cross(phi_rate);
  return phi.dot(phi_rate) * (da * cross + db * phi.cross(cross)) + b * phi_rate.cross(cross);
}

AxisSystem axis_system(const AxisParams& p) {
  const double mb = p.mass_base, me = p.mass_ee;
  const double kb = p.stiffness_base, ke = p.stiffness_ee;
  const double db = p.damping_base, de = p.damping_ee;
  AxisSystem s;
  s.a << 0, 0, 1, 0,                                        //
      0, 0, 0, 1,                                           //
      -(kb + ke) / mb, ke / mb, -(db + de) / mb, de / mb,   //
      ke / me, -ke / me, de / me, -de / me;
  s.b << 0, 0, 0, 1.0 / me;
  return s;
}

std::array<std::complex<double>, 4> template_poles(const AxisParams& p) {
  const Eigen::Vector4cd ev = Eigen::EigenSolver<Eigen::Matrix4d>(axis_system(p).a).eigenvalues();
  return {ev[0], ev[1], ev[2], ev[3]};
}

TemplateReference::TemplateReference(const TemplateAxes& axes, double dt_s) {
  for (int axis = 0; axis < 3; ++axis) {
    const AxisSystem sys = axis_system(axes[static_cast<std::size_t>(axis)]);
    Eigen::Matrix<double, 5, 5> aug = Eigen::Matrix<double, 5, 5>::Zero();
    aug.topLeftCorner<4, 4>() = sys.a * dt_s;
    aug.topRightCorner<4, 1>() = sys.b * dt_s;
    const Eigen::Matrix<double, 5, 5> e = aug.exp();
    ad_[axis] = e.topLeftCorner<4, 4>();
    bd_[axis] = e.topRightCorner<4, 1>();
  }
  reset();
}

}  // namespace springbok::wbc
