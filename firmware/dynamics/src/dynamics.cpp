// Mass matrix (CRBA), inverse dynamics (RNEA), nonlinear effects, gravity,
// and the one-pass controller tick.
#include "dispatch.hpp"
#include "kernels.hpp"

namespace springbok::dyn {
using namespace detail;

const MatNv& kernel::crba(const Model& model, Data& data, const VecNq& q) noexcept {
  placements(model, data, q);
  body_inertias(model, data);
  composite_inertias(data, true);
  mass_matrix(data);
  return data.M;
}

const VecNv& kernel::rnea(const Model& model, Data& data, const VecNq& q, const VecNv& v,
                          const VecNv& vdot) noexcept {
  placements(model, data, q);
  body_inertias(model, data);
  velocities(data, v);
  accelerations(data, v, &vdot);
  newton_euler_backward(data, -model.gravity_world_m_s2, data.tau);
  return data.tau;
}

const VecNv& nonlinear_effects(const Model& model, Data& data, const VecNq& q,
                               const VecNv& v) noexcept {
  placements(model, data, q);
  body_inertias(model, data);
  velocities(data, v);
  accelerations(data, v, nullptr);
  newton_euler_backward(data, -model.gravity_world_m_s2, data.nle);
  return data.nle;
}

const VecNv& gravity(const Model& model, Data& data, const VecNq& q) noexcept {
  placements(model, data, q);
  body_inertias(model, data);
  composite_inertias(data, false);
  // At rest each body's force is its weight: the subtree of joint i carries
  // (m_sub (-g), h_sub x (-g)) in frame A.
  const Vec3 minus_g = -model.gravity_world_m_s2;
  for (int i = 0; i < kNj; ++i) {
    const SpatialInertia& sub = data.composite[body_of(i)];
    data.g[kBase + i] = sub.mass_kg * data.joint_moment_arm[i].dot(minus_g) +
                        data.joint_axis[i].dot(sub.first_moment_kgm.cross(minus_g));
  }
  const SpatialInertia& all = data.composite[0];
  const Mat3& r0 = data.body_rotation[0];
  data.g.segment<3>(0).noalias() = all.mass_kg * (r0.transpose() * minus_g);
  data.g.segment<3>(3).noalias() = r0.transpose() * all.first_moment_kgm.cross(minus_g);
  return data.g;
}

void kernel::compute_tick(const Model& model, Data& data, const VecNq& q, const VecNv& v) noexcept {
  placements(model, data, q);
  frame_placements(model, data, q);
  body_inertias(model, data);
  velocities(data, v);
  accelerations(data, v, nullptr);
  all_point_bias_accelerations(model, data);
  all_point_jacobians(model, data);
  newton_euler_backward(data, -model.gravity_world_m_s2, data.nle);
  composite_inertias(data, true);
  mass_matrix(data);
}

}  // namespace springbok::dyn
