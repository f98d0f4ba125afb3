// Joint position and speed limits, taken from the generated robot model
// (springbok::robot::kJoints). Continuous joints have no position limit. The torque limits
// depend on the angle: springbok::torque_limit_nm (model.hpp).
#pragma once

#include <array>

#include "springbok/model/model.hpp"

namespace springbok::safety {

struct JointLimits {
  std::array<bool, kNj> bounded{};  // false for continuous joints
  VecNj lower_rad = VecNj::Zero();
  VecNj upper_rad = VecNj::Zero();
  VecNj velocity_rad_s = VecNj::Zero();
};

inline JointLimits joint_limits_from_model() noexcept {
  JointLimits limits;
  for (int j = 0; j < kNj; ++j) {
    const auto& l = robot::kJoints[static_cast<std::size_t>(j)].limits;
    limits.bounded[static_cast<std::size_t>(j)] = l.bounded;
    limits.lower_rad[j] = l.lower_rad;
    limits.upper_rad[j] = l.upper_rad;
    limits.velocity_rad_s[j] = l.velocity_rad_s;
  }
  return limits;
}

}  // namespace springbok::safety
