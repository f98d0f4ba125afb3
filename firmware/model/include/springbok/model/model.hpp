// The robot springbok controls: dimensions, named frames and joint groups,
// and the matrix aliases every layer uses. All compile-time.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "springbok/model/hyq_gen3.hpp"
#include "springbok/model/hyq_gen3_actuators.hpp"
#include "springbok/model/model_types.hpp"

namespace springbok {

namespace robot = model::hyq_gen3;

// ---- dimensions --------------------------------------------------------------
inline constexpr int kNj = robot::kNumJoints;   // actuated joints
inline constexpr int kNq = 7 + kNj;             // [p_WB, quaternion xyzw, joints]
inline constexpr int kNv = 6 + kNj;             // [v_B, w_B (trunk frame), joint rates]
inline constexpr int kNb = robot::kNumBodies;   // bodies, 0 = floating base
inline constexpr int kFeet = 4;
inline constexpr int kLegJoints = 3;
inline constexpr int kArmJoints = 7;
inline constexpr int kFirstArmJoint = robot::kJoint_arm_joint_1;  // index into the 19 joints

static_assert(kNq == 26 && kNv == 25 && kNj == 19, "HyQ + Gen3: nq 26, nv 25, 19 joints");
static_assert(kFeet * kLegJoints + kArmJoints == kNj);
static_assert(kFirstArmJoint == kFeet * kLegJoints, "legs first, then the arm");

// ---- named frames ----------------------------------------------------------------
enum class Foot : int { lf = 0, rf = 1, lh = 2, rh = 3 };
inline constexpr std::array<int, kFeet> kFootFrames{robot::kFrame_lf_foot, robot::kFrame_rf_foot,
                                                    robot::kFrame_lh_foot, robot::kFrame_rh_foot};
inline constexpr int kEeFrame = robot::kFrame_arm_end_effector_link;
// The wrist 6-axis F/T sensor sits at the Gen3 tool flange, which is the
// end-effector frame (no gripper): the measured wrench is F_e at the EE.
inline constexpr int kWristFtFrame = robot::kFrame_arm_end_effector_link;
inline constexpr int kImuFrame = robot::kFrame_trunk_imu;
inline constexpr double kFootRadius_m = 0.02175;
inline constexpr double kGravity_m_s2 = 9.81;

// First joint (0..18) of leg `foot`.
constexpr int leg_first_joint(int foot) { return foot * kLegJoints; }

// Total mass, summed at compile time from the model.
constexpr double total_mass_kg() {
  double m = robot::kBaseInertia.mass_kg;
  for (const auto& j : robot::kJoints) m += j.inertia.mass_kg;
  return m;
}

// ---- rotor (reflected actuator) inertia ----------------------------------------------------
// Not in the URDF (../shared/robot/PARAMS.md): HyQ's legs are hydraulic (the cylinders'
// moving mass is in the links; no rotor: 0). The Gen3's joints are motors behind harmonic
// drives. Kinova publishes no rotor figure; these are an ESTIMATE, not a measurement: a
// frameless motor of the size such an actuator holds has a rotor inertia of about 4e-6 kg m^2
// (large actuators, joints 1-4, 39 N m) and 1.5e-6 kg m^2 (small, joints 5-7, 9 N m); times
// an assumed 100:1 reduction squared: 0.04 and 0.015 kg m^2. Identify it on the robot (a
// joint's low-frequency acceleration response to a torque chirp) before trusting it. It
// dominates the wrist's own inertia (~1e-3 kg m^2): without it the dynamically consistent
// pseudo-inverse of the arm task moved the hand with the light wrist joints, at twice their
// speed limit.
// The rotor is modelled as inertia about the joint's axis added to the joint's own body (all
// axes here are z of the body frame), so the dynamics and the simulated robot (Bullet has no
// armature) carry the same physics; M's (j, j) entry is exact, the couplings with the
// joints before it are the rotor's times its reduction (small at 100:1).
inline constexpr std::array<double, kNj> kRotorInertia_kgm2{
    0.0,   0.0,   0.0,   0.0,   0.0,   0.0,   0.0,   0.0,   0.0,   0.0,   0.0,   0.0,  // legs
    0.04,  0.04,  0.04,  0.04,  0.015, 0.015, 0.015};                                    // Gen3 1-7

constexpr bool every_axis_is_z() {
  for (const auto& j : robot::kJoints) {
    if (j.axis[0] != 0.0 || j.axis[1] != 0.0 || j.axis[2] != 1.0) return false;
  }
  return true;
}
static_assert(every_axis_is_z(), "the rotors (and joint_own_axis_inertia_kgm2) take each joint's axis as z");

enum class Rotors { included, none };

// Body b's inertia (0: the trunk), with its joint's rotor unless `rotors` is none. rt: no alloc
constexpr model::Inertia body_inertia(int body, Rotors rotors = Rotors::included) {
  if (body == 0) return robot::kBaseInertia;
  const std::size_t j = static_cast<std::size_t>(body - 1);
  model::Inertia in = robot::kJoints[j].inertia;
  if (rotors == Rotors::included) in.inertia_com_kgm2[2] += kRotorInertia_kgm2[j];
  return in;
}

// The inertia of joint j's own body about the joint's axis (z of its frame) [kg m^2]: a
// lower bound of what the joint drives (the bodies beyond it add to it). A damping law
// evaluated once per step dt is stable only below about 2 this / dt: for the wrist's last
// joint at 1 ms ~31 N m s/rad with its rotor, 0.5 without (the drive emulator caps what it
// renders at this / dt).
constexpr double joint_own_axis_inertia_kgm2(int j) {
  const model::Inertia in = body_inertia(j + 1);
  return in.inertia_com_kgm2[2] + in.mass_kg * (in.com_m[0] * in.com_m[0] + in.com_m[1] * in.com_m[1]);
}

// ---- torque limits -----------------------------------------------------------------------
// The URDF's flat effort, or a lever actuator's force times its lever arm at the angle
// (hyq_gen3_actuators.hpp), the same both directions.

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
