// The robot's state as the controller sees it in one tick: the base estimator
// (or, in the simulation tool only, the simulator's ground truth) writes it; the
// gait and the whole-body controller read it. One value type, one orientation
// conversion per tick.
#pragma once

#include <array>

#include "springbok/model/model.hpp"

namespace springbok {

// Which feet are on the ground (index: Foot), the one stance type of every layer.
using Stance = std::array<bool, kFeet>;
inline constexpr Stance kAllFeet{true, true, true, true};

struct RobotState {
  VecNq q = [] {
    VecNq q0 = VecNq::Zero();
    q0[6] = 1.0;  // identity orientation (quaternion x y z w)
    return q0;
  }();
  VecNv v = VecNv::Zero();
  Mat3 rotation_wb = Mat3::Identity();  // R_WB of q's quaternion (normalised): set_rotation_from_q()
  Stance stance = kAllFeet;             // the feet the controller treats as on the ground this tick

  // rotation_wb from q[3:7], the one quaternion -> matrix conversion of a tick. rt: no alloc
  void set_rotation_from_q() noexcept {
    rotation_wb = Quat(q[6], q[3], q[4], q[5]).normalized().toRotationMatrix();
  }
};

}  // namespace springbok
