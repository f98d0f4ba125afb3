// The robot springbok controls: dimensions, named frames and joint groups,
// and the matrix aliases every layer uses. All compile-time.
#pragma once

#include <array>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "springbok/model/hyq_gen3.hpp"
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

// The inertia of joint j's own body about the joint's axis (z of its frame) [kg m^2]: a
// lower bound of what the joint drives (the bodies beyond it add to it). A damping law
// evaluated once per step dt is stable only below about this / dt: 0.24 N m s/rad for the
// wrist's last joint at 1 ms (the drive emulator caps what it renders there).
constexpr double joint_own_axis_inertia_kgm2(int j) {
  const auto& in = robot::kJoints[static_cast<std::size_t>(j)].inertia;
  return in.inertia_com_kgm2[2] + in.mass_kg * (in.com_m[0] * in.com_m[0] + in.com_m[1] * in.com_m[1]);
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

}  // namespace springbok
