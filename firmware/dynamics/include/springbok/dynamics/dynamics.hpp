// springbok::dyn — fixed-size, allocation-free rigid-body dynamics of the
// robot this build is for (firmware/model: a quadruped with an arm), Pinocchio-style
// Model / Data split:
//
//   const springbok::dyn::Model model;            // once, at start-up
//   auto data = std::make_unique<springbok::dyn::Data>();   // once (~25 kB)
//   springbok::dyn::compute_tick(model, *data, q, v);       // each tick
//   use data->M, data->nle, data->J_feet[f], data->dJv_ee, ...
//
// Conventions (../shared/robot/CONVENTIONS.md, Pinocchio free-flyer):
//   q (26) = [p_WB (3), quaternion x y z w of R_WB (4), 19 joint angles]
//   v (25) = [v_B (3), w_B (3) in the TRUNK frame (LOCAL), 19 joint rates]
//   vdot   = d/dt of the components of v (vdot[0:3] = d/dt v_B).
//   M vdot + nle = tau; tau[0:3] force on the trunk (trunk axes),
//   tau[3:6] moment about the trunk origin (trunk axes), tau[6:] joint torques.
//   Gravity (0, 0, -9.81) m/s^2 in world. The quaternion is normalised
//   internally (callers validate that it is near unit norm).
//   Point Jacobians are world-aligned and taken at the point ("LOCAL_WORLD_
//   ALIGNED"), linear rows first; dJv = Jdot v is the CLASSICAL acceleration
//   of the point for vdot = 0 (includes w x v).
//
// Every algorithm takes the full state it needs and recomputes the kinematics
// it depends on, so calls can be made in any order. All functions are
// noexcept, never allocate and never throw (// rt: no alloc, no block).
// Results are written into Data and also returned by reference.
//
// Internally everything is expressed in a world-aligned frame whose origin is
// the trunk origin at the current instant ("frame A"): joint motion subspaces,
// velocities and inertias are then summed along the tree with no spatial
// transforms (Featherstone, ch. 6, "world coordinates"), and a leg or the arm
// only ever touches its own columns of M and of the Jacobians.
#pragma once

#include <array>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "springbok/model/model.hpp"

namespace springbok::dyn {

inline constexpr int kNumFrames = robot::kNumFrames;
inline constexpr int kNumPoints = kFeet + 1;  // the 4 feet and the end-effector

// Compile-time tree topology. parent_joint(i) is the joint moving the parent
// body of joint i's body, -1 when the parent is the trunk.
inline constexpr std::array<int, kNj> kParentJoint = [] {
  std::array<int, kNj> p{};
  for (int i = 0; i < kNj; ++i) p[i] = robot::kJoints[i].parent_body - 1;
  return p;
}();

// The dynamics specialise on revolute joints about +z of their joint frame
// (urdf2model turns every joint's frame so: tools/urdf2model/urdf_tree.hpp); a
// model with another axis must not compile silently into wrong numbers.
static_assert([] {
  for (int i = 0; i < kNj; ++i) {
    const auto& j = robot::kJoints[i];
    if (j.axis[0] != 0.0 || j.axis[1] != 0.0 || j.axis[2] != 1.0) return false;
    if (j.parent_body < 0 || j.parent_body > i) return false;
  }
  return true;
}(), "springbok::dyn needs every joint axis = +z and parents before children");

// A rigid transform: p_parent = rotation * p_child + translation.
struct Placement {
  Mat3 rotation = Mat3::Identity();
  Vec3 translation = Vec3::Zero();
};

// Constant robot description in the form the algorithms use; built once from
// the generated springbok::robot specs.
struct Model {
  // The robot with the actuators' rotors (springbok::kRotorInertia_kgm2, what the controller
  // and the simulated robot use) or without (Rotors::none: the URDF alone, as the reference
  // states of ../shared/robot and Pinocchio have it).
  explicit Model(Rotors rotors = Rotors::included) noexcept;

  std::array<Placement, kNj> joint_placement;  // joint frame in parent body frame at q = 0
  std::array<double, kNb> mass_kg{};
  std::array<Vec3, kNb> com_body_m;            // centre of mass, body frame
  std::array<Mat3, kNb> inertia_com_body;      // about the COM, body axes [kg m^2]
  std::array<int, kNumFrames> frame_body{};
  std::array<Placement, kNumFrames> frame_placement;  // frame in its body frame
  double total_mass_kg = 0.0;
  Vec3 gravity_world_m_s2{0.0, 0.0, -kGravity_m_s2};
};

// Rigid-body inertia in world-aligned axes about the trunk origin ("frame A"):
// mass, first moment h = m c (c the COM relative to the trunk origin) and the
// rotational inertia about the trunk origin.
struct SpatialInertia {
  double mass_kg = 0.0;
  Vec3 first_moment_kgm = Vec3::Zero();
  Mat3 rotational_kgm2 = Mat3::Zero();
};

// Workspace and results. Zero-initialised; columns of the Jacobians and
// blocks of M that the tree makes structurally zero are never written.
struct Data {
  // ---- results ----------------------------------------------------------
  MatNv M = MatNv::Zero();        // joint-space inertia matrix (crba, compute_tick)
  VecNv nle = VecNv::Zero();      // h = C(q,v) v + g(q) (nonlinear_effects, compute_tick)
  VecNv g = VecNv::Zero();        // g(q) (gravity)
  VecNv tau = VecNv::Zero();      // RNEA(q, v, vdot) (rnea)
  VecNv ddq = VecNv::Zero();      // forward dynamics M^-1 (tau - h) (aba)
  std::array<Mat3Nv, kFeet> J_feet{Mat3Nv::Zero(), Mat3Nv::Zero(), Mat3Nv::Zero(), Mat3Nv::Zero()};
  Mat6Nv J_ee = Mat6Nv::Zero();   // [linear; angular] at the EE origin, world axes
  std::array<Vec3, kFeet> dJv_feet{Vec3::Zero(), Vec3::Zero(), Vec3::Zero(), Vec3::Zero()};
  Vec6 dJv_ee = Vec6::Zero();     // [classical linear acc; angular acc], world axes
  // Placements in world of every named frame (index robot::kFrame_*: feet,
  // EE kEeFrame, IMU kImuFrame, arm base), filled by forward_kinematics.
  std::array<Placement, kNumFrames> frames;
  // Centre of mass (world) and its Jacobian (center_of_mass, jacobian_center_of_mass).
  Vec3 com_world_m = Vec3::Zero();
  Mat3Nv J_com = Mat3Nv::Zero();
  // The whole robot as one rigid body at q (composite_inertia): about its
  // COM, world axes. (About the trunk origin in trunk axes it is M[0:6,0:6].)
  Mat3 inertia_com_world_kgm2 = Mat3::Zero();

  // ---- workspace (per body b = 0..19; joint i moves body i + 1) ----------
  std::array<Mat3, kNb> body_rotation;      // R_W,body
  std::array<Vec3, kNb> body_position_m;    // body origin relative to the trunk origin, world axes
  std::array<Vec3, kNj> joint_axis;         // joint axis in world (motion subspace, angular)
  std::array<Vec3, kNj> joint_moment_arm;   // r_joint x axis (motion subspace, linear, frame A)
  std::array<Vec3, kNumFrames> frame_position_m;  // frame origin relative to the trunk origin
  std::array<Vec3, kNb> vel_lin, vel_ang;   // body spatial velocity in frame A
  std::array<Vec3, kNb> acc_lin, acc_ang;   // body spatial acceleration in frame A
  std::array<Vec3, kNb> force_lin, force_ang;  // body / subtree spatial force in frame A
  std::array<SpatialInertia, kNb> inertia;     // body inertia in frame A
  std::array<SpatialInertia, kNb> composite;   // subtree inertia in frame A
  // aba workspace
  std::array<Mat6, kNb> art_inertia;
  std::array<Vec6, kNb> art_bias;
  std::array<Vec6, kNj> aba_u, aba_c;
  std::array<double, kNj> aba_d{}, aba_tau{};
};

// ---- kinematics --------------------------------------------------------------
// Placements of every body and of every named frame (data.frames). rt: no alloc
void forward_kinematics(const Model& model, Data& data, const VecNq& q) noexcept;

// World-aligned point Jacobians of the 4 feet (3x25) and the EE (6x25). rt: no alloc
void point_jacobians(const Model& model, Data& data, const VecNq& q) noexcept;

// Classical Jdot*v of the 4 feet and the EE (data.dJv_feet, data.dJv_ee). rt: no alloc
void point_jacobians_dot_times_v(const Model& model, Data& data, const VecNq& q,
                                 const VecNv& v) noexcept;

// Centre of mass in world. rt: no alloc
const Vec3& center_of_mass(const Model& model, Data& data, const VecNq& q) noexcept;

// The static zero-moment point on the ground plane z = ground_z_m (world): where the
// ground's resultant must act to balance the weight W at the centre of mass c, an
// external wrench (force F, torque T) applied at the point p, and a force G at the centre
// of mass (Vukobratovic's ZMP with the accelerations dropped):
//   x (W - F_z - G_z) = c_x (W - G_z) + (p_z - z_g) F_x - p_x F_z + T_y + (c_z - z_g) G_x
//   y (W - F_z - G_z) = c_y (W - G_z) + (p_z - z_g) F_y - p_y F_z - T_x + (c_z - z_g) G_y
// Returns c_xy when W - F_z - G_z is not positive (the load does not press on the ground).
// rt: no alloc
Vec3 static_zmp(const Vec3& com_m, double weight_n, const Vec3& point_m, const Vec3& force_n, const Vec3& torque_nm,
                double ground_z_m, const Vec3& force_at_com_n = Vec3::Zero()) noexcept;

// COM position (data.com_world_m) and its Jacobian d com / dt = J_com v. rt: no alloc
const Mat3Nv& jacobian_center_of_mass(const Model& model, Data& data, const VecNq& q) noexcept;

// The whole robot's composite rigid-body inertia about its COM, world axes
// (also sets data.com_world_m). rt: no alloc
const Mat3& composite_inertia(const Model& model, Data& data, const VecNq& q) noexcept;

// ---- dynamics ----------------------------------------------------------------
// Joint-space inertia matrix (composite rigid body algorithm), symmetric. rt: no alloc
const MatNv& crba(const Model& model, Data& data, const VecNq& q) noexcept;

// Inverse dynamics tau = M vdot + h (recursive Newton-Euler). rt: no alloc
const VecNv& rnea(const Model& model, Data& data, const VecNq& q, const VecNv& v,
                  const VecNv& vdot) noexcept;

// h = C(q,v) v + g(q) = rnea(q, v, 0). rt: no alloc
const VecNv& nonlinear_effects(const Model& model, Data& data, const VecNq& q,
                               const VecNv& v) noexcept;

// g(q) = rnea(q, 0, 0). rt: no alloc
const VecNv& gravity(const Model& model, Data& data, const VecNq& q) noexcept;

// Forward dynamics vdot = M^-1 (tau - h) (articulated body algorithm). rt: no alloc
const VecNv& aba(const Model& model, Data& data, const VecNq& q, const VecNv& v,
                 const VecNv& tau) noexcept;

// Everything one controller tick needs, in one pass sharing the work:
// forward_kinematics (data.frames), M, nle, the 5 point Jacobians and the 5
// Jdot*v. rt: no alloc
void compute_tick(const Model& model, Data& data, const VecNq& q, const VecNv& v) noexcept;

}  // namespace springbok::dyn
