// Internal building blocks shared by the algorithms (not part of the API).
// All quantities in "frame A": world-aligned axes, origin at the trunk origin.
// Spatial vectors are split into (linear, angular) 3-vectors, linear first.
#pragma once

#include <array>
#include <cmath>

#include "springbok/dynamics/dynamics.hpp"
#include "springbok/dynamics/sincos.hpp"

namespace springbok::dyn::detail {

inline constexpr int kBase = 6;  // first joint column in v

// Body moved by joint i.
constexpr int body_of(int joint) { return joint + 1; }
constexpr int parent_body(int joint) { return robot::kJoints[joint].parent_body; }

// Support of body b's points: the joints from body b up to the trunk.
// Visits joint indices, child first. rt: no alloc
template <class F>
inline void for_each_support_joint(int body, F&& f) noexcept {
  for (int j = body - 1; j >= 0; j = kParentJoint[j]) f(j);
}

// Trunk placement, body placements, joint axes and moment arms from q.
// rt: no alloc
inline void placements(const Model& model, Data& data, const VecNq& q) noexcept {
  data.body_rotation[0] = Quat(q[6], q[3], q[4], q[5]).normalized().toRotationMatrix();
  data.body_position_m[0].setZero();
  double cos_q[kNj], sin_q[kNj];
  sincos_batch<kNj>(q.data() + 7, sin_q, cos_q);  // all joints at once (vectorised)
#pragma GCC unroll 32  // the tree's indices constant: a chain's rotation stays in registers
  for (int i = 0; i < kNj; ++i) {
    const int b = body_of(i), p = parent_body(i);
    const Placement& x = model.joint_placement[i];
    const Mat3 r_joint = data.body_rotation[p] * x.rotation;
    const double c = cos_q[i], s = sin_q[i];
    Mat3& r = data.body_rotation[b];
    r.col(0) = c * r_joint.col(0) + s * r_joint.col(1);
    r.col(1) = c * r_joint.col(1) - s * r_joint.col(0);
    r.col(2) = r_joint.col(2);
    data.body_position_m[b] = data.body_position_m[p] + data.body_rotation[p] * x.translation;
    data.joint_axis[i] = r.col(2);
    data.joint_moment_arm[i] = data.body_position_m[b].cross(data.joint_axis[i]);
  }
}

// Placements of the named frames (world, and relative to the trunk origin).
// rt: no alloc
inline void frame_placements(const Model& model, Data& data, const VecNq& q) noexcept {
  for (int k = 0; k < kNumFrames; ++k) {
    const int b = model.frame_body[k];
    const Placement& x = model.frame_placement[k];
    data.frame_position_m[k] = data.body_position_m[b] + data.body_rotation[b] * x.translation;
    data.frames[k].rotation = data.body_rotation[b] * x.rotation;
    data.frames[k].translation = q.head<3>() + data.frame_position_m[k];
  }
}

// Body spatial velocities from v. rt: no alloc
inline void velocities(Data& data, const VecNv& v) noexcept {
  const Mat3& r0 = data.body_rotation[0];
  data.vel_lin[0] = r0 * v.segment<3>(0);
  data.vel_ang[0] = r0 * v.segment<3>(3);
  #pragma GCC unroll 64
  for (int i = 0; i < kNj; ++i) {
    const int b = body_of(i), p = parent_body(i);
    const double qd = v[kBase + i];
    data.vel_lin[b] = data.vel_lin[p] + qd * data.joint_moment_arm[i];
    data.vel_ang[b] = data.vel_ang[p] + qd * data.joint_axis[i];
  }
}

// Body spatial accelerations for v and vdot (nullptr: vdot = 0), without
// gravity (newton_euler_backward adds it). Needs velocities(). rt: no alloc
inline void accelerations(Data& data, const VecNv& v, const VecNv* vdot) noexcept {
  const Mat3& r0 = data.body_rotation[0];
  if (vdot != nullptr) {
    data.acc_lin[0] = r0 * vdot->segment<3>(0);
    data.acc_ang[0] = r0 * vdot->segment<3>(3);
  } else {
    data.acc_lin[0].setZero();
    data.acc_ang[0].setZero();
  }
  for (int i = 0; i < kNj; ++i) {
    const int b = body_of(i), p = parent_body(i);
    const double qd = v[kBase + i];
    const Vec3& s_lin = data.joint_moment_arm[i];
    const Vec3& s_ang = data.joint_axis[i];
    const Vec3& w = data.vel_ang[b];
    // (V_b x S) qd: the derivative of the world-fixed motion subspace.
    data.acc_lin[b] = data.acc_lin[p] + qd * (w.cross(s_lin) + data.vel_lin[b].cross(s_ang));
    data.acc_ang[b] = data.acc_ang[p] + qd * w.cross(s_ang);
    if (vdot != nullptr) {
      const double qdd = (*vdot)[kBase + i];
      data.acc_lin[b] += qdd * s_lin;
      data.acc_ang[b] += qdd * s_ang;
    }
  }
}

// Body inertias in frame A. rt: no alloc
inline void body_inertias(const Model& model, Data& data) noexcept {
  for (int b = 0; b < kNb; ++b) {
    const Mat3& r = data.body_rotation[b];
    const double m = model.mass_kg[b];
    const Vec3 c = data.body_position_m[b] + r * model.com_body_m[b];
    SpatialInertia& in = data.inertia[b];
    in.mass_kg = m;
    in.first_moment_kgm = m * c;
    in.rotational_kgm2.noalias() = r * model.inertia_com_body[b] * r.transpose();
    in.rotational_kgm2 += m * (c.squaredNorm() * Mat3::Identity() - c * c.transpose());
  }
}

// Subtree (composite) inertias: data.composite[b] = sum over b's subtree. Only
// mass and first moment when `rotational` is false. rt: no alloc
inline void composite_inertias(Data& data, bool rotational) noexcept {
  for (int b = 0; b < kNb; ++b) data.composite[b] = data.inertia[b];
  // Unrolled, the tree's indices are constants: the compiler keeps a chain's running sum in
  // registers instead of storing and reloading it at every joint.
#pragma GCC unroll 32
  for (int i = kNj - 1; i >= 0; --i) {
    SpatialInertia& parent = data.composite[parent_body(i)];
    const SpatialInertia& child = data.composite[body_of(i)];
    parent.mass_kg += child.mass_kg;
    parent.first_moment_kgm += child.first_moment_kgm;
    if (rotational) parent.rotational_kgm2 += child.rotational_kgm2;
  }
}

// Spatial inertia times a spatial motion (v, w): momentum (f, n). rt: no alloc
inline void inertia_times(const SpatialInertia& in, const Vec3& v, const Vec3& w, Vec3& f,
                          Vec3& n) noexcept {
  f = in.mass_kg * v - in.first_moment_kgm.cross(w);
  n = in.rotational_kgm2 * w + in.first_moment_kgm.cross(v);
}

// Body forces I (a - g) + V x* I V summed over each subtree (needs
// accelerations()), then the generalized forces S^T F into tau. `minus_g` is
// the uniform acceleration of the gravity trick (-g, or 0). rt: no alloc
inline void newton_euler_backward(Data& data, const Vec3& minus_g, VecNv& tau) noexcept {
  #pragma GCC unroll 64
  for (int b = 0; b < kNb; ++b) {
    Vec3 f, n, mom_lin, mom_ang;
    inertia_times(data.inertia[b], data.acc_lin[b] + minus_g, data.acc_ang[b], f, n);
    inertia_times(data.inertia[b], data.vel_lin[b], data.vel_ang[b], mom_lin, mom_ang);
    const Vec3& vl = data.vel_lin[b];
    const Vec3& w = data.vel_ang[b];
    data.force_lin[b] = f + w.cross(mom_lin);
    data.force_ang[b] = n + vl.cross(mom_lin) + w.cross(mom_ang);
  }
  #pragma GCC unroll 64
  for (int i = kNj - 1; i >= 0; --i) {
    const int b = body_of(i), p = parent_body(i);
    tau[kBase + i] = data.joint_moment_arm[i].dot(data.force_lin[b]) +
                     data.joint_axis[i].dot(data.force_ang[b]);
    data.force_lin[p] += data.force_lin[b];
    data.force_ang[p] += data.force_ang[b];
  }
  const Mat3& r0 = data.body_rotation[0];
  tau.segment<3>(0).noalias() = r0.transpose() * data.force_lin[0];
  tau.segment<3>(3).noalias() = r0.transpose() * data.force_ang[0];
}

// The (ancestor-or-self j, joint i) pairs of the tree, j <= i: the joint block of M that the
// tree does not make zero (52 of 361 for the quadruped manipulator), ordered by i then j.
struct SupportPair {
  int j, i;
};
inline constexpr int kSupportPairs = [] {
  int n = 0;
  for (int i = 0; i < kNj; ++i)
    for (int j = i; j >= 0; j = kParentJoint[j]) ++n;
  return n;
}();
inline constexpr std::array<SupportPair, kSupportPairs> kSupport = [] {
  std::array<SupportPair, kSupportPairs> pairs{};
  int n = 0;
  for (int i = 0; i < kNj; ++i)
    for (int j = i; j >= 0; j = kParentJoint[j]) pairs[static_cast<std::size_t>(n++)] = {j, i};
  return pairs;
}();

// Joint-space inertia matrix from the composite inertias: per joint the composite's
// momentum F_i = I^C_i S_i, then M_ji = S_j . F_i over the support pairs (one flat loop of
// 6-term dots, the tree unrolled at compile time) and the trunk rows [R0' f_i; R0' n_i].
// rt: no alloc
inline void mass_matrix(Data& data) noexcept {
  MatNv& mm = data.M;
  const Mat3& r0 = data.body_rotation[0];
  Eigen::Matrix<double, 6, kNj> motion, momentum;  // S_i = [moment arm; axis], F_i = [f; n]
  for (int i = 0; i < kNj; ++i) {
    motion.col(i).head<3>() = data.joint_moment_arm[i];
    motion.col(i).tail<3>() = data.joint_axis[i];
    Vec3 f, n;
    inertia_times(data.composite[body_of(i)], data.joint_moment_arm[i], data.joint_axis[i], f, n);
    momentum.col(i).head<3>() = f;
    momentum.col(i).tail<3>() = n;
  }
  for (const SupportPair& p : kSupport) {
    const double mji = motion.col(p.j).dot(momentum.col(p.i));
    mm(kBase + p.j, kBase + p.i) = mji;
    mm(kBase + p.i, kBase + p.j) = mji;
  }
  mm.block<3, kNj>(0, kBase).noalias() = r0.transpose() * momentum.topRows<3>();
  mm.block<3, kNj>(3, kBase).noalias() = r0.transpose() * momentum.bottomRows<3>();
  mm.block<kNj, 6>(kBase, 0) = mm.block<6, kNj>(0, kBase).transpose();
  // Trunk block: the whole robot's inertia about the trunk origin, trunk axes.
  const SpatialInertia& all = data.composite[0];
  const Vec3 h = r0.transpose() * all.first_moment_kgm;
  Mat3 hx;
  hx << 0.0, -h.z(), h.y(), h.z(), 0.0, -h.x(), -h.y(), h.x(), 0.0;
  mm.block<3, 3>(0, 0) = all.mass_kg * Mat3::Identity();
  mm.block<3, 3>(0, 3) = -hx;
  mm.block<3, 3>(3, 0) = hx;
  const Mat3 rot = r0.transpose() * all.rotational_kgm2 * r0;
  mm.block<3, 3>(3, 3) = 0.5 * (rot + rot.transpose());  // exactly symmetric
}

// Linear part of the world-aligned Jacobian of the point at `r` (relative to
// the trunk origin) on body b into rows 0..2 of `jac`, and the angular part into
// rows 3..5 when Rows == 6. rt: no alloc
template <int Rows>
inline void point_jacobian(const Data& data, int body, const Vec3& r,
                           Eigen::Matrix<double, Rows, kNv>& jac) noexcept {
  const Mat3& r0 = data.body_rotation[0];
  jac.template block<3, 3>(0, 0) = r0;
  for (int k = 0; k < 3; ++k) jac.template block<3, 1>(0, 3 + k) = r0.col(k).cross(r);
  if constexpr (Rows == 6) {
    jac.template block<3, 3>(3, 0).setZero();
    jac.template block<3, 3>(3, 3) = r0;
  }
  for_each_support_joint(body, [&](int j) {
    const Vec3& a = data.joint_axis[j];
    jac.template block<3, 1>(0, kBase + j) = data.joint_moment_arm[j] + a.cross(r);
    if constexpr (Rows == 6) jac.template block<3, 1>(3, kBase + j) = a;
  });
}

// Classical acceleration of the point at `r` on body b (needs velocities()
// and accelerations()). rt: no alloc
inline Vec3 point_classical_acceleration(const Data& data, int body, const Vec3& r) noexcept {
  const Vec3& w = data.vel_ang[body];
  const Vec3 v_point = data.vel_lin[body] + w.cross(r);
  return data.acc_lin[body] + data.acc_ang[body].cross(r) + w.cross(v_point);
}

// The 5 point Jacobians (needs placements() and frame_placements()). rt: no alloc
inline void all_point_jacobians(const Model& model, Data& data) noexcept {
  for (int f = 0; f < kFeet; ++f) {
    const int k = kFootFrames[f];
    point_jacobian<3>(data, model.frame_body[k], data.frame_position_m[k], data.J_feet[f]);
  }
  point_jacobian<6>(data, model.frame_body[kEeFrame], data.frame_position_m[kEeFrame], data.J_ee);
}

// The 5 classical Jdot*v (needs accelerations() with vdot = 0, no gravity).
// rt: no alloc
inline void all_point_bias_accelerations(const Model& model, Data& data) noexcept {
  for (int f = 0; f < kFeet; ++f) {
    const int k = kFootFrames[f];
    data.dJv_feet[f] = point_classical_acceleration(data, model.frame_body[k], data.frame_position_m[k]);
  }
  const int b = model.frame_body[kEeFrame];
  data.dJv_ee.head<3>() = point_classical_acceleration(data, b, data.frame_position_m[kEeFrame]);
  data.dJv_ee.tail<3>() = data.acc_ang[b];
}

}  // namespace springbok::dyn::detail
