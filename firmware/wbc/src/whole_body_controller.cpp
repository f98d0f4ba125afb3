#include "springbok/wbc/whole_body_controller.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

#include <Eigen/LU>

namespace springbok::wbc {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
// base_task: the hand spring's pull on the base is limited to the push after an overload of
// the arm until it is within this of the push again [N].
constexpr double kCouplingReleaseMarginN = 10.0;
// support_limit: the natural frequency of its spring at the template's base mass [rad/s],
// and the ticks the stance must have held before it acts (standing, not stepping: a trot's
// four-feet phases last at most 0.11 s, d_f 0.65 at 1.4 Hz).
constexpr double kSupportOmega = 15.0;
constexpr int kSupportSettleTicks = 250;

int foot_var(int foot) noexcept { return kNv + kFootVars * foot; }

// The Cholesky factor of the QP Hessian build_qp assembles: dense in the base block
// (first 6 variables), diagonal elsewhere (build_qp writes nothing else), so L is the
// 6x6 block's factor and the square roots of the other diagonal entries (column-major
// lower, leading dim kQpVars; only the lower triangle's base block and diagonal are
// written: `lower` holds zeros elsewhere). False (the solver then factors H itself) when
// H is not positive definite. Were H ever of another shape, the solver would refuse the
// factor (its couplings are checked against H's) and the tick would fail.
// rt: no alloc
bool factor_qp_hessian(const WbcSolver::ProblemType& p, std::array<double, static_cast<std::size_t>(kQpVars) * kQpVars>& lower) noexcept {
  constexpr int kBlock = 6;
  const Eigen::Map<const Eigen::Matrix<double, kQpVars, kQpVars>> hess(p.hessian.data());
  Eigen::Map<Eigen::Matrix<double, kQpVars, kQpVars>> factor(lower.data());
  const SmallCholesky<kBlock> block(hess.topLeftCorner<kBlock, kBlock>());
  if (!block.ok()) return false;
  factor.topLeftCorner<kBlock, kBlock>().triangularView<Eigen::Lower>() = block.matrix_l();
  for (int j = kBlock; j < kQpVars; ++j) {
    if (!(hess(j, j) > 0.0)) return false;
    factor(j, j) = std::sqrt(hess(j, j));
  }
  return true;
}

}  // namespace

WholeBodyController::WholeBodyController(const WbcParams& params)
    : params_(params),
      solver_(std::make_unique<WbcSolver>()),
      problem_(std::make_unique<WbcSolver::ProblemType>()),
      result_(std::make_unique<WbcSolver::ResultType>()),
      warm_start_(std::make_unique<qp::ActiveSet<kQpIn>>()),
      switch_hint_(std::make_unique<qp::ActiveSet<kQpIn>>()),
      mode_sets_(std::make_unique<std::array<qp::ActiveSet<kQpIn>, 1 << kFeet>>()),
      hessian_factor_(std::make_unique<HessianFactor>()) {}

WholeBodyController::~WholeBodyController() = default;

void WholeBodyController::set_reference(const VecNq& q, dyn::Data& data) noexcept {
  dyn::forward_kinematics(model_, data, q);
  reference_ = WbcReference{};
  reference_.base_position_m = q.head<3>();
  reference_.base_rotation = Quat(q[6], q[3], q[4], q[5]).normalized().toRotationMatrix();
  reference_.ee_position_m = data.frames[kEeFrame].translation;
  reference_.ee_rotation = data.frames[kEeFrame].rotation;
  engaged_ = reference_;
  if (!params_.pin_arm_posture) params_.arm_posture_rad = q.segment<kArmDofs>(7 + kFirstArmJoint);
  // I_b (the rotational template's when it is on): the composite rotational inertia about
  // the robot's COM, in trunk axes, where no positive value is given.
  const Vec3& given = params_.rotational_template_enabled ? params_.rotational_template.inertia_base_kgm2
                                                          : params_.base_rot_inertia_kgm2;
  const Mat3 inertia_world = dyn::composite_inertia(model_, data, q);
  const Mat3 inertia_trunk = reference_.base_rotation.transpose() * inertia_world * reference_.base_rotation;
  for (int i = 0; i < 3; ++i) base_inertia_diag_[i] = given[i] > 0.0 ? given[i] : inertia_trunk(i, i);
  have_warm_start_ = false;
  have_mode_set_.fill(false);
  out_.arm_overloaded = false;
  coupling_limited_ = false;
  stance_ticks_ = 0;
}

void WholeBodyController::move_reference(const PlanarMotion& m) noexcept {
  const Mat3 turn = Eigen::AngleAxisd(m.yaw_rad, Vec3::UnitZ()).toRotationMatrix();
  const Vec3 yaw_rate = m.yaw_rate_rad_s * Vec3::UnitZ();
  // The rest pose's horizontal frame: the engaged heading, turned.
  const Mat3& r0 = engaged_.base_rotation;
  const Mat3 heading = turn * Eigen::AngleAxisd(std::atan2(r0(1, 0), r0(0, 0)), Vec3::UnitZ()).toRotationMatrix();
  const Vec3 hand_velocity = heading * m.hand_velocity_m_s;
  // The base rest point to the hand's: the engaged arm, turned, plus the hand's offset.
  const Vec3 arm = turn * (engaged_.ee_position_m - engaged_.base_position_m) + heading * m.hand_offset_m;
  reference_.base_position_m = engaged_.base_position_m + m.offset_m;
  reference_.base_rotation = turn * engaged_.base_rotation;
  reference_.ee_position_m = reference_.base_position_m + arm;
  // The hand's rest orientation: the engaged one turned by exp(phi) in the rest pose's horizontal
  // frame, R = heading exp(phi) heading0^T R_e0 (heading = turn heading0). Its angular velocity
  // is the turn's plus the heading's J_l(phi) phi'.
  const Vec3& phi = m.hand_rotation_rad;
  const Vec3& phi_rate = m.hand_rotation_rate_rad_s;
  const Mat3 hand_turn = phi.squaredNorm() > 0.0 ? Mat3(Eigen::AngleAxisd(phi.norm(), phi.normalized())) : Mat3::Identity();
  const Mat3 jl = so3_left_jacobian(phi);
  const Vec3 w_hand = heading * (jl * phi_rate);
  const Vec3 jl_rate_phi = so3_left_jacobian_rate(phi, phi_rate);
  reference_.ee_rotation = heading * hand_turn * (turn.transpose() * heading).transpose() * engaged_.ee_rotation;
  reference_.ee_angular_velocity_rad_s = yaw_rate + w_hand;
  reference_.ee_angular_acceleration_rad_s2 = m.yaw_acceleration_rad_s2 * Vec3::UnitZ() + yaw_rate.cross(w_hand) +
                                              heading * (jl * m.hand_rotation_acceleration_rad_s2 + jl_rate_phi);
  reference_.base_velocity_m_s = m.velocity_m_s;
  reference_.base_acceleration_m_s2 = m.acceleration_m_s2;
  reference_.base_angular_velocity_rad_s = yaw_rate;
  reference_.ee_velocity_m_s = m.velocity_m_s + yaw_rate.cross(arm) + hand_velocity;
  reference_.ee_acceleration_m_s2 = m.acceleration_m_s2 + m.yaw_acceleration_rad_s2 * Vec3::UnitZ().cross(arm) +
                                    yaw_rate.cross(yaw_rate.cross(arm)) + 2.0 * yaw_rate.cross(hand_velocity) +
                                    heading * m.hand_acceleration_m_s2;
}

// The support limit: the template's base gives way to a push only as far as the feet can
// hold the robot up. The static centre of pressure of the whole robot under gravity, the
// measured hand wrench and the unmeasured pushes (dyn::static_zmp: W_e at the wrist sensor's
// origin, WbcInput::unmeasured_force_world_n at the centre of mass, the ground at the stance
// feet's contact points) must stay support_margin_m inside the stance feet's polygon (three or
// four feet). Within the margin of an edge, a spring-damper on the base along the edge's inward
// normal n (natural frequency kSupportOmega at the template's base mass, critically damped)
// pushes back:
//   dF = n clamp(M_b w^2 (margin - s) - 2 M_b w (xd_b . n), 0, M_b g),  s the distance inside the edge,
// and the base stops where the push's moment leaves the feet room. Only while standing: the
// stance unchanged for kSupportSettleTicks and no stance foot's force ramping: a trot's
// support is a diagonal most of the time, and limiting it in its short four-feet phases
// throws its base about. Why it is needed and what it holds: firmware/control/README.md.
void WholeBodyController::support_limit(const WbcInput& in, const dyn::Data& d, const Vec3& base_vel_world,
                                        Vec3& force) noexcept {
  out_.support_limited = false;
  out_.support_distance_m = kInf;
  out_.capture_distance_m = kInf;
  if (!(params_.support_margin_m > 0.0) || stance_ticks_ < kSupportSettleTicks) return;
  std::array<Eigen::Vector2d, kFeet> pts;
  int count = 0;
  double ground_z = 0.0;
  for (int f = 0; f < kFeet; ++f) {
    if (!in.state.stance[f]) continue;
    if (in.normal_force_cap_n[f] < params_.normal_force_max_n) return;  // its force ramping: stepping
    const Vec3 c = d.frames[kFootFrames[f]].translation - params_.foot_contact_radius_m * Vec3::UnitZ();
    pts[count++] = c.head<2>();
    ground_z += c.z();
  }
  if (count < 3) return;
  ground_z /= count;
  const dyn::SpatialInertia& whole = d.composite[0];
  const double weight_n = whole.mass_kg * kGravity_m_s2;
  const Vec3& unmeasured = in.unmeasured_force_world_n;
  if (!(weight_n - wrench_ee_world_.head<3>().z() - unmeasured.z() > 0.1 * weight_n)) return;  // lifted off its feet: no centre of pressure
  const Vec3 com = in.state.q.head<3>() + whole.first_moment_kgm / whole.mass_kg;
  const Eigen::Vector2d cop = dyn::static_zmp(com, weight_n, d.frames[kWristFtFrame].translation, wrench_ee_world_.head<3>(),
                                              wrench_ee_world_.tail<3>(), ground_z, unmeasured)
                                  .head<2>();
  // The polygon counter-clockwise: the points by their angle about their mean.
  Eigen::Vector2d mean = Eigen::Vector2d::Zero();
  for (int k = 0; k < count; ++k) mean += pts[k];
  mean /= count;
  std::array<double, kFeet> angle{};
  std::array<int, kFeet> order{};
  for (int k = 0; k < count; ++k) {
    angle[k] = std::atan2(pts[k].y() - mean.y(), pts[k].x() - mean.x());
    order[k] = k;
  }
  std::sort(order.begin(), order.begin() + count, [&angle](int a, int b) noexcept { return angle[a] < angle[b]; });
  // The capture point of that centre of pressure: where it would have to be for the trunk's
  // horizontal velocity to die out (a linear inverted pendulum of the centre of mass's height,
  // omega = sqrt(g / h)). The static centre of pressure leaves the trunk's motion out: a
  // backward push unloads the front feet while it is still 7 cm inside.
  const double height_m = com.z() - ground_z;
  const Eigen::Vector2d capture =
      cop + (height_m > 0.0 ? std::sqrt(height_m / kGravity_m_s2) : 0.0) * base_vel_world.head<2>();
  double inside_m = kInf, capture_inside_m = kInf;
  Eigen::Vector2d normal = Eigen::Vector2d::Zero();
  for (int k = 0; k < count; ++k) {
    const Eigen::Vector2d& a = pts[order[k]];
    const Eigen::Vector2d edge = pts[order[(k + 1) % count]] - a;
    const double length = edge.norm();
    if (!(length > 1e-6)) continue;
    const Eigen::Vector2d n(-edge.y() / length, edge.x() / length);  // inward (left of a CCW edge)
    const double s = n.dot(cop - a);
    if (s < inside_m) {
      inside_m = s;
      normal = n;
    }
    capture_inside_m = std::min(capture_inside_m, n.dot(capture - a));
  }
  out_.support_distance_m = inside_m;
  out_.capture_distance_m = capture_inside_m;
  if (!(inside_m < params_.support_margin_m)) return;
  const double mass = params_.template_params.mass_base_kg.head<2>().mean();
  const double push_n = mass * kSupportOmega * kSupportOmega * (params_.support_margin_m - inside_m) -
                        2.0 * mass * kSupportOmega * normal.dot(base_vel_world.head<2>() - reference_.base_velocity_m_s.head<2>());
  if (!(push_n > 0.0)) return;
  // At most what accelerates the template's base by 1 g (a CoP 4.4 cm past the margin): a
  // push beyond the robot's tipping limit is not answered by flinging the trunk.
  force.head<2>() += std::min(push_n, mass * kGravity_m_s2) * normal;
  out_.support_limited = true;
}

// Eq. 4-5 and the base task acceleration; returns the desired base acceleration
// in the coordinates of udot (d/dt v_B, d/dt w_B, trunk frame).
void WholeBodyController::base_task(const WbcInput& in, const dyn::Data& d, Vec6& base_acc_desired) noexcept {
  const TemplateParams& tp = params_.template_params;
  const Mat3& rot = in.state.rotation_wb;
  const Vec3 base_vel_world = rot * in.state.v.head<3>();
  const Vec3 omega_world = rot * in.state.v.segment<3>(3);

  // Displacements from the rest pose and their rates relative to it (it moves when walking).
  const Vec3 x_b = in.state.q.head<3>() - reference_.base_position_m;
  const Vec3 x_e = d.frames[kEeFrame].translation - reference_.ee_position_m;
  const Vec3 xd_b = base_vel_world - reference_.base_velocity_m_s;
  const Vec3 xd_e = d.J_ee.topRows<3>() * in.state.v - reference_.ee_velocity_m_s;
  const Vec3 x_be = x_e - x_b, xd_be = xd_e - xd_b;

  // The template's force on the base, plus what carries the base along the rest pose's
  // acceleration (M_b a_ref: zero in place). The hand's spring pulls the base by the hand's
  // measured displacement; where a push overloaded the arm (last tick's fit_arm_to_its_torques)
  // that displacement is the push's doing, not the spring's: the arm yielded, the hand went
  // where it was pushed, and the stretched spring would drag the base after it (the straight
  // arm under 50 N: the hand 0.9 m down, 450 N on the base, which sank 21 cm; under 100 N the
  // robot tipped over). So from the overload on, the spring's pull on the base is at most the
  // push |F_e| (what an arm at its torques passes on), until it is back within that by
  // kCouplingReleaseMarginN: the hand back within the spring's reach (2 cm at K_e 500).
  Vec3 force = -tp.stiffness_base_n_per_m.cwiseProduct(x_b) - tp.damping_base_ns_per_m.cwiseProduct(xd_b) +
               tp.stiffness_ee_n_per_m.cwiseProduct(x_be) + tp.damping_ee_ns_per_m.cwiseProduct(xd_be) +
               tp.mass_base_kg.cwiseProduct(reference_.base_acceleration_m_s2);
  if (out_.arm_overloaded) coupling_limited_ = true;
  if (coupling_limited_) {
    const Vec3 pull = tp.stiffness_ee_n_per_m.cwiseProduct(x_be) + tp.damping_ee_ns_per_m.cwiseProduct(xd_be);
    const double push_n = out_.external_force_world_n.norm(), pull_n = pull.norm();
    if (pull_n > push_n + kCouplingReleaseMarginN) {
      force -= (1.0 - push_n / pull_n) * pull;
    } else {
      coupling_limited_ = false;
    }
  }
  out_.hand_coupling_limited = coupling_limited_;
  support_limit(in, d, base_vel_world, force);
  Vec3 torque;
  if (params_.rotational_template_enabled) {
    // The rotational template's torque on the trunk and the hand's angular acceleration.
    const RotationalTemplateParams& rp = params_.rotational_template;
    const RotationalTemplateState rs = rotational_template_state(
        rot, reference_.base_rotation, d.frames[kEeFrame].rotation, reference_.ee_rotation, omega_world,
        reference_.base_angular_velocity_rad_s, d.J_ee.bottomRows<3>() * in.state.v, reference_.ee_angular_velocity_rad_s);
    torque = rotational_template_base_torque_nm(rp, rs);
    Vec3 ee_angular_acc = rotational_template_ee_acceleration_rad_s2(rp, rs, out_.external_torque_world_nm);
    const double norm = ee_angular_acc.norm();
    if (norm > params_.ee_angular_acceleration_limit_rad_s2) ee_angular_acc *= params_.ee_angular_acceleration_limit_rad_s2 / norm;
    out_.ee_angular_acceleration_desired = ee_angular_acc + reference_.ee_angular_acceleration_rad_s2;
  } else {
    // Eq. 5: a rotational PD towards the rest orientation.
    const Vec3 e_r = so3_log(reference_.base_rotation * rot.transpose());
    torque = params_.kr_nm_per_rad.cwiseProduct(e_r) -
             params_.dr_nms_per_rad.cwiseProduct(omega_world - reference_.base_angular_velocity_rad_s);
  }
  out_.base_wrench_desired.head<3>() = force;  // (not <<: GCC 12 -march=native false array-bounds)
  out_.base_wrench_desired.tail<3>() = torque;
  out_.base_displacement_m = x_b;
  out_.ee_displacement_m = x_e;

  // The EE's template acceleration (second line of eq. 3), world axes.
  Vec3 ee_template_acc = (-tp.stiffness_ee_n_per_m.cwiseProduct(x_be) - tp.damping_ee_ns_per_m.cwiseProduct(xd_be) +
                          out_.external_force_world_n)
                             .cwiseQuotient(tp.mass_ee_kg);
  const double ee_acc_norm = ee_template_acc.norm();
  if (ee_acc_norm > params_.ee_acceleration_limit_m_s2) {
    ee_template_acc *= params_.ee_acceleration_limit_m_s2 / ee_acc_norm;
  }
  out_.ee_acceleration_desired = ee_template_acc + reference_.ee_acceleration_m_s2;

  // qdd_b^d = diag(M_b, I_b)^-1 W_b^d in world axes, then in udot coordinates:
  // p'' = R (d/dt v_B + w_B x v_B), w' = R d/dt w_B.
  const Vec3 acc_world = force.cwiseQuotient(tp.mass_base_kg);
  const Vec3 omega_dot_world = rot * (rot.transpose() * torque).cwiseQuotient(base_inertia_diag_);
  base_acc_desired.head<3>() = rot.transpose() * acc_world - in.state.v.segment<3>(3).cross(in.state.v.head<3>());
  base_acc_desired.tail<3>() = rot.transpose() * omega_dot_world;
}

// Eq. 8 with the sign of the posture term fixed (SPEC): the desired arm joint
// accelerations. The base's part of the EE acceleration uses this tick's
// desired base acceleration (the QP tracks it), so the arm does not lag a tick.
// kTask 3: the hand's position (the paper); 6: position and orientation (the
// rotational template), the posture in the 1-D null space left. Then the reference is
// fitted to the arm's torques (fit_arm_to_its_torques).
void WholeBodyController::arm_task(const WbcInput& in, const dyn::Data& d, const Vec6& base_acc_desired) noexcept {
  const MatArm m_arm = d.M.block<kArmDofs, kArmDofs>(kArmCol, kArmCol);
  const SmallCholesky<kArmDofs> llt(m_arm);
  if (params_.rotational_template_enabled) {
    arm_task_rows<6>(in, d, base_acc_desired, llt);
  } else {
    arm_task_rows<3>(in, d, base_acc_desired, llt);
  }
  fit_arm_to_its_torques(d, base_acc_desired, m_arm, llt);
}

template <int kTask>
void WholeBodyController::arm_task_rows(const WbcInput& in, const dyn::Data& d, const Vec6& base_acc_desired,
                                        const SmallCholesky<kArmDofs>& llt) noexcept {
  using MatTask = Eigen::Matrix<double, kTask, kTask>;
  using VecTask = Eigen::Matrix<double, kTask, 1>;
  const Eigen::Matrix<double, kTask, kArmDofs> jac = d.J_ee.block<kTask, kArmDofs>(0, kArmCol);
  const Eigen::Matrix<double, kArmDofs, kTask> minv_jt = llt.solve<kTask>(jac.transpose());

  const MatTask jjt = jac * jac.transpose();
  const double w = std::sqrt(std::max(0.0, jjt.determinant()));
  out_.manipulability = w;
  const double w0 = kTask == 3 ? params_.manipulability_threshold : params_.manipulability_threshold_6d;
  double lambda2 = 0.0;
  if (w < w0) {
    const double s = 1.0 - w / w0;
    lambda2 = params_.pinv_lambda0 * params_.pinv_lambda0 * s * s;
  }
  const MatTask lambda = jac * minv_jt + lambda2 * MatTask::Identity();
  const Eigen::Matrix<double, kArmDofs, kTask> pinv = minv_jt * lambda.inverse();  // dynamically consistent
  const Eigen::Matrix<double, kArmDofs, kArmDofs> null_space =
      Eigen::Matrix<double, kArmDofs, kArmDofs>::Identity() - pinv * jac;

  const VecArm q_arm = in.state.q.segment<kArmDofs>(7 + kFirstArmJoint);
  const VecArm qd_arm = in.state.v.segment<kArmDofs>(kArmCol);
  const VecArm qdd_posture =
      params_.posture_kp_per_s2 * (params_.arm_posture_rad - q_arm) - params_.posture_kd_per_s * qd_arm;
  Vec6 ee_acc;
  ee_acc.head<3>() = out_.ee_acceleration_desired;
  ee_acc.tail<3>() = out_.ee_angular_acceleration_desired;
  const VecTask task = ee_acc.head<kTask>() - d.J_ee.block<kTask, 6>(0, 0) * base_acc_desired - d.dJv_ee.head<kTask>();
  out_.arm_qdd_desired = pinv * task + null_space * qdd_posture;
}

// The arm's reference within its joints' torques. At the base's desired acceleration a_b
// the arm's joints need tau = tau_hold + M_aa qdd_a^d, where
//   tau_hold = M_ab a_b + h_a + c qd_a - J_e,a^T W_e
// holds the arm still (the legs' accelerations do not enter: M has no arm-leg block in a
// tree). Where tau is beyond a joint's limit the reference becomes what the clipped
// torques give, qdd_a^d = M_aa^-1 (clip(tau) - tau_hold): the hand renders a heavier mass
// while the push lasts. Left as it was, a reference the arm cannot follow draws the QP to
// accelerate the base instead (the arm's rows couple to it through M_ab), and a push the
// arm could not hold - 50 N on the straight arm, 80 N on the bent one - toppled the robot.
// Where tau_hold alone is beyond a limit, the arm is overloaded: no torque of its own holds
// it against the push and gravity, it is back-driven whatever it does, and its joints'
// acceleration bounds (speed and position limits) could be met only by moving the base,
// the same way; build_qp leaves them open until the load is back within the arm's torques.
// rt: no alloc
void WholeBodyController::fit_arm_to_its_torques(const dyn::Data& d, const Vec6& base_acc_desired, const MatArm& m_arm,
                                                 const SmallCholesky<kArmDofs>& llt) noexcept {
  const VecArm hold =
      d.M.block<kArmDofs, 6>(kArmCol, 0) * base_acc_desired + known_torque_nm_.segment<kArmDofs>(kFirstArmJoint);
  const VecArm need = hold + m_arm * out_.arm_qdd_desired;
  VecArm fit;
  out_.arm_reference_saturated = false;
  out_.arm_overloaded = false;
  for (int j = 0; j < kArmDofs; ++j) {
    const double limit = params_.torque_limit_scale * out_.torque_limit_nm[kFirstArmJoint + j];
    fit[j] = std::clamp(need[j], -limit, limit);
    out_.arm_reference_saturated = out_.arm_reference_saturated || fit[j] != need[j];
    out_.arm_overloaded = out_.arm_overloaded || std::abs(hold[j]) > limit;
  }
  if (out_.arm_reference_saturated) out_.arm_qdd_desired = llt.solve<1>(fit - hold);
}

void WholeBodyController::build_qp(const WbcInput& in, const dyn::Data& d) noexcept {
  const TemplateParams& tp = params_.template_params;
  WbcSolver::ProblemType& p = *problem_;
  Eigen::Map<Eigen::Matrix<double, kQpVars, kQpVars>> hess(p.hessian.data());
  Eigen::Map<Vec<kQpVars>> grad(p.gradient.data());
  Eigen::Map<Eigen::Matrix<double, kQpEq, kQpVars>> aeq(p.aeq.data());
  Eigen::Map<Vec<kQpEq>> beq(p.beq_values.data());
  Eigen::Map<Eigen::Matrix<double, kQpIn, kQpVars>> ain(p.ain.data());
  Eigen::Map<Vec<kQpIn>> lb(p.lower.data()), ub(p.upper.data());
  // Only the entries below are ever written, and which ones depends on the stance alone:
  // the rest stays zero from the last build. H's shape never changes; a contact switch
  // clears what depends on the stance: the feet's columns (forces or slacks) of the
  // dynamics' and the torques' rows, and the rows after them (the feet's equalities, the
  // feet's inequalities).
  if (!built_) {
    hess.setZero();
    aeq.setZero();
    ain.setZero();
  } else if (in.state.stance != built_stance_) {
    constexpr int kFeetCols = kQpVars - kNv;
    aeq.topRightCorner<6, kFeetCols>().setZero();
    aeq.bottomRows<kQpEq - 6>().setZero();
    ain.block<kNj, kFeetCols>(kNj, kNv).setZero();
    ain.bottomRows<kQpIn - 2 * kNj>().setZero();
  }
  built_ = true;
  built_stance_ = in.state.stance;
  grad.setZero();

  const Mat3& rot = in.state.rotation_wb;

  // ---- cost ------------------------------------------------------------------
  // Base: || diag(M_b R, I_b R) [d/dt v_B; d/dt w_B] + [M_b R (w_B x v_B); 0] - W_b^d ||^2.
  Mat6 a_base = Mat6::Zero();
  a_base.topLeftCorner<3, 3>() = tp.mass_base_kg.asDiagonal() * rot;
  a_base.bottomRightCorner<3, 3>() = rot * base_inertia_diag_.asDiagonal();
  Vec6 b_base = out_.base_wrench_desired;
  b_base.head<3>() -= tp.mass_base_kg.cwiseProduct(rot * in.state.v.segment<3>(3).cross(in.state.v.head<3>()));
  Vec6 w_base;
  w_base << Vec3::Constant(params_.weight_base_force), Vec3::Constant(params_.weight_base_torque);
  hess.topLeftCorner<6, 6>().noalias() = a_base.transpose() * w_base.asDiagonal() * a_base;
  grad.head<6>().noalias() = -a_base.transpose() * w_base.asDiagonal() * b_base;
  // Arm: || qdd_a - qdd_a^d ||^2; regularisation (the diagonal past the base block is set,
  // not added to: it is what the last tick left there).
  hess.diagonal().segment<kNv - 6>(6).setConstant(params_.reg_acceleration);
  hess.block<kArmDofs, kArmDofs>(kArmCol, kArmCol).diagonal().array() += params_.weight_arm;
  grad.segment<kArmDofs>(kArmCol) -= params_.weight_arm * out_.arm_qdd_desired;
  hess.diagonal().head<6>().array() += params_.reg_acceleration;
  // A foot whose force ramps (the gait's cap below a quarter of the weight) has its
  // tangential force regularised by (weight / 4) / cap: the share of the ground forces'
  // free part (what the tasks leave undetermined) it carries shrinks with its cap, as its
  // friction pyramid does, rather than the pyramid's faces joining the active set one by one
  // at the ramp's end.
  const double quarter_weight_n = 0.25 * d.composite[0].mass_kg * kGravity_m_s2;
  for (int f = 0; f < kFeet; ++f) {
    auto vars = hess.diagonal().segment<kFootVars>(foot_var(f));
    if (!in.state.stance[f]) {
      vars.setConstant(params_.reg_slack);
      continue;
    }
    const double cap = std::max(in.normal_force_cap_n[f], params_.normal_force_min_n);
    vars.setConstant(params_.reg_force);
    if (cap < quarter_weight_n) vars.head<2>().setConstant(params_.reg_force * quarter_weight_n / cap);
  }

  // ---- equalities ----------------------------------------------------------------
  // Floating-base dynamics (eq. 10): M_b-rows udot - J_st,b^T F_g = -h_b + J_e,b^T W_e.
  aeq.topLeftCorner<6, kNv>() = d.M.topRows<6>();
  beq.head<6>() = -d.nle.head<6>() + d.J_ee.leftCols<6>().transpose() * wrench_ee_world_;
  int row = 6;
  for (int f = 0; f < kFeet; ++f) {
    if (in.state.stance[f]) {
      const RollingContact& c = contact_[f];
      aeq.block<6, 3>(0, foot_var(f)) = -c.jacobian.leftCols<6>().transpose();
      // Stance feet roll without slipping: J_c udot + bias = 0.
      aeq.block<3, kNv>(row, 0) = c.jacobian;
      beq.segment<3>(row) = -c.bias_m_s2;
      row += 3;
      continue;
    }
    // Swing: the foot relative to the trunk, rho = R^T (p_f - p_b), follows a PD; the slack s
    // takes what the other tasks leave of it, J_rho qdd_leg + bias - s = rho''^d, and costs
    // reg_slack |s|^2: the task in the cost, as a soft equality. (As -s <= e <= s, the same
    // optimum, one row of each pair was active and flipped side with the sign of the foot's
    // error: the QP's active set changed on most swing ticks.)
    const SwingKinematics& k = swing_[f];
    const SwingTarget& target = in.swing[f];
    const Vec3 rho_ddot_des = target.acceleration_m_s2 +
                              params_.swing_kp_per_s2.cwiseProduct(target.position_m - k.position_m) +
                              params_.swing_kd_per_s.cwiseProduct(target.velocity_m_s - k.velocity_m_s);
    aeq.block<3, kLegJoints>(row, 6 + leg_first_joint(f)) = k.jacobian;
    aeq.block<3, 3>(row, foot_var(f)) = -Mat3::Identity();
    beq.segment<3>(row) = rho_ddot_des - k.bias_m_s2;
    row += 3;
  }
  const int meq = row;

  // ---- inequalities -------------------------------------------------------------------
  row = 0;
  const double dt = params_.joint_limit_horizon_s, dt_v = params_.joint_velocity_horizon_s;
  for (int j = 0; j < kNj; ++j) {
    // Joint accelerations that stop at a position limit within dt (eq. 17) and that take
    // the speed towards its limit no faster than within dt_v:
    //   (-v_max - qd) / dt_v <= qdd <= (v_max - qd) / dt_v.
    // Where the two disagree (a joint already past its position limit and faster than
    // v_max) the position's bounds alone hold.
    const auto& lim = robot::kJoints[j].limits;
    const double q = in.state.q[7 + j], qd = in.state.v[6 + j];
    ain(row, 6 + j) = 1.0;
    const double lo_q = lim.bounded ? 2.0 * (lim.lower_rad - q - dt * qd) / (dt * dt) : -kInf;
    const double hi_q = lim.bounded ? 2.0 * (lim.upper_rad - q - dt * qd) / (dt * dt) : kInf;
    const double v_max = params_.joint_velocity_limit_scale * lim.velocity_rad_s;
    const double lo = std::max(lo_q, (-v_max - qd) / dt_v), hi = std::min(hi_q, (v_max - qd) / dt_v);
    lb[row] = lo <= hi ? lo : lo_q;
    ub[row] = lo <= hi ? hi : hi_q;
    position_only_bounds_[static_cast<std::size_t>(j)] = {lo_q, hi_q};
    if (out_.arm_overloaded && j >= kFirstArmJoint) {  // it yields (fit_arm_to_its_torques)
      lb[row] = -kInf;
      ub[row] = kInf;
      position_only_bounds_[static_cast<std::size_t>(j)] = {-kInf, kInf};
    }
    ++row;
  }
  // Torque limits through the actuated rows of eq. 1 (c_j qd_j: the compensated friction):
  //   tau = M_j udot + h_j + c_j qd_j - J_st,j^T F_g - J_e,j^T W_e  in [-tau_max, tau_max],
  // tau_max the joint's limit at the tick's angle (a hydraulic joint's lever: model.hpp).
  ain.block<kNj, kNv>(row, 0) = d.M.bottomRows<kNj>();  // column by column: both column-major
  for (int f = 0; f < kFeet; ++f) {
    if (in.state.stance[f]) ain.block<kNj, 3>(row, foot_var(f)) = -contact_[f].jacobian.rightCols<kNj>().transpose();
  }
  for (int j = 0; j < kNj; ++j) {
    const double tau_max = params_.torque_limit_scale * out_.torque_limit_nm[j];
    lb[row] = -tau_max - known_torque_nm_[j];
    ub[row] = tau_max - known_torque_nm_[j];
    ++row;
  }
  const double mu = params_.friction_mu / std::sqrt(2.0);  // pyramid inscribed in the cone
  for (int f = 0; f < kFeet; ++f) {
    if (!in.state.stance[f]) continue;
    const int c = foot_var(f);
    for (int t = 0; t < 2; ++t) {  // |f_t| <= mu f_n as two rows each
      ain(row, c + t) = 1.0;
      ain(row, c + 2) = -mu;
      lb[row] = -kInf;
      ub[row] = 0.0;
      ++row;
      ain(row, c + t) = 1.0;
      ain(row, c + 2) = mu;
      lb[row] = 0.0;
      ub[row] = kInf;
      ++row;
    }
    ain(row, c + 2) = 1.0;
    lb[row] = params_.normal_force_min_n;
    const double cap = in.normal_force_cap_n[f];
    ub[row] = std::max(params_.normal_force_min_n, cap < params_.normal_force_max_n ? cap : params_.normal_force_max_n);
    ++row;
  }
  p.resize(kQpVars, meq, row);
}

// Eq. 19: tau = M_act udot + h_act - J_st,act^T F_g - J_e,act^T W_e, plus the compensated friction c qd.
void WholeBodyController::torques_from_solution(const WbcInput& in, const dyn::Data& d) noexcept {
  const Eigen::Map<const Vec<kQpVars>> x(result_->x.data());
  out_.udot = x.head<kNv>();
  {
    const Mat3& rot = in.state.rotation_wb;
    const Vec3 acc_world = rot * (out_.udot.head<3>() + in.state.v.segment<3>(3).cross(in.state.v.head<3>()));
    out_.base_wrench_applied.head<3>() = params_.template_params.mass_base_kg.cwiseProduct(acc_world);
    out_.base_wrench_applied.tail<3>() = rot * base_inertia_diag_.cwiseProduct(out_.udot.segment<3>(3));
  }
  VecNv tau_full = d.M * out_.udot + d.nle - d.J_ee.transpose() * wrench_ee_world_;
  tau_full.tail<kNj>() += joint_friction_nm_;
  for (int f = 0; f < kFeet; ++f) {
    if (in.state.stance[f]) {
      out_.foot_force_n[f] = x.segment<3>(foot_var(f));
      tau_full.noalias() -= contact_[f].jacobian.transpose() * out_.foot_force_n[f];
    } else {
      out_.foot_force_n[f].setZero();
    }
  }
  for (int j = 0; j < kNj; ++j) {
    out_.tau_nm[j] = std::clamp(tau_full[6 + j], -out_.torque_limit_nm[j], out_.torque_limit_nm[j]);
  }
}

namespace {

// The inequality rows' layout (build_qp): the joints' acceleration and torque rows, then each
// stance foot's 5 (friction pyramid, normal force); a swing foot has none.
constexpr int kJointRows = 2 * kNj;
constexpr int foot_rows(bool stance) noexcept { return stance ? kStanceFootRows : 0; }
int first_foot_row(const Stance& stance, int foot) noexcept {
  int row = kJointRows;
  for (int f = 0; f < foot; ++f) row += foot_rows(stance[f]);
  return row;
}
int foot_of_row(const Stance& stance, int row) noexcept {
  for (int f = 0; f < kFeet; ++f) {
    row -= foot_rows(stance[f]);
    if (row < kJointRows) return f;
  }
  return -1;
}
unsigned stance_mask(const Stance& stance) noexcept {
  unsigned mask = 0;
  for (int f = 0; f < kFeet; ++f) mask |= stance[f] ? 1u << f : 0u;
  return mask;
}

}  // namespace

// At a contact switch the last tick's active set no longer fits the rows: the joints' rows keep
// their places, a foot that kept its state keeps its rows (moved by the switched feet's row
// counts before it), and a switched foot takes its rows from the set last solved with this
// stance (a trot's diagonals return every cycle). Only a hint: the solver checks it.
void WholeBodyController::switch_hint(const Stance& stance) noexcept {
  const unsigned last = stance_mask(last_stance_), now = stance_mask(stance);
  (*mode_sets_)[last] = *warm_start_;
  have_mode_set_[last] = true;
  qp::ActiveSet<kQpIn>& hint = *switch_hint_;
  hint.clear();
  for (int e = 0; e < warm_start_->size; ++e) {
    const int row = warm_start_->row[static_cast<std::size_t>(e)];
    const qp::Side side = warm_start_->side[static_cast<std::size_t>(e)];
    if (row < kJointRows) {
      hint.push(row, side);
      continue;
    }
    const int f = foot_of_row(last_stance_, row);
    if (f < 0 || stance[f] != last_stance_[f]) continue;
    hint.push(first_foot_row(stance, f) + row - first_foot_row(last_stance_, f), side);
  }
  if (!have_mode_set_[now]) return;
  const qp::ActiveSet<kQpIn>& seen = (*mode_sets_)[now];
  for (int e = 0; e < seen.size; ++e) {
    const int row = seen.row[static_cast<std::size_t>(e)];
    if (row < kJointRows) continue;
    const int f = foot_of_row(stance, row);
    if (f >= 0 && stance[f] != last_stance_[f]) hint.push(row, seen.side[static_cast<std::size_t>(e)]);
  }
}

const WbcOutput& WholeBodyController::tick_kernel(const WbcInput& in, const dyn::Data& d) noexcept {
  for (int f = 0; f < kFeet; ++f) {
    if (in.state.stance[f]) {
      rolling_contact(d, in.state, f, params_.foot_contact_radius_m, contact_[f]);
    } else {
      swing_kinematics(d, in.state, f, swing_[f]);
    }
  }
  wrench_ee_world_ << in.wrist_force_world_n, in.wrist_torque_world_nm;
  out_.external_force_world_n = wrench_ee_world_.head<3>();
  out_.external_torque_world_nm = wrench_ee_world_.tail<3>();
  out_.ee_rotation = d.frames[kEeFrame].rotation;
  joint_friction_nm_ = params_.joint_viscous_friction_nms_per_rad.cwiseProduct(in.state.v.tail<kNj>());
  out_.torque_limit_nm = torque_limits_nm(in.state.q.tail<kNj>());
  // The joints' torques besides M udot and the contacts (eq. 19): h + c qd - J_e^T W_e; the
  // torque rows' bounds (build_qp) and the arm's fit (fit_arm_to_its_torques) both take it.
  {
    const VecNj external_nm = d.J_ee.rightCols<kNj>().transpose() * wrench_ee_world_;
    for (int j = 0; j < kNj; ++j) known_torque_nm_[j] = d.nle[6 + j] + joint_friction_nm_[j] - external_nm[j];
  }

  stance_ticks_ = in.state.stance == last_stance_ ? std::min(stance_ticks_ + 1, kSupportSettleTicks) : 0;
  Vec6 base_acc_desired;
  base_task(in, d, base_acc_desired);
  arm_task(in, d, base_acc_desired);
  build_qp(in, d);

  // Warm start from the previous tick's active set while the contact state holds
  // (the per-foot rows keep their places); the solver checks it and falls back cold.
  // The Hessian's factor is cheap from its structure: the solver skips its Cholesky.
  WbcSolver::Hint hint;
  if (have_warm_start_ && in.state.stance == last_stance_) {
    hint.active_set = warm_start_.get();
  } else if (have_warm_start_) {
    switch_hint(in.state.stance);
    hint.active_set = switch_hint_.get();
  }
  if (factor_qp_hessian(*problem_, *hessian_factor_)) hint.cholesky_lower = hessian_factor_->data();
  qp::Status status = solver_->solve(*problem_, *result_, hint);
  // The joints' speed limits give way to the torque limits and the contacts: a push the arm
  // cannot hold back-drives it faster than its limit (a real arm would too), which with the
  // speed rows has no solution. Solved again without them (the position limits stay).
  out_.velocity_limits_relaxed = false;
  out_.joint_limits_relaxed = false;
  if (status != qp::Status::optimal) {
    for (int j = 0; j < kNj; ++j) {  // the joint-acceleration rows come first (build_qp)
      problem_->lower[static_cast<std::size_t>(j)] = position_only_bounds_[static_cast<std::size_t>(j)][0];
      problem_->upper[static_cast<std::size_t>(j)] = position_only_bounds_[static_cast<std::size_t>(j)][1];
    }
    WbcSolver::Hint cold;
    cold.cholesky_lower = hint.cholesky_lower;
    status = solver_->solve(*problem_, *result_, cold);
    out_.velocity_limits_relaxed = status == qp::Status::optimal;
    // Still none: a joint heading into its position limit faster than its torque can brake
    // (a push the arm cannot hold flings it). The braking rows give way too, last: the
    // joint's stop takes the rest, where a failed tick would have the supervisor damp the
    // whole robot to the ground.
    if (status != qp::Status::optimal) {
      for (int j = 0; j < kNj; ++j) {
        problem_->lower[static_cast<std::size_t>(j)] = -kInf;
        problem_->upper[static_cast<std::size_t>(j)] = kInf;
      }
      status = solver_->solve(*problem_, *result_, cold);
      out_.joint_limits_relaxed = status == qp::Status::optimal;
    }
  }
  out_.qp_status = status;
  out_.qp_iterations = result_->iterations;
  out_.qp_from_hint = result_->from_hint;
  last_stance_ = in.state.stance;
  if (status == qp::Status::optimal) {
    // A row with lb == ub (a foot's force minimum that is also its cap, at a touch-down
    // ramp's start) is hinted on the side its multiplier pushes: the next tick's cap
    // opens the range, and an `equal` hint would leave the row out (a repair or more to
    // find it again). While lb == ub the solver takes it as an equality either way.
    *warm_start_ = result_->active;
    for (int e = 0; e < warm_start_->size; ++e) {
      qp::Side& side = warm_start_->side[static_cast<std::size_t>(e)];
      if (side != qp::Side::equal) continue;
      const int row = warm_start_->row[static_cast<std::size_t>(e)];
      side = result_->lambda_in[static_cast<std::size_t>(row)] > 0.0 ? qp::Side::upper : qp::Side::lower;
    }
    have_warm_start_ = true;
    out_.failed = false;
    torques_from_solution(in, d);
  } else {
    have_warm_start_ = false;
    out_.failed = true;
    ++qp_failures_;
  }
  return out_;
}

}  // namespace springbok::wbc
