// Forward dynamics by the articulated body algorithm (Featherstone, "Rigid
// Body Dynamics Algorithms", table 7.1), in frame A (world-aligned, trunk
// origin), with the trunk as a 6-DoF root joint of motion subspace
// blockdiag(R_WB, R_WB).
#include "dispatch.hpp"
#include "kernels.hpp"
#include "springbok/dynamics/small_cholesky.hpp"

namespace springbok::dyn {
using namespace detail;
namespace {

Mat6 to_matrix(const SpatialInertia& in) noexcept {
  const Vec3& h = in.first_moment_kgm;
  Mat3 hx;
  hx << 0.0, -h.z(), h.y(), h.z(), 0.0, -h.x(), -h.y(), h.x(), 0.0;
  Mat6 m;
  m << in.mass_kg * Mat3::Identity(), -hx, hx, in.rotational_kgm2;
  return m;
}

Vec6 motion_subspace(const Data& data, int joint) noexcept {
  Vec6 s;
  s.head<3>() = data.joint_moment_arm[joint];
  s.tail<3>() = data.joint_axis[joint];
  return s;
}

}  // namespace

const VecNv& kernel::aba(const Model& model, Data& data, const VecNq& q, const VecNv& v,
                         const VecNv& tau) noexcept {
  placements(model, data, q);
  body_inertias(model, data);
  velocities(data, v);
  // Pass 1: articulated inertias start as rigid ones, bias forces V x* I V,
  // velocity-product accelerations c = (V x S) qd.
  for (int b = 0; b < kNb; ++b) {
    data.art_inertia[b] = to_matrix(data.inertia[b]);
    Vec3 mom_lin, mom_ang;
    inertia_times(data.inertia[b], data.vel_lin[b], data.vel_ang[b], mom_lin, mom_ang);
    const Vec3& w = data.vel_ang[b];
    data.art_bias[b].head<3>() = w.cross(mom_lin);
    data.art_bias[b].tail<3>() = data.vel_lin[b].cross(mom_lin) + w.cross(mom_ang);
  }
  for (int i = 0; i < kNj; ++i) {
    const int b = body_of(i);
    const double qd = v[kBase + i];
    const Vec3& w = data.vel_ang[b];
    data.aba_c[i].head<3>() = qd * (w.cross(data.joint_moment_arm[i]) + data.vel_lin[b].cross(data.joint_axis[i]));
    data.aba_c[i].tail<3>() = qd * w.cross(data.joint_axis[i]);
  }
  // Pass 2: leaves to root.
  for (int i = kNj - 1; i >= 0; --i) {
    const int b = body_of(i), p = parent_body(i);
    const Vec6 s = motion_subspace(data, i);
    data.aba_u[i].noalias() = data.art_inertia[b] * s;
    data.aba_d[i] = s.dot(data.aba_u[i]);
    data.aba_tau[i] = tau[kBase + i] - s.dot(data.art_bias[b]);
    const Mat6 ia = data.art_inertia[b] - data.aba_u[i] * data.aba_u[i].transpose() / data.aba_d[i];
    data.art_bias[p] += data.art_bias[b] + ia * data.aba_c[i] +
                        data.aba_u[i] * (data.aba_tau[i] / data.aba_d[i]);
    data.art_inertia[p] += ia;
  }
  // Root: IA_0 a_0 + pA_0 = (R tau_lin, R tau_ang); a_0 includes -g.
  const Mat3& r0 = data.body_rotation[0];
  const Vec3 minus_g = -model.gravity_world_m_s2;
  Vec6 rhs;
  rhs.head<3>() = r0 * tau.segment<3>(0) - data.art_bias[0].head<3>();
  rhs.tail<3>() = r0 * tau.segment<3>(3) - data.art_bias[0].tail<3>();
  const Vec6 a0 = SmallCholesky<6>(data.art_inertia[0]).solve(rhs);
  data.acc_lin[0] = a0.head<3>();
  data.acc_ang[0] = a0.tail<3>();
  data.ddq.segment<3>(0).noalias() = r0.transpose() * (data.acc_lin[0] - minus_g);
  data.ddq.segment<3>(3).noalias() = r0.transpose() * data.acc_ang[0];
  // Pass 3: root to leaves.
  for (int i = 0; i < kNj; ++i) {
    const int b = body_of(i), p = parent_body(i);
    Vec6 a = data.aba_c[i];
    a.head<3>() += data.acc_lin[p];
    a.tail<3>() += data.acc_ang[p];
    const double qdd = (data.aba_tau[i] - data.aba_u[i].dot(a)) / data.aba_d[i];
    data.ddq[kBase + i] = qdd;
    data.acc_lin[b] = a.head<3>() + qdd * data.joint_moment_arm[i];
    data.acc_ang[b] = a.tail<3>() + qdd * data.joint_axis[i];
  }
  return data.ddq;
}

}  // namespace springbok::dyn
