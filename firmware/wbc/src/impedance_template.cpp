// Start-up parts of the template: the continuous system, its poles and its
// exact zero-order-hold discretisation (kept out of the header: Eigen's
// matrix functions are heavy to compile).
#include "springbok/wbc/impedance_template.hpp"

#include <Eigen/Eigenvalues>
#include <unsupported/Eigen/MatrixFunctions>

namespace springbok::wbc {

namespace {
// The rotation vector of r (log map).
Eigen::Vector3d log_map(const Eigen::Matrix3d& r) noexcept {
  const Eigen::AngleAxisd aa(r);
  return aa.angle() * aa.axis();
}
}  // namespace

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
                                                  const Eigen::Vector3d& w_ee) noexcept {
  const Eigen::Matrix3d base_turn = r_base * r_base_rest.transpose();
  RotationalTemplateState s;
  s.base_rad = log_map(base_turn);
  s.ee_from_base_rad = log_map(r_ee * (base_turn * r_ee_rest).transpose());
  s.base_rate_rad_s = w_base - w_rest;
  s.ee_from_base_rate_rad_s = w_ee - w_base;
  return s;
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
