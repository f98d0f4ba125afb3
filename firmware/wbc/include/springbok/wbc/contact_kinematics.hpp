// The feet's kinematics the whole-body controller's rows are written in.
//
// A foot is a sphere of radius r at the end of its lower leg (the foot frame is the
// sphere's centre). Two points of it matter:
//  - in stance, the lower leg's material point at the ground contact, c = p_f - r e_z
//    (world e_z, flat ground): a sphere that rolls without slipping holds that point
//    still, and the horizontal ground forces act there. Its velocity and the rolling
//    constraint's acceleration are
//        J_c v = J_f v + r e_z x w_leg,       J_c = J_f + r [e_z]x J_w,
//        d/dt (J_c v) = J_c udot + Jdot_f v + r e_z x (Jdot_w v),
//    with J_w the lower leg's angular Jacobian (world axes) and Jdot_w v = sum over the
//    leg's joints k of w_(k-1) x a_k qd_k (w_(k-1): the angular velocity of the body
//    before joint k, a_k its axis; the trunk's w itself adds no bias in udot's
//    coordinates, where d/dt w_world = R d/dt w_B);
//  - in swing, the sphere's lowest point p_f - r e_z, which is what touches down: it
//    moves as the sphere's centre does, so the swing task is the centre's,
//    rho = R^T (p_f - p_b) in trunk axes, which depends on the leg's joints only:
//        rho'' = J_rho qdd_leg + bias,        J_rho = R^T J_f[leg columns].
//
// Frames: world axes for c; trunk axes for rho. rt: every function here, no alloc.
#pragma once

#include <Eigen/Core>

#include "springbok/dynamics/dynamics.hpp"
#include "springbok/model/model.hpp"
#include "springbok/model/robot_state.hpp"

namespace springbok::wbc {

using Mat3Leg = Eigen::Matrix<double, 3, kLegJoints>;

// The rolling contact point of a stance foot (see above).
struct RollingContact {
  Mat3Nv jacobian = Mat3Nv::Zero();  // J_c, world axes
  Vec3 bias_m_s2 = Vec3::Zero();     // Jdot_f v + r e_z x (Jdot_w v): the constraint's J_c udot + bias = 0
};

// The swing task's point relative to the trunk, trunk axes.
struct SwingKinematics {
  Mat3Leg jacobian = Mat3Leg::Zero();  // J_rho = d rho / d q_leg
  Vec3 position_m = Vec3::Zero();      // rho
  Vec3 velocity_m_s = Vec3::Zero();    // rho'
  Vec3 bias_m_s2 = Vec3::Zero();       // rho'' - J_rho qdd_leg
};

// `d` holds dyn::compute_tick at (state.q, state.v). rt: no alloc
void rolling_contact(const dyn::Data& d, const RobotState& state, int foot, double radius_m,
                     RollingContact& out) noexcept;

// `d` holds dyn::compute_tick at (state.q, state.v). rt: no alloc
void swing_kinematics(const dyn::Data& d, const RobotState& state, int foot, SwingKinematics& out) noexcept;

}  // namespace springbok::wbc
