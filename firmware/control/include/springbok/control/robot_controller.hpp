// springbok::control — the controller of the control mode, one object in every
// binary: the deployed firmware (springbok, on SocketCAN), springbok-on-sim and the
// simulation tool (springbok-sim) all run this class. One tick:
//
//   hal::Measurements --> BaseEstimator (IMU + leg kinematics, last tick's stance)
//          |                   |
//          |              RobotState (q, v, R_WB once, stance)  <-- or the simulator's
//          |                   |                                    ground truth (tool only)
//          |              dyn::compute_tick: kinematics and dynamics once, one Data
//          |                   |
//          +-- wrist F/T --> gait: stand (four feet) or trot (stance set, swing targets,
//          |   minus tare       footholds under the static ZMP of weight + wrist wrench
//          |                    + unmeasured pushes, touch-down from the feet's estimated
//          |                    forces, force ramps)
//          +-- joint torques --> FootForceObserver (the ground force on each foot from
//                                its leg's torques and motion; the robot's external force)
//                                -> unmeasured pushes: external - feet - wrist (WbcInput)
//                              |
//                         WholeBodyController (QP) --> joint torques
//
// Outside the control mode (stand-up, stand; the tool's settle phase) observe()
// keeps the estimator running on four feet and, while the robot stands still,
// tares the wrist F/T (CAN.md 6.2: the mean of the first tare_samples valid
// readings in stand is subtracted from then on; request_tare() takes a new one at
// the next stand). The tare never collects in the control mode, where the hand
// may be pushed; until one completes, nothing is subtracted. The first tick() after construction or
// disengage() engages: the template's reference is the pose of that instant and
// the requested gait starts.
//
// A failed tick (estimate not ok, QP failure, not engaged) leaves the command
// untouched and says why: the safety supervisor alone decides what it commands.
//
// Gait switching (request_gait, applied at the next tick): stand -> trot starts the
// cycle from the feet where they stand; trot -> stand lets every swinging foot land
// and lifts no new one, then stands.
#pragma once

#include <array>
#include <cstdint>
#include <memory>
#include <span>
#include <string>

#include <Eigen/Core>

#include "springbok/dynamics/dynamics.hpp"
#include "springbok/estimation/base_estimator.hpp"
#include "springbok/control/hand_trajectory.hpp"
#include "springbok/estimation/foot_force_observer.hpp"
#include "springbok/gait/trot.hpp"
#include "springbok/hal/types.hpp"
#include "springbok/model/robot_state.hpp"
#include "springbok/wbc/whole_body_controller.hpp"

namespace springbok::control {

enum class GaitKind : std::uint8_t { stand = 0, trot = 1 };

// The unmeasured pushes' estimate (WbcInput::unmeasured_force_world_n): its filter's time
// constant, and the magnitude the trot's foothold centring takes off it, the estimate's own
// error (the wrist tare's gravity residual when the hand turns, the feet's forces from the
// model: about 2 N in the shipped trots, which moved their footholds enough to worsen the
// rendering by a fifth). The support limit takes it whole: it acts near the edge only.
inline constexpr double kUnmeasuredForceFilter_s = 0.05;
inline constexpr double kUnmeasuredForceDeadband_n = 10.0;

// How fast the walking velocity follows its command.
inline constexpr double kWalkAcceleration_m_s2 = 0.5;
inline constexpr double kWalkYawAcceleration_rad_s2 = 1.0;
const char* to_string(GaitKind kind) noexcept;

struct GaitCommand {
  GaitKind kind = GaitKind::stand;
  gait::TrotParams trot;  // with kind == trot
};

// Live tuning: a new template (M, D, K per body and axis; with the rotational template on,
// its D, K per body and the hand's inertia too) and posture gains, reached linearly over
// ramp_s from the values of the tick it is taken (0: at once). Plain arrays: requests cross
// a lock-free ring by value. `set` says which are given; the rest keep their current values.
struct TuningRequest {
  enum Part : std::uint8_t {
    base_mass, base_damping, base_stiffness, ee_mass, ee_damping, ee_stiffness,  // translational
    rot_base_damping, rot_base_stiffness, rot_ee_inertia, rot_ee_damping, rot_ee_stiffness,
    kParts
  };
  static constexpr int kTranslationalParts = rot_base_damping;
  std::array<std::array<double, 3>, kParts> value{};
  std::array<bool, kParts> set{};
  double posture_kp_per_s2 = 0.0;
  double posture_kd_per_s = 0.0;
  bool set_posture_kp = false;
  bool set_posture_kd = false;
  double ramp_s = 1.0;
};
// The template's ranges, one table for the config's reader (springbok::params) and the
// tuning's check.
struct TuningRange {
  double lo, hi;
};
inline constexpr std::array<TuningRange, TuningRequest::kParts> kTemplateRanges{{
    {1e-6, 1e5}, {0.0, 1e6}, {1e-6, 1e7},    // base mass, damping, stiffness
    {1e-6, 1e4}, {0.0, 1e6}, {1e-6, 1e7},    // ee
    {0.0, 1e5}, {1e-6, 1e6},                 // rotational: base damping, stiffness
    {1e-6, 1e3}, {0.0, 1e4}, {1e-6, 1e5}}};  // hand inertia, damping, stiffness
inline constexpr TuningRange kPostureKpRange{0.0, 1e5}, kPostureKdRange{0.0, 1e4}, kTuningRampRange{0.0, 60.0};

// Stepping to catch a push standing cannot hold (beyond the paper). Standing, the support
// limit keeps the static centre of pressure of the weight and the pushes (the wrist's and the
// unmeasured ones) support_margin_m inside the feet by leaning the trunk against them; near
// the robot's tipping limit it cannot, and the CoP nears the feet's edge (or, pushed backwards,
// the front feet unload first: the static CoP leaves out the trunk's deceleration). When the CoP
// or its capture point (the CoP moved by the trunk's horizontal velocity times sqrt(h / g):
// where the trunk's motion would end) has been closer than trigger_inside_m to the edge, or a
// foot's normal force (the QP's, last tick) within unloaded_within_n of its minimum
// (wbc.normal_force_min_n), or a leg joint's torque at leg_torque_ratio of its limit at its
// angle (a hip or knee near the end of its range is weak on a hydraulic leg: pushed backwards,
// the base leans the hind hips toward their range's end, and their limit falls below what
// holding the base asks; stepping brings the feet back under the hips), for delay_s, the
// robot trots in place (the configured gait's cycle, params().gait.trot, without its
// velocity), its footholds centred under that CoP and leading the trunk's velocity by
// velocity_gain_s (the capture point's sqrt(h / g) for h ~ 0.6 m: the trot's foothold
// correction, at least this); once the trunk has stayed within settle_drift_m and the push
// within settle_push_change_n of where they were for settle_s, it stands again on the feet it
// has placed. Needs the support limit (wbc.contact.support_margin > 0): its CoP is the
// trigger. An operator's gait request takes over. What it holds, measured: firmware/control/README.md.
struct PushStepping {
  bool enabled = true;
  double trigger_inside_m = 0.02;  // half the default support margin
  double unloaded_within_n = 5.0;  // or a foot's normal force this close to the WBC's minimum
  double leg_torque_ratio = 0.95;  // or a leg joint's torque this fraction of its limit (> 1: off)
  double delay_s = 0.05;
  double velocity_gain_s = 0.25;   // the trot's foothold lead per trunk velocity (at least)
  double settle_s = 1.0;
  double settle_drift_m = 0.05;    // over settle_s: the trot's own sway is no drift
  double settle_push_change_n = 20.0;
};

struct ControlParams {
  wbc::WbcParams wbc;
  est::EstimatorParams estimator;
  GaitCommand gait;                  // the gait the controller engages with
  PushStepping push_stepping;
  std::uint32_t tare_samples = 500;  // wrist F/T readings a tare averages
};

enum class TickStatus : std::uint8_t {
  ok = 0,
  estimate_failed = 1,  // the base estimate is not ok (no IMU, a bad measurement, no foot down)
  qp_failed = 2,        // the whole-body QP has no solution this tick
};
const char* to_string(TickStatus status) noexcept;

// What the gait does now.
enum class GaitState : std::uint8_t { stand = 0, trot = 1, stopping = 2 };
const char* to_string(GaitState state) noexcept;

// The simulator's floating base (tool only): q[0:7] = [p_WB, quaternion xyzw],
// v[0:6] = [v_B, w_B] (trunk frame). The joints always come from the measurements.
struct BaseTruth {
  Vec<7> pose = Vec<7>::Zero();
  Vec6 twist = Vec6::Zero();
};

// The wrist F/T tare.
struct Tare {
  Vec3 force_n = Vec3::Zero();    // subtracted from the reading (EE frame)
  Vec3 torque_nm = Vec3::Zero();
  std::uint32_t samples = 0;      // readings collected by the running (or last) tare
  bool running = false;           // a tare is collecting readings
  std::uint32_t completed = 0;    // tares taken since start-up
};

// What the controller's last tick (observe() or tick()) did: the one value telemetry, the
// operator's `controller` report and the simulation's log copy from.
struct TickReport {
  TickStatus status = TickStatus::ok;  // of the last control-mode tick (ok before the first)
  bool engaged = false;
  GaitState gait = GaitState::stand;
  bool stepping_for_push = false;      // the trot under way is PushStepping's
  gait::TrotParams trot;               // of the running (or last) trot
  Stance stance = kAllFeet;
  std::uint64_t failed_ticks = 0;
  std::uint64_t stance_changes = 0;
  Tare tare;
  Vec3 wrist_force_n = Vec3::Zero();   // the reading less the tare (zero when not valid), sensor axes
  // The base estimate: q[0:7] = [p_WB, quaternion xyzw], v[0:6] = [v_B, w_B] (trunk axes).
  Vec<7> base_pose = Vec<7>::Zero();
  Vec6 base_twist = Vec6::Zero();
  // The estimator's gyro bias (filter ekf: the EKF's estimate once it runs, before it the start-up
  // calibration's; IMU axes) and the still time that calibration averaged (0: none).
  Vec3 gyro_bias_i_rad_s = Vec3::Zero();
  double gyro_calibrated_s = 0.0;
  // The whole-body controller's, from its last engaged tick.
  qp::Status qp_status = qp::Status::bad_input;
  int qp_iterations = 0;
  bool arm_overloaded = false;
  bool support_limited = false;
  Vec3 base_rest_m = Vec3::Zero();             // the template's rest pose (world)
  Vec3 hand_rest_m = Vec3::Zero();
  Mat3 hand_rest_rotation = Mat3::Identity();
  Vec3 base_displacement_m = Vec3::Zero();     // x_b, x_e
  Vec3 hand_displacement_m = Vec3::Zero();
  Mat3 hand_rotation = Mat3::Identity();       // the hand's orientation (world)
  Vec3 external_force_world_n = Vec3::Zero();  // F_e, T_e
  Vec3 external_torque_world_nm = Vec3::Zero();
  Vec3 unmeasured_force_world_n = Vec3::Zero();
  std::array<Vec3, kFeet> foot_force_n{};      // the QP's, world axes
};

class RobotController {
 public:
  // Start-up: allocates the QP and the dynamics workspace once.
  explicit RobotController(const ControlParams& params);
  ~RobotController();
  RobotController(const RobotController&) = delete;
  RobotController& operator=(const RobotController&) = delete;

  // The horizontal position the estimator starts from (default 0, 0). Start-up.
  void set_start_position_xy(const Eigen::Vector2d& xy_m) noexcept { start_xy_m_ = xy_m; }

  // A tick outside the control mode: the estimator on four feet; `standing_still`
  // (the stand mode, the tool's settle) lets the tare collect. rt: no alloc, no block
  void observe(const hal::Measurements& m, double dt_s, bool standing_still) noexcept;
  // A tick before the first observe() (idle: the robot lying, damped): the estimator's start-up
  // gyro calibration (BaseEstimator::calibrate). rt: no alloc, no block
  void calibrate(const hal::Measurements& m, double dt_s) noexcept;

  // One control-mode tick. Writes `cmd` (torque mode) only when it returns ok.
  // `truth` (tool only) replaces the estimated base. rt: no alloc, no block
  TickStatus tick(const hal::Measurements& m, double dt_s, hal::JointCommands& cmd,
                  const BaseTruth* truth = nullptr) noexcept;

  // Leaving the control mode: the next tick() engages anew, with the configured
  // gait (params().gait; an operator's gait request ends with the mode). rt: no alloc
  void disengage() noexcept {
    engaged_ = false;
    requested_gait_ = params_.gait;
    gait_request_pending_ = false;
    tune_.pending = tune_.active = false;  // a ramp under way stops where it is
  }

  // Operator requests, taken at the next tick. request_gait refuses (false) a
  // trot with parameters outside read_trot_params' ranges. rt: no alloc
  bool request_gait(const GaitCommand& command) noexcept;
  void request_tare() noexcept;
  // Walking: a new trunk velocity [v_x, v_y, yaw rate] (m/s, m/s, rad/s, the trunk's
  // horizontal frame) for the running trot, without restarting it; refused (false)
  // outside kTrotFields' velocity ranges. The rest pose follows it, ramped at
  // kWalkAcceleration_m_s2 / kWalkYawAcceleration_rad_s2; a stand request ramps it to 0.
  // rt: no alloc
  bool request_velocity(const Vec3& velocity) noexcept;
  // Live tuning, in the control mode: refused (why; nothing changes) with a value outside
  // kTemplateRanges / the posture ranges or not finite, or a rotational part without the
  // rotational template; otherwise (nullptr) the ramp starts at the next tick from the
  // values then (a ramp under way is replaced from where it is). rt: no alloc
  const char* request_tuning(const TuningRequest& request) noexcept;
  bool tuning() const noexcept { return tune_.active; }
  // Hand pose commands (hand_trajectory.hpp): the waypoints the hand's rest pose follows
  // from each engagement on (start-up; "" or why not), and an operator's move of it to an
  // offset and a rotation from the engaged rest pose over duration_s, in the control mode
  // (nullptr or why not; nothing changes then). Turning the hand needs the rotational
  // template (without it the hand's orientation is free). rt: no alloc (the move)
  std::string set_hand_trajectory(std::span<const HandWaypoint> waypoints);
  const char* request_hand_move(const Vec3& target_m, const Vec3& target_rotation_rad, double duration_s) noexcept;
  const HandTrajectory& hand_trajectory() const noexcept { return hand_; }
  double control_time_s() const noexcept { return control_time_s_; }
  const Vec3& walking_velocity() const noexcept { return velocity_now_; }

  // The last tick's report (observe() and tick() fill it). rt: no alloc
  const TickReport& report() const noexcept { return report_; }
  bool engaged() const noexcept { return engaged_; }
  const RobotState& state() const noexcept { return state_; }
  const est::BaseEstimate& estimate() const noexcept { return estimator_.estimate(); }
  const wbc::WbcOutput& output() const noexcept { return wbc_->output(); }
  const wbc::WholeBodyController& wbc() const noexcept { return *wbc_; }
  // What the WBC got this tick (state, swing targets, force bounds, wrist wrench).
  const wbc::WbcInput& input() const noexcept { return input_; }
  const gait::TrotGait& trot() const noexcept { return trot_; }
  // The ground force on each foot estimated from its leg (world, N), this tick's.
  const std::array<Vec3, kFeet>& foot_force_estimate_n() const noexcept { return foot_forces_.force_world_n(); }
  GaitState gait_state() const noexcept { return gait_state_; }
  // The trot under way was started by a push standing could not hold (PushStepping).
  bool stepping_for_push() const noexcept { return stepping_for_push_; }
  const Tare& tare() const noexcept { return tare_; }
  // The wrist wrench the controller used this tick (tared; zero when not valid), EE frame.
  const Vec3& wrist_force_n() const noexcept { return wrist_force_n_; }
  std::uint64_t stance_changes() const noexcept { return stance_changes_; }
  std::uint64_t failed_ticks() const noexcept { return failed_ticks_; }
  const ControlParams& params() const noexcept { return params_; }

 private:
  // The tick's report; `control_tick`: a control-mode tick, whose status it is. rt: no alloc
  TickStatus report_tick(TickStatus status, bool control_tick) noexcept;
  void report_gyro_bias() noexcept;  // the report's gyro bias and calibration. rt: no alloc
  // The estimator's tick (reset on the first one and after a gap in m.sequence).
  est::EstimateStatus estimate(const hal::Measurements& m, double dt_s, const Stance& stance) noexcept;
  void take_wrist(const hal::Measurements& m, bool collect) noexcept;
  void plan_gait(double dt_s, bool engaging) noexcept;
  void begin_trot(const gait::TrotParams& p) noexcept;
  void observe_unmeasured_force(double dt_s, bool engaging) noexcept;
  bool push_needs_a_step(double dt_s) noexcept;
  bool push_settled(double dt_s) noexcept;
  void move_rest_pose(double dt_s) noexcept;
  Vec3 footholds_shift_h(const Mat3& yaw) const noexcept;

  ControlParams params_;
  dyn::Model model_;
  std::unique_ptr<dyn::Data> data_;
  est::BaseEstimator estimator_;
  est::FootForceObserver foot_forces_;
  std::unique_ptr<wbc::WholeBodyController> wbc_;
  gait::TrotGait trot_;
  wbc::WbcInput input_;       // input_.state is the tick's RobotState
  Vec3 wrist_force_n_ = Vec3::Zero();    // the tick's wrist reading less the tare, sensor axes
  Vec3 wrist_torque_nm_ = Vec3::Zero();  // (in world axes: input_, after the kinematics)
  RobotState& state_ = input_.state;
  Eigen::Vector2d start_xy_m_ = Eigen::Vector2d::Zero();
  bool have_sequence_ = false;
  std::uint64_t last_sequence_ = 0;
  bool engaged_ = false;
  GaitState gait_state_ = GaitState::stand;
  GaitCommand requested_gait_;
  bool gait_request_pending_ = false;
  double gait_time_s_ = 0.0;
  bool stepping_for_push_ = false;  // the trot is PushStepping's
  double push_near_edge_s_ = 0.0;   // standing: how long the push's CoP has been near the feet's edge
  double push_settled_s_ = 0.0;     // stepping: how long the robot has been settled
  Vec3 push_at_settle_n_ = Vec3::Zero();  // the push and the base when the settled interval began
  Vec3 base_at_settle_m_ = Vec3::Zero();
  Vec3 velocity_command_ = Vec3::Zero();  // [v_x, v_y, yaw rate] in H, while trotting
  Vec3 velocity_now_ = Vec3::Zero();      // the command ramped (kWalkAcceleration*)
  wbc::PlanarMotion motion_;              // of the template's rest pose since engaging
  struct TuneRamp {
    bool pending = false;            // taken at the next tick
    bool active = false;
    TuningRequest request;
    wbc::TemplateParams from, to;
    wbc::RotationalTemplateParams rot_from, rot_to;
    double kp_from = 0.0, kp_to = 0.0, kd_from = 0.0, kd_to = 0.0;
    double elapsed_s = 0.0;
  } tune_;
  void step_tuning(double dt_s) noexcept;
  Tare tare_;
  HandTrajectory configured_hand_;        // set_hand_trajectory's, restarted at each engagement
  HandTrajectory hand_;                   // the one followed (an operator's move replaces it)
  double control_time_s_ = 0.0;           // since the engagement
  Vec3 tare_force_sum_n_ = Vec3::Zero(), tare_torque_sum_nm_ = Vec3::Zero();
  std::uint64_t stance_changes_ = 0;
  std::uint64_t failed_ticks_ = 0;
  TickReport report_;
};

// The robot's centre of mass (world) from the mass matrix's base block: about the
// trunk origin in trunk axes, M[0:3, 3:6] = -m [c_B]x. rt: no alloc
Vec3 center_of_mass_from_inertia(const MatNv& mass_matrix, const RobotState& state) noexcept;

}  // namespace springbok::control
