#include "springbok/wbc/stand_controller.hpp"

#include <Eigen/Cholesky>

namespace springbok::wbc {

VecNj nominal_stance() noexcept {
  VecNj q;
  for (int j = 0; j < kNj; ++j) q[j] = robot::kStance_rad[static_cast<std::size_t>(j)];
  return q;
}

void stance_gravity_compensation(const dyn::Model& model, dyn::Data& data, const VecNq& q,
                                 StanceForces& forces) noexcept {
  const VecNv& g = dyn::gravity(model, data, q);
  dyn::point_jacobians(model, data, q);
  Mat<6, 3 * kFeet> base_rows;  // J_st,b^T
  for (int f = 0; f < kFeet; ++f) {
    base_rows.block<6, 3>(0, 3 * f) = data.J_feet[f].leftCols<6>().transpose();
  }
  // Minimum-norm solution of base_rows f = g_b: f = A^T (A A^T)^-1 g_b.
  const Mat6 gram = base_rows * base_rows.transpose();
  const Vec6 y = gram.ldlt().solve(g.head<6>());
  forces.f_n = base_rows.transpose() * y;
  forces.tau_gravity_nm = g.tail<kNj>();
  for (int f = 0; f < kFeet; ++f) {
    forces.tau_gravity_nm.noalias() -= data.J_feet[f].rightCols<kNj>().transpose() * forces.f_n.segment<3>(3 * f);
  }
}

StandController::StandController(const StandGains& gains, const VecNj& posture_rad)
    : data_(std::make_unique<dyn::Data>()), gains_(gains), posture_rad_(posture_rad) {}

void StandController::tick(const VecNq& q, hal::JointCommands& out) noexcept {
  stance_gravity_compensation(model_, *data_, q, forces_);
  out.mode = hal::CommandMode::enabled;
  out.tau_ff_nm = forces_.tau_gravity_nm;
  out.q_des_rad = posture_rad_;
  out.qd_des_rad_s.setZero();
  out.kp_nm_per_rad.head<kFirstArmJoint>().setConstant(gains_.kp_leg_nm_per_rad);
  out.kd_nms_per_rad.head<kFirstArmJoint>().setConstant(gains_.kd_leg_nms_per_rad);
  out.kp_nm_per_rad.tail<kArmJoints>().setConstant(gains_.kp_arm_nm_per_rad);
  out.kd_nms_per_rad.tail<kArmJoints>().setConstant(gains_.kd_arm_nms_per_rad);
  ++out.sequence;
}

}  // namespace springbok::wbc
