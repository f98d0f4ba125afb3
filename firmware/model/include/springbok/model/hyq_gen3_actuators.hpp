// HyQ's actuators, which its URDF cannot say (../shared/robot/ACTUATORS.md): the hip and knee
// flexion-extension joints (HFE, KFE) are driven by hydraulic cylinders through levers, so
// their torque limit is the cylinder's force limit times a lever arm that changes with the
// angle (about 81 N m at the ends of each range, 162 N m where the lever is perpendicular).
// The hip abduction-adduction joints (HAA) and the Gen3's joints keep the URDF's flat effort.
//
// Source: IIT's HyQ code (iit-DLSLab/robotlib: cylinder_lever_arm.cpp for the geometry,
// robot_limits.cpp for the force). The hind legs' formulas, in our URDF's angles:
//   HFE  phi = pi/2 + q + 0.1089,          a = 0.3219 m, b = 0.045 m
//   KFE  phi = pi - q - (0.1403 + 0.1047),  a = 0.3218 m, b = 0.045 m
// and the front legs' the same at -q (their angles run the other way).
// UNCERTAIN: the source's 3600 N is a software limit with no stated origin, and it is the same
// both directions. A cylinder pulling on its rod side has 61 % of the piston's area, so at the
// same pressure it pulls only 61 % of what it pushes; which joint direction pulls is not in the
// source. We use the symmetric 3600 N as the source does. Flow limits (torque falling with
// speed) are not modelled.
#pragma once

#include <array>
#include <numbers>

#include "springbok/model/hyq_gen3.hpp"
#include "springbok/model/model_types.hpp"

namespace springbok::model::hyq_gen3 {

inline constexpr double kCylinderForceMax_n = 3600.0;

namespace actuators {
inline constexpr double kPi = std::numbers::pi;
inline constexpr TorqueLimit kFlat{TorqueLimit::Kind::flat, {}};
constexpr TorqueLimit hfe(double angle_sign) {
  return {TorqueLimit::Kind::lever, {kCylinderForceMax_n, 0.3219, 0.045, angle_sign, kPi / 2.0 + 0.1089}};
}
constexpr TorqueLimit kfe(double angle_sign) {
  return {TorqueLimit::Kind::lever, {kCylinderForceMax_n, 0.3218, 0.045, -angle_sign, kPi - (0.1403 + 0.1047)}};
}
inline constexpr double kFront = -1.0;  // the front legs' angles are the hind legs' negated
inline constexpr double kHind = 1.0;
}  // namespace actuators

// In joint order (kJoints).
inline constexpr std::array<TorqueLimit, kNumJoints> kTorqueLimits{
    actuators::kFlat, actuators::hfe(actuators::kFront), actuators::kfe(actuators::kFront),  // LF
    actuators::kFlat, actuators::hfe(actuators::kFront), actuators::kfe(actuators::kFront),  // RF
    actuators::kFlat, actuators::hfe(actuators::kHind),  actuators::kfe(actuators::kHind),   // LH
    actuators::kFlat, actuators::hfe(actuators::kHind),  actuators::kfe(actuators::kHind),   // RH
    actuators::kFlat, actuators::kFlat, actuators::kFlat, actuators::kFlat,                   // Gen3 1-4
    actuators::kFlat, actuators::kFlat, actuators::kFlat};                                    // Gen3 5-7

}  // namespace springbok::model::hyq_gen3
