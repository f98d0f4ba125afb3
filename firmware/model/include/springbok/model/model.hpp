// The robot springbok controls: dimensions, named frames and joint groups,
// and the matrix aliases every layer uses. All compile-time.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "robot_model.hpp"  // the robot's folder (SPRINGBOK_ROBOT): firmware/model/robots/README.md
#include "springbok/model/model_types.hpp"

namespace springbok {

// ---- dimensions --------------------------------------------------------------
inline constexpr int kNj = robot::kNumJoints;   // actuated joints
inline constexpr int kNq = 7 + kNj;             // [p_WB, quaternion xyzw, joints]
inline constexpr int kNv = 6 + kNj;             // [v_B, w_B (trunk frame), joint rates]
inline constexpr int kNb = robot::kNumBodies;   // bodies, 0 = floating base
using robot::kArmJoints;
using robot::kFeet;
using robot::kFirstArmJoint;                    // index into the joints
using robot::kLegJoints;

static_assert(kFeet == 4 && kLegJoints == 3, "a quadruped, three joints per leg");
static_assert(kFeet * kLegJoints + kArmJoints == kNj);
static_assert(kFirstArmJoint == kFeet * kLegJoints, "legs first, then the arm");
static_assert(kArmJoints >= 1);

// ---- named frames ----------------------------------------------------------------
enum class Foot : int { lf = 0, rf = 1, lh = 2, rh = 3 };
using robot::kEeFrame;        // the hand: the arm's end effector
using robot::kFootFrames;     // the feet's contact spheres' centres, LF RF LH RH
using robot::kFootRadius_m;
using robot::kImuFrame;
using robot::kWristFtFrame;   // where the wrist F/T sensor measures F_e
inline constexpr double kGravity_m_s2 = 9.81;

// First joint of leg `foot`.
constexpr int leg_first_joint(int foot) { return foot * kLegJoints; }

// Total mass, summed at compile time from the model.
constexpr double total_mass_kg() {
  double m = robot::kBaseInertia.mass_kg;
  for (const auto& j : robot::kJoints) m += j.inertia.mass_kg;
  return m;
}

// ---- rotor (reflected actuator) inertia ----------------------------------------------------
// Not in a URDF: the robot file's (robot::kRotorInertiaSource says where each figure comes
// from). It dominates a light wrist's own inertia: without it the dynamically consistent
// pseudo-inverse of the arm task moves the hand with the light wrist joints.
// The rotor is modelled as inertia about the joint's axis added to the joint's own body, so the
// dynamics and the simulated robot (Bullet has no armature) carry the same physics; M's (j, j)
// entry is exact, the couplings with the joints before it are the rotor's times its reduction
// (small at high reductions).
using robot::kRotorInertia_kgm2;

enum class Rotors { included, none };

// Body b's inertia (0: the trunk), with its joint's rotor (I_r a a^T about the COM, a the
// joint's unit axis in the body frame) unless `rotors` is none. rt: no alloc
constexpr model::Inertia body_inertia(int body, Rotors rotors = Rotors::included) {
  if (body == 0) return robot::kBaseInertia;
  const std::size_t j = static_cast<std::size_t>(body - 1);
  model::Inertia in = robot::kJoints[j].inertia;
  if (rotors == Rotors::included) {
    const std::array<double, 3>& a = robot::kJoints[j].axis;
    const double r = kRotorInertia_kgm2[j];
    in.inertia_com_kgm2[0] += r * a[0] * a[0];
    in.inertia_com_kgm2[1] += r * a[1] * a[1];
    in.inertia_com_kgm2[2] += r * a[2] * a[2];
    in.inertia_com_kgm2[3] += r * a[0] * a[1];
    in.inertia_com_kgm2[4] += r * a[0] * a[2];
    in.inertia_com_kgm2[5] += r * a[1] * a[2];
  }
  return in;
}

// The inertia of joint j's own body about the joint's axis [kg m^2]: a' I_com a plus the mass
// times the squared distance of the COM from the axis. A lower bound of what the joint drives
// (the bodies beyond it add to it). A damping law evaluated once per step dt is stable only
// below about 2 this / dt (the drive emulator caps what it renders at this / dt).
constexpr double joint_own_axis_inertia_kgm2(int j) {
  const model::Inertia in = body_inertia(j + 1);
  const std::array<double, 3>& a = robot::kJoints[static_cast<std::size_t>(j)].axis;
  const std::array<double, 6>& I = in.inertia_com_kgm2;
  const double about_com = a[0] * a[0] * I[0] + a[1] * a[1] * I[1] + a[2] * a[2] * I[2] +
                           2.0 * (a[0] * a[1] * I[3] + a[0] * a[2] * I[4] + a[1] * a[2] * I[5]);
  const std::array<double, 3>& c = in.com_m;
  const double along = c[0] * a[0] + c[1] * a[1] + c[2] * a[2];
  const double distance2 = c[0] * c[0] + c[1] * c[1] + c[2] * c[2] - along * along;
  return about_com + in.mass_kg * distance2;
}

// ---- torque limits -----------------------------------------------------------------------
// The URDF's flat effort (or the robot file's in its place), or a lever actuator's force times
// its lever arm at the angle (the robot file's torque_limits), the same both directions.

// The lever arm's ratio a b sin(phi) / c at the actuator angle phi [m]. rt: no alloc
inline double lever_arm_m(const model::LeverActuator& l, double phi_rad) noexcept {
  const double c2 = l.a_m * l.a_m + l.b_m * l.b_m - 2.0 * l.a_m * l.b_m * std::cos(phi_rad);
  return l.a_m * l.b_m * std::abs(std::sin(phi_rad)) / std::sqrt(c2);
}

// Joint j's torque limit at q_rad [N m]. Beyond a bounded joint's stop the actuator is at its
// end: the angle is taken within the range. A non-finite angle gives the smallest limit over
// the range (the safe one where the angle is unknown). rt: no alloc
inline double torque_limit_nm(int j, double q_rad) noexcept {
  const model::Joint& joint = robot::kJoints[static_cast<std::size_t>(j)];
  const model::TorqueLimit& t = robot::kTorqueLimits[static_cast<std::size_t>(j)];
  if (t.kind == model::TorqueLimit::Kind::flat) return joint.limits.effort_nm;
  const model::LeverActuator& l = t.lever;
  if (!std::isfinite(q_rad)) {
    return l.force_max_n * std::min(lever_arm_m(l, l.angle_sign * joint.limits.lower_rad + l.angle_offset_rad),
                                     lever_arm_m(l, l.angle_sign * joint.limits.upper_rad + l.angle_offset_rad));
  }
  if (joint.limits.bounded) q_rad = std::clamp(q_rad, joint.limits.lower_rad, joint.limits.upper_rad);
  return l.force_max_n * lever_arm_m(l, l.angle_sign * q_rad + l.angle_offset_rad);
}

// The largest of joint j's limits over its range [N m]: the arm is longest, b, where
// cos(phi) = b / a (a > b), else at an end of the range. rt: no alloc
inline double torque_limit_peak_nm(int j) noexcept {
  const model::Joint& joint = robot::kJoints[static_cast<std::size_t>(j)];
  const model::TorqueLimit& t = robot::kTorqueLimits[static_cast<std::size_t>(j)];
  if (t.kind == model::TorqueLimit::Kind::flat) return joint.limits.effort_nm;
  const model::LeverActuator& l = t.lever;
  const double phi_lower = l.angle_sign * joint.limits.lower_rad + l.angle_offset_rad;
  const double phi_upper = l.angle_sign * joint.limits.upper_rad + l.angle_offset_rad;
  const double phi_peak = std::acos(l.b_m / l.a_m);
  if (std::min(phi_lower, phi_upper) <= phi_peak && phi_peak <= std::max(phi_lower, phi_upper)) {
    return l.force_max_n * l.b_m;
  }
  return l.force_max_n * std::max(lever_arm_m(l, phi_lower), lever_arm_m(l, phi_upper));
}

// ---- matrix aliases (fixed size: nothing on the tick path allocates) -------------------
template <int R, int C>
using Mat = Eigen::Matrix<double, R, C>;
template <int R>
using Vec = Eigen::Matrix<double, R, 1>;

using Vec3 = Eigen::Vector3d;
using Vec6 = Vec<6>;
using Mat3 = Eigen::Matrix3d;
using Mat6 = Eigen::Matrix<double, 6, 6>;
using Quat = Eigen::Quaterniond;

using VecNq = Vec<kNq>;
using VecNv = Vec<kNv>;
using VecNj = Vec<kNj>;
using MatNv = Eigen::Matrix<double, kNv, kNv>;
using Mat3Nv = Eigen::Matrix<double, 3, kNv>;
using Mat6Nv = Eigen::Matrix<double, 6, kNv>;

// Every joint's torque limit at q [N m] (torque_limit_nm). rt: no alloc
inline VecNj torque_limits_nm(const VecNj& q_rad) noexcept {
  VecNj limits;
  for (int j = 0; j < kNj; ++j) limits[j] = torque_limit_nm(j, q_rad[j]);
  return limits;
}

}  // namespace springbok
