// springbok::dyn::Model from the generated compile-time robot description.
#include "springbok/dynamics/dynamics.hpp"

namespace springbok::dyn {
namespace {

Placement to_placement(const model::Transform& t) noexcept {
  Placement x;
  x.rotation = Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>>(t.rotation.data());
  x.translation = Eigen::Map<const Vec3>(t.translation.data());
  return x;
}

Mat3 to_tensor(const std::array<double, 6>& i) noexcept {  // ixx iyy izz ixy ixz iyz
  Mat3 m;
  m << i[0], i[3], i[4],  //
      i[3], i[1], i[5],   //
      i[4], i[5], i[2];
  return m;
}

}  // namespace

Model::Model(Rotors rotors) noexcept {
  const auto set_body = [this](int b, const model::Inertia& in) {
    mass_kg[b] = in.mass_kg;
    com_body_m[b] = Eigen::Map<const Vec3>(in.com_m.data());
    inertia_com_body[b] = to_tensor(in.inertia_com_kgm2);
    total_mass_kg += in.mass_kg;
  };
  set_body(0, body_inertia(0, rotors));
  for (int i = 0; i < kNj; ++i) {
    joint_placement[i] = to_placement(robot::kJoints[i].origin);
    set_body(i + 1, body_inertia(i + 1, rotors));
  }
  for (int k = 0; k < kNumFrames; ++k) {
    frame_body[k] = robot::kFrames[k].body;
    frame_placement[k] = to_placement(robot::kFrames[k].placement);
  }
}

}  // namespace springbok::dyn
