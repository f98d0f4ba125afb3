// Start-up parts of the template: the continuous system, its poles and its
// exact zero-order-hold discretisation (kept out of the header: Eigen's
// matrix functions are heavy to compile).
#include "springbok/wbc/impedance_template.hpp"

#include <Eigen/Eigenvalues>
#include <unsupported/Eigen/MatrixFunctions>

namespace springbok::wbc {

AxisSystem axis_system(const TemplateParams& p, int axis) {
  const double mb = p.mass_base_kg[axis], me = p.mass_ee_kg[axis];
  const double kb = p.stiffness_base_n_per_m[axis], ke = p.stiffness_ee_n_per_m[axis];
  const double db = p.damping_base_ns_per_m[axis], de = p.damping_ee_ns_per_m[axis];
  AxisSystem s;
  s.a << 0, 0, 1, 0,                                        //
      0, 0, 0, 1,                                           //
      -(kb + ke) / mb, ke / mb, -(db + de) / mb, de / mb,   //
      ke / me, -ke / me, de / me, -de / me;
  s.b << 0, 0, 0, 1.0 / me;
  return s;
}

std::array<std::complex<double>, 4> template_poles(const TemplateParams& p, int axis) {
  const Eigen::Vector4cd ev = Eigen::EigenSolver<Eigen::Matrix4d>(axis_system(p, axis).a).eigenvalues();
  return {ev[0], ev[1], ev[2], ev[3]};
}

TemplateReference::TemplateReference(const TemplateParams& params, double dt_s) : params_(params) {
  for (int axis = 0; axis < 3; ++axis) {
    const AxisSystem sys = axis_system(params, axis);
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
