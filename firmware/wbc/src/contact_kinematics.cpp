#include "springbok/wbc/contact_kinematics.hpp"

namespace springbok::wbc {

void rolling_contact(const dyn::Data& d, const RobotState& state, int foot, double radius_m,
                     RollingContact& out) noexcept {
  const Mat3& rot = state.rotation_wb;
  const int first = leg_first_joint(foot);
  out.jacobian = d.J_feet[foot];
  // r [e_z]x w = r (-w_y, w_x, 0) for each column's angular part w.
  const auto shift = [&](int col, const Vec3& w) {
    out.jacobian(0, col) -= radius_m * w.y();
    out.jacobian(1, col) += radius_m * w.x();
  };
  for (int k = 0; k < 3; ++k) shift(3 + k, rot.col(k));
  Vec3 omega = rot * state.v.segment<3>(3);  // w_(k-1), world axes
  Vec3 angular_bias = Vec3::Zero();          // Jdot_w v
  for (int k = 0; k < kLegJoints; ++k) {
    const int j = first + k;
    shift(6 + j, d.joint_axis[j]);
    const Vec3 joint_rate = d.joint_axis[j] * state.v[6 + j];
    angular_bias += omega.cross(joint_rate);
    omega += joint_rate;
  }
  out.bias_m_s2 = d.dJv_feet[foot] + radius_m * Vec3::UnitZ().cross(angular_bias);
}

void swing_kinematics(const dyn::Data& d, const RobotState& state, int foot, SwingKinematics& out) noexcept {
  const Mat3& rot = state.rotation_wb;
  const int leg_col = 6 + leg_first_joint(foot);
  const Vec3 base_vel_world = rot * state.v.head<3>();
  const Vec3 omega_world = rot * state.v.segment<3>(3);
  // r = p_f - p_b (world): r' = J_f v - p_b', r'' = J_f udot + Jdot_f v - p_b'' with
  // p_b'' = R (d/dt v_B + w_B x v_B); rho = R^T r, so
  //   rho'' = R^T (r'' - 2 w x r' - w' x r + w x (w x r)),
  // where the trunk's accelerations cancel (rho depends on the leg's joints only) and
  // what remains besides J_rho qdd_leg is the bias below.
  out.jacobian = rot.transpose() * d.J_feet[foot].block<3, kLegJoints>(0, leg_col);
  const Vec3 r = d.frames[kFootFrames[foot]].translation - state.q.head<3>();
  const Vec3 r_dot = d.J_feet[foot] * state.v - base_vel_world;
  const Vec3 r_ddot0 = d.dJv_feet[foot] - rot * state.v.segment<3>(3).cross(state.v.head<3>());
  out.position_m = rot.transpose() * r;
  out.velocity_m_s = out.jacobian * state.v.segment<kLegJoints>(leg_col);
  out.bias_m_s2 =
      rot.transpose() * (r_ddot0 - 2.0 * omega_world.cross(r_dot) + omega_world.cross(omega_world.cross(r)));
}

}  // namespace springbok::wbc
