// controller.type: wbc — the firmware (springbok::app::Firmware: the safety supervisor, the
// mode controller and the control mode's whole-body controller, the loop that `springbok` and
// `springbok-on-sim` run) over the Bullet robot's HAL in lockstep, the scenario as its operator.
//
// The run goes through the supervisor's modes as on the robot: the operator's `start`, then
// stand_up, done before the physics starts (the stand posture is the scenario's initial one,
// stand_up_duration_s one tick), then stand from t = 0, in which the mode controller holds the
// posture with the robot's weight as feed-forward (gains.stand_feed_forward weight) for
// `controller.settle_s` seconds while the robot settles on its feet and the controller
// observes (its estimator runs, the wrist F/T is tared);
// the operator's `mode control` at settle_s: the controller engages (the pose of that instant
// is the template's reference) and runs from then on. A failed controller tick gets the
// supervisor's command (the last good one, damping after a streak), as on the robot.
//
// The tool's own parts: the ground-truth hook (without `controller.params.estimator` the
// control mode reads the base pose and twist from the simulator, with it from its estimator,
// as on hardware: ControlMode::use_base_truth), the scenario's operator (start, mode
// control, gait.velocity_schedule's walk requests), the scoring and the CSV.
// `controller.params.gait` makes the controller trot (springbok::gait::TrotGait).
//
// After each physics step it logs the measured base and EE displacements from
// the reference pose (world; positions, and orientations as rotation vectors), the
// template driven by the measured wrist force (and the rotational one by the wrist
// torque, when it is on),
// F_e, the foot forces, the QP status and iterations and the firmware tick's
// compute time (read to write); at the end it scores the run (nrmse, steady_state_error,
// peak_deviation, chirp_gain_db_error, qp_failures, max_torque_ratio,
// joint_limit_hit, tick_us). Definitions: tools/scenarios/README.md.
#pragma once

#include <memory>
#include <optional>
#include <vector>

#include "controller.hpp"
#include "estimator_errors.hpp"
#include "scenario.hpp"
#include "springbok/app/config.hpp"
#include "springbok/app/firmware.hpp"
#include "springbok/control/robot_controller.hpp"
#include "springbok/dynamics/dynamics.hpp"
#include "springbok/wbc/impedance_template.hpp"
#include "springbok/wbc/whole_body_controller.hpp"

namespace springbok::simtool {

class WbcAdapter final : public Controller {
 public:
  // `params` is the scenario's controller.params; its problems go to params.errors() (the
  // caller refuses the scenario when there are any). The firmware runs over `robot`.
  WbcAdapter(const Scenario& scenario, const yaml::Field& params, sim::BulletRobot& robot);
  ~WbcAdapter() override;

  bool tick(sim::BulletRobot& robot, std::int64_t k) noexcept override;
  std::string csv_columns() const override;
  void after_step(const sim::GroundTruth& truth, std::string& row) override;
  std::string summary_fields() const override;

  // The firmware's configuration made from the scenario (the stand posture, gains, the
  // controller's parameters), as springbok-on-sim would run it.
  const app::AppConfig& config() const noexcept { return config_; }
  // Every operator request the scenario posted, with the tick whose loop took it.
  struct Posted {
    std::uint64_t tick;  // the firmware tick that took it
    app::OperatorRequest request;
  };
  const std::vector<Posted>& posted() const noexcept { return posted_; }
  // One firmware tick as the loop saw it.
  struct FirmwareTick {
    hal::Measurements meas;
    hal::JointCommands cmd;
    safety::Mode mode;  // the mode it computed in
  };
  // Every firmware tick from the next on is appended to `ticks` (nullptr: none; a test's recording).
  void record(std::vector<FirmwareTick>* ticks) noexcept { recording_ = ticks; }
  const control::RobotController& controller() const noexcept { return firmware_->control().controller(); }

 private:
  // base x y z, ee x y z [m], then the orientation displacements from the rest pose
  // (rotation vectors, world) base rx ry rz, ee rx ry rz [rad]: reference 0 where the
  // rotational template is off.
  static constexpr int kAxes = 12;
  struct Sample {
    double time_s;
    std::array<double, kAxes> measured;
    std::array<double, kAxes> reference;
    Vec6 base_wrench_error;  // W_b^d - the solution's base wrench [N, N m]
    Vec3 force_world_n;
    Vec3 torque_world_nm;
  };

  wbc::WbcParams params_;
  double dt_s_;
  double settle_s_;
  double still_start_s_;
  int idle_columns_;  // csv_columns()'s count: the zeros of a row before the WBC's first tick
  bool step_profile_ = false;                       // only step/constant forces: steady state is scored
  std::optional<sim::ForceProfile> chirp_;          // the first chirp, for the gain estimate
  Vec3 chirp_axis_ = Vec3::UnitX();
  bool use_estimator_ = false;                      // state_source: estimated (false: truth)
  bool trot_ = false;
  // controller.params.gait.velocity_schedule: at at_s, the operator's walk or gait request.
  struct ScheduledRequest {
    double at_s;
    app::ControllerRequest request;
  };
  std::vector<ScheduledRequest> velocity_schedule_;
  std::size_t next_velocity_change_ = 0;
  // The trunk's velocity in its horizontal frame [x, y, yaw rate], control ticks (gait.mean_velocity).
  std::vector<Vec3> trunk_velocity_h_;
  app::AppConfig config_;
  control::BaseTruth base_truth_;                   // the ground-truth hook's value, this tick
  std::unique_ptr<app::Firmware> firmware_;
  std::vector<Posted> posted_;                      // reserved: posting does not allocate
  std::vector<std::string> refusals_;               // the operator's requests the firmware refused
  std::unique_ptr<wbc::TemplateReference> template_;
  // The rotational template driven by the measured wrist torque (controller.params.
  // rotational_template), made at engagement: its I_b is the WBC's then.
  std::optional<wbc::TemplateReference> rotational_template_;
  safety::Mode tick_mode_ = safety::Mode::idle;   // the mode the firmware computed in, this tick
  // The firmware ticks of its stand-up, before the physics starts (stand_up_duration_s is one tick).
  static constexpr int kStandUpTicks = 2;
  std::uint64_t firmware_ticks_ = 0;
  std::vector<FirmwareTick>* recording_ = nullptr;
  // Into the firmware's mailbox, taken by its next tick. rt: no alloc
  void post(const app::OperatorRequest& request) noexcept;
  // One tick of the firmware (read -> observe -> compute -> finish -> write; no physics step).
  void firmware_tick(const sim::GroundTruth& truth) noexcept;
  EstimatorErrors estimator_errors_;                // the estimate vs the ground truth, WBC ticks
  Eigen::Matrix<double, 7, 1> truth_before_step_pose_ = Eigen::Matrix<double, 7, 1>::Zero();
  Vec3 truth_before_step_v_ = Vec3::Zero();
  dyn::Model model_;
  std::unique_ptr<dyn::Data> data_;                 // the ground truth's kinematics, for scoring
  bool ticked_ = false;                             // the controller ran this tick
  control::TickStatus status_ = control::TickStatus::ok;
  double tick_us_ = 0.0;
  std::vector<Sample> samples_;
  std::vector<double> tick_us_all_;
  std::vector<double> qp_iterations_all_;
  int tick_faults_ = 0;    // page faults (minor + major) of the thread during this tick
  int tick_switches_ = 0;  // its context switches (voluntary + involuntary) during it
  struct SlowTick {
    double tick_us = 0.0;
    double time_s = 0.0;
    int faults = 0;
    int switches = 0;
    int qp_iterations = 0;
    bool qp_from_hint = false;
    bool first = false;  // the WBC's first tick
  } slowest_;
  double max_torque_ratio_ = 0.0;
  std::array<std::uint64_t, kNj> torque_limit_ticks_{};   // |tau| >= kAtLimit of the limit, per joint
  std::uint64_t any_torque_limit_ticks_ = 0;              // ticks with some joint there
  std::uint64_t arm_overloaded_ticks_ = 0;                // ticks the arm yielded to a push it could not hold
  std::uint64_t support_limited_ticks_ = 0;               // ticks the base was held back from its support's edge
  std::uint64_t push_stepping_ticks_ = 0;                 // ticks trotting for a push (control::PushStepping)
  std::uint64_t push_steppings_ = 0;                      // times it started
  bool was_stepping_for_push_ = false;
  double max_speed_ratio_ = 0.0;                          // max |qd| / velocity limit
  int max_speed_joint_ = 0;
  std::uint64_t failed_ticks_ = 0;
  std::uint64_t qp_from_hint_ticks_ = 0;  // ticks whose QP was solved on the last tick's active set
  bool joint_limit_hit_ = false;
  std::string joint_limit_joint_;
};

}  // namespace springbok::simtool
