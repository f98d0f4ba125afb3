// HyQ's HFE / KFE torque limits written as ../shared/robot/ACTUATORS.md gives them (the law of
// cosines for the cylinder's length, the lever arm through the angle at the rod's end), in the
// hind legs' angle convention; a front leg's limit is the hind formula's at -q. An oracle for
// the firmware's own form (model.hpp's lever_arm_m), which it shares no code with.
#pragma once

#include <cmath>
#include <numbers>

namespace springbok::test {

inline constexpr double kHyqCylinderForce_n = 3600.0;

inline double hyq_lever_arm_m(double a, double b, double c) {
  return a * std::sin(std::acos((a * a + c * c - b * b) / (2.0 * a * c)));
}

// Hind-leg convention, q in rad.
inline double hyq_hfe_limit_nm(double q) {
  const double a1 = 0.3219, b1 = 0.045, eps11 = 0.1089;
  const double c = std::sqrt(a1 * a1 + b1 * b1 - 2.0 * a1 * b1 * std::cos(std::numbers::pi / 2.0 + q + eps11));
  return kHyqCylinderForce_n * hyq_lever_arm_m(a1, b1, c);
}
inline double hyq_kfe_limit_nm(double q) {
  const double a2 = 0.3218, b2 = 0.045, eps21 = 0.1403, eps22 = 0.1047;
  const double c = std::sqrt(a2 * a2 + b2 * b2 - 2.0 * a2 * b2 * std::cos(std::numbers::pi - q - (eps21 + eps22)));
  return kHyqCylinderForce_n * hyq_lever_arm_m(a2, b2, c);
}

// Joint j (0..11, the legs LF RF LH RH, HAA HFE KFE each) at q in our URDF's angles: HAA's flat
// 150 N m, HFE / KFE by the formulas above.
inline double hyq_leg_limit_nm(int j, double q) {
  const bool front = j < 6;
  const double hind_q = front ? -q : q;
  switch (j % 3) {
    case 1: return hyq_hfe_limit_nm(hind_q);
    case 2: return hyq_kfe_limit_nm(hind_q);
    default: return 150.0;
  }
}

}  // namespace springbok::test
