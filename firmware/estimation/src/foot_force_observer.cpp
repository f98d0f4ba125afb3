#include "springbok/estimation/foot_force_observer.hpp"

#include <cmath>

#include <Eigen/LU>

namespace springbok::est {

void FootForceObserver::update(const dyn::Data& d, const VecNv& v, const Mat3& rotation_wb, const VecNj& tau_nm,
                               const VecNj& friction_nm, double dt_s) noexcept {
  if (!primed_ || !(dt_s > 0.0) || !v.allFinite()) {
    v_last_ = v;
    primed_ = v.allFinite();
    return;
  }
  const VecNv udot = (v - v_last_) / dt_s;
  v_last_ = v;
  const double alpha = dt_s / (params_.filter_s + dt_s);
  for (int f = 0; f < kFeet; ++f) {
    const int row = 6 + leg_first_joint(f);
    const Vec3 residual = d.M.middleRows<kLegJoints>(row) * udot + d.nle.segment<kLegJoints>(row) -
                          tau_nm.segment<kLegJoints>(leg_first_joint(f)) +
                          friction_nm.segment<kLegJoints>(leg_first_joint(f));
    const Mat3 j_leg = d.J_feet[f].middleCols<kLegJoints>(row);
    if (!(std::abs(j_leg.determinant()) > params_.min_jacobian_det) || !residual.allFinite()) continue;
    const Vec3 force = j_leg.transpose().partialPivLu().solve(residual);
    force_n_[f] = ready_ ? Vec3(force_n_[f] + alpha * (force - force_n_[f])) : force;
  }
  const Vec3 external = rotation_wb * (d.M.topRows<3>() * udot + d.nle.head<3>());
  if (external.allFinite()) external_n_ = ready_ ? Vec3(external_n_ + alpha * (external - external_n_)) : external;
  ready_ = true;
}

}  // namespace springbok::est
