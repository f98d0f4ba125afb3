// A plain serial forward kinematics of the generated model, for the model tests' checks
// against numbers the robots' documents state (independent of springbok::dyn).
#pragma once

#include <array>

#include <Eigen/Geometry>

#include "springbok/model/model.hpp"

namespace springbok::test {

inline Eigen::Isometry3d to_iso(const model::Transform& t) {
  Eigen::Isometry3d x = Eigen::Isometry3d::Identity();
  x.linear() = Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>>(t.rotation.data());
  x.translation() = Eigen::Map<const Eigen::Vector3d>(t.translation.data());
  return x;
}

// Frame `frame`'s placement in the base frame for joint angles q.
inline Eigen::Isometry3d frame_in_trunk(int frame, const VecNj& q) {
  std::array<Eigen::Isometry3d, kNb> body;
  body[0] = Eigen::Isometry3d::Identity();
  for (int i = 0; i < kNj; ++i) {
    const auto& j = robot::kJoints[static_cast<std::size_t>(i)];
    const Eigen::Vector3d axis(j.axis[0], j.axis[1], j.axis[2]);
    body[static_cast<std::size_t>(i) + 1] =
        body[static_cast<std::size_t>(j.parent_body)] * to_iso(j.origin) * Eigen::AngleAxisd(q[i], axis);
  }
  const auto& f = robot::kFrames[static_cast<std::size_t>(frame)];
  return body[static_cast<std::size_t>(f.body)] * to_iso(f.placement);
}

}  // namespace springbok::test
