// The paper's whole-body controller (Risiglione et al., SPEC section 3): the
// robot renders a double mass-spring-damper template when its hand is pushed.
//
// One tick, on the caller's dynamics (springbok::control computes them once per
// tick for the gait and this controller):
//  1. dynamics at (q, v): M, h, foot and EE Jacobians and Jdot*v (dyn::compute_tick,
//     by the caller); from them the stance feet's rolling contact points and the swing
//     feet's positions relative to the trunk (contact_kinematics.hpp);
//  2. the desired base wrench W_b^d (eq. 4-5) from the template gains and a
//     rotational PD (after an overload of the arm, see 3, the hand spring's pull on
//     the base at most the push); the base task  diag(M_b, I_b) qdd_b = W_b^d;
//  3. the arm task (eq. 8): the template's EE acceleration through the damped,
//     dynamically consistent pseudo-inverse of the arm Jacobian, plus a
//     null-space posture task (with the rotational template: the hand's linear and
//     angular accelerations through the full 6x7 Jacobian); cut to what the arm's
//     torques give, and an arm overloaded by a push it cannot hold yields (its
//     acceleration bounds open) rather than the base giving way for it;
//  4. one QP (eq. 6) over xi = [udot (25); 3 per foot] where a foot's three
//     variables are its ground force when in stance and its swing-task slack
//     when in swing, so the sizes never change, only which rows are live:
//       equalities   floating-base dynamics (6), stance feet do not accelerate (3 each),
//                    swing feet's task with its slack (3 each: J qdd + b - s = rho''^d,
//                    s penalised: the task in the cost, s = the task's error)
//       inequalities joint-acceleration bounds (eq. 17, 19, and the joints' velocity
//                    limits), torque limits (19), friction pyramid and normal-force bounds
//                    (5 per stance foot);
//  5. torques by eq. 19. If the QP fails the tick says so (`failed`), counts it
//     and leaves the torques of the last solved tick: the safety supervisor alone
//     decides what a failed tick commands.
//
// Frames: world quantities are in world axes; the base twist v[0:6] is in the
// trunk frame (CONVENTIONS.md). The template's displacements are of the trunk
// origin and of the EE origin from their desired (initial) positions.
#pragma once

#include <array>
#include <limits>
#include <cstdint>
#include <memory>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "springbok/dynamics/dynamics.hpp"
#include "springbok/model/model.hpp"
#include "springbok/model/robot_state.hpp"
#include "springbok/qp/qp.hpp"
#include "springbok/wbc/contact_kinematics.hpp"
#include "springbok/wbc/impedance_template.hpp"
#include "springbok/dynamics/small_cholesky.hpp"

namespace springbok::wbc {

inline constexpr int kArmDofs = kArmJoints;
inline constexpr int kArmCol = 6 + kFirstArmJoint;       // first arm column of v
inline constexpr int kFootVars = 3;                      // force (stance) or slack (swing)
inline constexpr int kQpVars = kNv + kFootVars * kFeet;  // 37
inline constexpr int kQpEq = 6 + 3 * kFeet;              // 18
inline constexpr int kStanceFootRows = 5;                // friction pyramid (4), normal force (1)
inline constexpr int kQpIn = 2 * kNj + kStanceFootRows * kFeet;  // 58 (all feet in stance)
using WbcSolver = qp::Solver<kQpVars, kQpEq, kQpIn>;
using VecArm = Vec<kArmDofs>;
using MatArm = Eigen::Matrix<double, kArmDofs, kArmDofs>;
using dyn::SmallCholesky;

struct WbcParams {
  TemplateParams template_params;

  // Rotational PD of the base (eq. 5) and the desired rotational inertia I_b. Stiff enough
  // for the trot: on one diagonal the ground cannot hold the trunk's roll, and with the
  // CAN path's two ticks from measurement to torque (CAN.md 3.3) 800/80 let it roll
  // 0.09 rad and fall within a cycle (the in-process twin of the HIL case,
  // tests/app/timing); stance renders identically with either.
  Vec3 kr_nm_per_rad{1600.0, 1600.0, 1600.0};
  Vec3 dr_nms_per_rad{160.0, 160.0, 160.0};
  // Diagonal of I_b [kg m^2]; a non-positive entry means "the robot's composite
  // rotational inertia at the reference pose" (the default).
  Vec3 base_rot_inertia_kgm2{0.0, 0.0, 0.0};

  // The rotational template (impedance_template.hpp; beyond the paper, off by default):
  // when on, the base task's rotational rows take its trunk torque (its I_b in place of
  // base_rot_inertia_kgm2, kr/dr unused) and the arm task becomes 6-D, the hand's
  // orientation following the template driven by the wrist torque.
  bool rotational_template_enabled = false;
  RotationalTemplateParams rotational_template;

  // Arm null-space posture task qdd_p = K_p (q_a^d - q_a) - D_p qd_a, and its posture.
  double posture_kp_per_s2 = 100.0;
  double posture_kd_per_s = 20.0;
  VecArm arm_posture_rad = VecArm::Zero();  // overwritten by set_reference() unless pinned
  bool pin_arm_posture = false;

  // Damped pseudo-inverse: lambda^2 = lambda_0^2 (1 - w / w_0)^2 below w_0.
  double pinv_lambda0 = 0.05;
  double manipulability_threshold = 0.02;
  // Bound on the norm of the hand's template acceleration [m/s^2] (infinity: the paper's
  // task). A light hand mass under a push the arm cannot follow asks for hundreds of m/s^2
  // (M_e 0.4 kg, 104 N: 260): the saturated Gen3 flung the hand about, its joints to their
  // limits, and the trotting robot fell. Bounded, the hand renders a heavier mass while
  // the push lasts. 100 m/s^2 is beyond what the arm gave the hand in the 50 N steps (the
  // M_e 0.4 step scores the same with 80).
  double ee_acceleration_limit_m_s2 = 100.0;
  // The same bound on the hand's template angular acceleration [rad/s^2] (rotational template).
  double ee_angular_acceleration_limit_rad_s2 = 200.0;
  // With the 6-D arm task the damping follows the manipulability of the full hand Jacobian,
  // sqrt(det(J J^T)) of the 6x7 J (units m^3 rad^3 per rad^7: its own threshold).
  double manipulability_threshold_6d = 0.005;

  // QP weights.
  double weight_base_force = 1.0;    // on (M_b a_b - F_b^d) [1/N^2]
  double weight_base_torque = 1.0;   // on (I_b w_b' - T_b^d) [1/(N m)^2]
  double weight_arm = 100.0;         // on (qdd_a - qdd_a^d)
  double reg_acceleration = 1e-4;    // on udot
  double reg_force = 1e-6;           // on ground forces
  double reg_slack = 1e3;            // on swing slack

  // Contacts (flat ground, normal +z).
  double friction_mu = 0.6;          // pyramid inscribed in this cone
  double normal_force_min_n = 5.0;
  double normal_force_max_n = 1500.0;
  // Radius of the sphere feet [m]. When positive, the foot Jacobians (forces,
  // stance rows, torques) are taken at the ground contact point, this far below
  // the foot frame (the sphere centre), instead of at the centre: a sphere that
  // rolls without slipping is still at its contact point, and the horizontal
  // ground forces act there. 0 keeps the frame origin (the sphere centre), which
  // leaves the base 4-8 % past its static displacement under a horizontal push.
  double foot_contact_radius_m = kFootRadius_m;
  // The support limit (whole_body_controller.cpp, support_limit): the static centre of
  // pressure kept this far inside the stance feet's polygon [m]; 0 turns it off.
  double support_margin_m = 0.04;

  // Joint-acceleration bounds that stop at a limit within this horizon (eq. 17). A knee
  // arrives at touch-down at 8-10 rad/s: 0.2 s together with "stance feet do not
  // accelerate" had no solution for a few ticks at every step of a trot.
  double joint_limit_horizon_s = 0.05;
  // Joint speeds within the URDF's velocity limits (times the scale): the acceleration
  // rows take a speed to its limit no faster than within this horizon (the Gen3's
  // 1.40 / 1.22 rad/s; a real arm faults beyond them).
  double joint_velocity_horizon_s = 0.02;
  double joint_velocity_limit_scale = 0.97;  // the rows aim 3 % below the URDF limit: the arm overshoots them by up to 0.5 %
  double torque_limit_scale = 1.0;   // fraction of the joints' torque limits the QP may use

  // Swing foot Cartesian PD (relative to the base, base axes).
  Vec3 swing_kp_per_s2{400.0, 400.0, 400.0};
  Vec3 swing_kd_per_s{40.0, 40.0, 40.0};

  // The joints' viscous friction c [N m s/rad] to compensate: the torques (eq. 19) and their
  // limits carry c qd besides M udot + h. 0: none (the simulated robot has none). Set it below
  // the friction identified on the robot: with c < b a joint stays passive whatever the delay
  // from measurement to torque (I s + b - c e^(-s d) has no root with Re s >= 0). Unmodelled,
  // friction renders as extra damping at the hand: the HIL case's emulated 0.5 N m s/rad per
  // joint left the hand 8 % off its template.
  VecNj joint_viscous_friction_nms_per_rad = VecNj::Zero();
};

// Desired swing-foot motion, foot position relative to the trunk origin, trunk axes.
struct SwingTarget {
  Vec3 position_m = Vec3::Zero();
  Vec3 velocity_m_s = Vec3::Zero();
  Vec3 acceleration_m_s2 = Vec3::Zero();
};

struct WbcInput {
  RobotState state;                  // q, v, R_WB, the stance feet
  std::array<SwingTarget, kFeet> swing{};
  // A stance foot's normal force bound, N (the gait's ramps at touch-down and lift-off),
  // within [normal_force_min_n, normal_force_max_n]; infinity: normal_force_max_n.
  std::array<double, kFeet> normal_force_cap_n{
      std::numeric_limits<double>::infinity(), std::numeric_limits<double>::infinity(),
      std::numeric_limits<double>::infinity(), std::numeric_limits<double>::infinity()};
  // The wrist F/T measurement: the external wrench on the EE about the sensor's origin, in
  // world axes (the caller turns the reading into them with the tick's kinematics, once:
  // springbok::control does it for the WBC, the footholds and the unmeasured pushes).
  Vec3 wrist_force_world_n = Vec3::Zero();
  Vec3 wrist_torque_world_nm = Vec3::Zero();
  // Pushes the wrist sensor does not measure (on the trunk, a leg, the arm's links: the robot's
  // momentum balance, springbok::control), world axes, N; taken as acting at the centre of mass.
  Vec3 unmeasured_force_world_n = Vec3::Zero();
};

// The template's rest pose, which its displacements are measured from: the pose at
// set_reference(), carried along a planar motion when the robot walks (move_reference).
// World axes; velocities and accelerations are the rest pose's own.
struct WbcReference {
  Vec3 base_position_m = Vec3::Zero();
  Mat3 base_rotation = Mat3::Identity();
  Vec3 ee_position_m = Vec3::Zero();
  Mat3 ee_rotation = Mat3::Identity();  // the hand's rest orientation (turns with the base's)
  Vec3 ee_angular_velocity_rad_s = Vec3::Zero();
  Vec3 ee_angular_acceleration_rad_s2 = Vec3::Zero();
  Vec3 base_velocity_m_s = Vec3::Zero();
  Vec3 base_acceleration_m_s2 = Vec3::Zero();
  Vec3 base_angular_velocity_rad_s = Vec3::Zero();
  Vec3 ee_velocity_m_s = Vec3::Zero();
  Vec3 ee_acceleration_m_s2 = Vec3::Zero();
};

// A rigid planar motion of the rest pose (walking): translated by offset (world, z = 0)
// and turned by yaw about world z through the base's rest point; with their rates.
struct PlanarMotion {
  Vec3 offset_m = Vec3::Zero();
  Vec3 velocity_m_s = Vec3::Zero();
  Vec3 acceleration_m_s2 = Vec3::Zero();
  double yaw_rad = 0.0;
  double yaw_rate_rad_s = 0.0;
  double yaw_acceleration_rad_s2 = 0.0;
  // The hand's rest point moved on top of that (hand pose commands): an offset in the rest
  // pose's horizontal frame (the engaged heading, turned by yaw), with its rates in that frame.
  Vec3 hand_offset_m = Vec3::Zero();
  Vec3 hand_velocity_m_s = Vec3::Zero();
  Vec3 hand_acceleration_m_s2 = Vec3::Zero();
  // And the hand's rest orientation turned by the rotation vector phi (same frame), with
  // d phi / dt and d^2 phi / dt^2 (the rotational template renders about it).
  Vec3 hand_rotation_rad = Vec3::Zero();
  Vec3 hand_rotation_rate_rad_s = Vec3::Zero();
  Vec3 hand_rotation_acceleration_rad_s2 = Vec3::Zero();
};

struct WbcOutput {
  VecNj tau_nm = VecNj::Zero();
  VecNj torque_limit_nm = VecNj::Zero();       // each joint's limit at the tick's angle (model.hpp)
  VecNv udot = VecNv::Zero();
  std::array<Vec3, kFeet> foot_force_n{};     // world axes; zero in swing
  qp::Status qp_status = qp::Status::bad_input;
  int qp_iterations = 0;
  bool qp_from_hint = false;                   // solved directly on the last tick's active set
  bool failed = false;                         // the QP failed this tick: tau_nm is the last solved tick's
  bool velocity_limits_relaxed = false;        // solved only without the joints' speed limits
  bool joint_limits_relaxed = false;           // solved only without any joint-acceleration bound
  // The arm's reference asked more torque than its joints have: it was cut to what they give.
  bool arm_reference_saturated = false;
  // No torque of the arm's holds it against the push and gravity: it yields, its joints'
  // acceleration bounds left open (whole_body_controller.cpp, fit_arm_to_its_torques).
  bool arm_overloaded = false;
  // The hand spring's pull on the base limited to the push (from an overload of the arm until
  // the hand is back within the spring's reach: whole_body_controller.cpp, base_task).
  bool hand_coupling_limited = false;
  // The base held back from the edge of its support (whole_body_controller.cpp, support_limit),
  // and how far inside the stance feet's polygon the centre of pressure is [m] (infinity: not
  // computed, fewer than three feet in stance or the limit off).
  bool support_limited = false;
  double support_distance_m = std::numeric_limits<double>::infinity();
  // The same for that centre of pressure's capture point (it moved by the trunk's horizontal
  // velocity times sqrt(h / g), h the centre of mass's height): negative, the trunk cannot
  // stop over these feet.
  double capture_distance_m = std::numeric_limits<double>::infinity();
  // What the tasks asked for, for logs and plots.
  Vec6 base_wrench_desired = Vec6::Zero();     // [F_b^d; T_b^d], world
  // The wrench the solution renders on the template's base (the base task's rows at
  // udot: [M_b p''; I_b w'], world); W_b^d minus it is what two feet could not give.
  Vec6 base_wrench_applied = Vec6::Zero();
  Vec3 ee_acceleration_desired = Vec3::Zero(); // world
  Vec3 ee_angular_acceleration_desired = Vec3::Zero();  // world; zero without the rotational template
  VecArm arm_qdd_desired = VecArm::Zero();
  double manipulability = 0.0;
  Vec3 external_force_world_n = Vec3::Zero();  // F_e
  Vec3 base_displacement_m = Vec3::Zero();     // x_b
  Vec3 ee_displacement_m = Vec3::Zero();       // x_e
  Vec3 external_torque_world_nm = Vec3::Zero(); // T_e (about the hand's origin)
  Mat3 ee_rotation = Mat3::Identity();          // the hand's orientation this tick (world)
};

class WholeBodyController {
 public:
  // Start-up: allocates the QP once.
  explicit WholeBodyController(const WbcParams& params);
  ~WholeBodyController();
  WholeBodyController(const WholeBodyController&) = delete;
  WholeBodyController& operator=(const WholeBodyController&) = delete;

  // Holds the pose at q as the desired one (base, EE, arm posture) and sets
  // I_b if it is automatic; `data` is the caller's workspace (its kinematics are
  // recomputed at q). rt: no alloc (once, on entering the control mode)
  void set_reference(const VecNq& q, dyn::Data& data) noexcept;
  const WbcReference& reference() const noexcept { return reference_; }
  // The rest pose of set_reference(), moved by `motion` (and at rest in it: the rates are
  // the motion's). rt: no alloc
  void move_reference(const PlanarMotion& motion) noexcept;
  // The rest pose as set_reference() took it.
  const WbcReference& engaged_reference() const noexcept { return engaged_; }
  const WbcParams& params() const noexcept { return params_; }
  // Live tuning (springbok::control ramps them tick by tick): the template's M, D, K and
  // the arm's posture gains from the next tick on. The caller checks the values (the
  // config's ranges); I_b stays what set_reference() took. rt: no alloc
  void set_template(const TemplateParams& t) noexcept { params_.template_params = t; }
  // The rotational template's D, K and hand inertia (I_b stays what set_reference() took).
  void set_rotational_template(const RotationalTemplateParams& t) noexcept {
    const Vec3 base_inertia = params_.rotational_template.inertia_base_kgm2;
    params_.rotational_template = t;
    params_.rotational_template.inertia_base_kgm2 = base_inertia;
  }
  void set_posture_gains(double kp_per_s2, double kd_per_s) noexcept {
    params_.posture_kp_per_s2 = kp_per_s2;
    params_.posture_kd_per_s = kd_per_s;
  }
  Vec3 base_rotational_inertia_kgm2() const noexcept { return base_inertia_diag_; }

  // `data` must hold dyn::compute_tick at (in.state.q, in.state.v). rt: no alloc,
  // no block. Never throws; on a QP failure `out.failed` is set.
  const WbcOutput& tick(const WbcInput& in, const dyn::Data& data) noexcept;
  // tick()'s body, compiled once per instruction-set level (springbok/isa/isa.hpp): tick()
  // runs the one of isa::active(). Call tick().
  const WbcOutput& tick_kernel(const WbcInput& in, const dyn::Data& data) noexcept;

  std::uint64_t qp_failures() const noexcept { return qp_failures_; }
  const WbcOutput& output() const noexcept { return out_; }

 private:
  void base_task(const WbcInput& in, const dyn::Data& d, Vec6& base_acc_desired) noexcept;
  void support_limit(const WbcInput& in, const dyn::Data& d, const Vec3& base_vel_world, Vec3& force) noexcept;
  void arm_task(const WbcInput& in, const dyn::Data& d, const Vec6& base_acc_desired) noexcept;
  template <int kTask>
  void arm_task_rows(const WbcInput& in, const dyn::Data& d, const Vec6& base_acc_desired,
                     const SmallCholesky<kArmDofs>& llt) noexcept;
  void fit_arm_to_its_torques(const dyn::Data& d, const Vec6& base_acc_desired, const MatArm& m_arm,
                              const SmallCholesky<kArmDofs>& llt) noexcept;
  void build_qp(const WbcInput& in, const dyn::Data& d) noexcept;
  void torques_from_solution(const WbcInput& in, const dyn::Data& d) noexcept;

  WbcParams params_;
  WbcReference reference_;
  WbcReference engaged_;
  Vec3 base_inertia_diag_ = Vec3::Ones();
  dyn::Model model_;
  std::unique_ptr<WbcSolver> solver_;
  std::unique_ptr<WbcSolver::ProblemType> problem_;
  std::unique_ptr<WbcSolver::ResultType> result_;
  // The warm start: the last tick's active set; at a contact switch its rows translated to
  // the new layout (feet that kept their state), the switched feet's rows from the set last
  // seen with the new stance (mode_sets_, by stance mask).
  void switch_hint(const Stance& stance) noexcept;
  std::unique_ptr<qp::ActiveSet<kQpIn>> warm_start_;
  std::unique_ptr<qp::ActiveSet<kQpIn>> switch_hint_;
  std::unique_ptr<std::array<qp::ActiveSet<kQpIn>, 1 << kFeet>> mode_sets_;
  std::array<bool, 1 << kFeet> have_mode_set_{};
  Stance last_stance_ = kAllFeet;
  bool have_warm_start_ = false;
  // build_qp: the stance the problem's zero pattern was last laid out for.
  Stance built_stance_ = kAllFeet;
  bool built_ = false;
  // H's Cholesky factor from its structure (whole_body_controller.cpp): zero but for the
  // base block's lower triangle and the diagonal, which every tick writes.
  using HessianFactor = std::array<double, static_cast<std::size_t>(kQpVars) * kQpVars>;
  std::unique_ptr<HessianFactor> hessian_factor_;
  std::array<RollingContact, kFeet> contact_{};  // this tick's stance feet
  std::array<SwingKinematics, kFeet> swing_{};   // this tick's swing feet
  Vec6 wrench_ee_world_ = Vec6::Zero();
  VecNj joint_friction_nm_ = VecNj::Zero();  // c qd this tick
  VecNj known_torque_nm_ = VecNj::Zero();   // h + c qd - J_e^T W_e on the joints this tick (tick())
  std::array<std::array<double, 2>, kNj> position_only_bounds_{};  // the acceleration rows without the speed limits
  bool coupling_limited_ = false;  // base_task: the hand spring's pull limited to the push
  int stance_ticks_ = 0;           // ticks the stance has held (support_limit), saturating
  WbcOutput out_;
  std::uint64_t qp_failures_ = 0;
};

}  // namespace springbok::wbc
