// Forward kinematics, point Jacobians and their Jdot*v, centre of mass.
#include "kernels.hpp"

namespace springbok::dyn {
using namespace detail;

void forward_kinematics(const Model& model, Data& data, const VecNq& q) noexcept {
  placements(model, data, q);
  frame_placements(model, data, q);
}

void point_jacobians(const Model& model, Data& data, const VecNq& q) noexcept {
  forward_kinematics(model, data, q);
  all_point_jacobians(model, data);
}

void point_jacobians_dot_times_v(const Model& model, Data& data, const VecNq& q,
                                 const VecNv& v) noexcept {
  forward_kinematics(model, data, q);
  velocities(data, v);
  accelerations(data, v, nullptr);
  all_point_bias_accelerations(model, data);
}

const Vec3& center_of_mass(const Model& model, Data& data, const VecNq& q) noexcept {
  placements(model, data, q);
  body_inertias(model, data);
  composite_inertias(data, false);
  data.com_world_m = q.head<3>() + data.composite[0].first_moment_kgm / data.composite[0].mass_kg;
  return data.com_world_m;
}

Vec3 static_zmp(const Vec3& com_m, double weight_n, const Vec3& point_m, const Vec3& force_n, const Vec3& torque_nm,
                double ground_z_m, const Vec3& force_at_com_n) noexcept {
  const double at_com = weight_n - force_at_com_n.z();  // what presses at the centre of mass
  const double normal = at_com - force_n.z();
  if (!(normal > 0.0)) return Vec3(com_m.x(), com_m.y(), ground_z_m);
  const double height = point_m.z() - ground_z_m, com_height = com_m.z() - ground_z_m;
  return Vec3((com_m.x() * at_com + height * force_n.x() - point_m.x() * force_n.z() + torque_nm.y() +
               com_height * force_at_com_n.x()) / normal,
              (com_m.y() * at_com + height * force_n.y() - point_m.y() * force_n.z() - torque_nm.x() +
               com_height * force_at_com_n.y()) / normal,
              ground_z_m);
}

const Mat3Nv& jacobian_center_of_mass(const Model& model, Data& data, const VecNq& q) noexcept {
  center_of_mass(model, data, q);
  const double total_mass = data.composite[0].mass_kg;
  // The subtree of joint i moves its mass about the joint axis: column i is
  // (linear momentum of the subtree per unit joint rate) / total mass.
  for (int i = 0; i < kNj; ++i) {
    const SpatialInertia& sub = data.composite[body_of(i)];
    data.J_com.col(kBase + i) =
        (sub.mass_kg * data.joint_moment_arm[i] - sub.first_moment_kgm.cross(data.joint_axis[i])) /
        total_mass;
  }
  const Vec3 com = data.composite[0].first_moment_kgm / total_mass;
  point_jacobian<3>(data, 0, com, data.J_com);
  return data.J_com;
}

const Mat3& composite_inertia(const Model& model, Data& data, const VecNq& q) noexcept {
  placements(model, data, q);
  body_inertias(model, data);
  composite_inertias(data, true);
  const SpatialInertia& all = data.composite[0];
  const Vec3 c = all.first_moment_kgm / all.mass_kg;
  data.com_world_m = q.head<3>() + c;
  data.inertia_com_world_kgm2 =
      all.rotational_kgm2 - all.mass_kg * (c.squaredNorm() * Mat3::Identity() - c * c.transpose());
  return data.inertia_com_world_kgm2;
}

}  // namespace springbok::dyn
