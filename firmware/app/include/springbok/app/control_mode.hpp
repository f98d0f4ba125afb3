// The control mode's controller, as configured (control.controller):
//
//   wbc:      springbok::control::RobotController, the paper's whole-body
//             controller on the base state estimated from the IMU and leg
//             kinematics, F_e from the wrist F/T (tared in stand), stand or trot
//             as the operator asks. The estimator runs from stand-up on (observe);
//             entering the control mode engages: the pose of that instant is the
//             template's reference. A failed tick (estimate not ok, QP failure)
//             reports it and leaves the command to the supervisor (the last good
//             command, damping after a streak).
//   joint_pd: hold the stand posture with gains.control (bring-up, no IMU).
#pragma once

#include <memory>

#include "springbok/app/config.hpp"
#include "springbok/app/mode_controller.hpp"
#include "springbok/control/robot_controller.hpp"

namespace springbok::app {

class ControlMode {
 public:
  explicit ControlMode(const AppConfig& config);
  ~ControlMode();

  // rt: no alloc, no block
  safety::ControllerReport compute(const ControlInput& in, hal::JointCommands& cmd) noexcept;
  // Stand-up and stand ticks. rt: no alloc, no block
  void observe(const ControlInput& in) noexcept;
  // Gait changes in the control mode; a tare in any mode. rt: no alloc, no block
  const char* request(const ControllerRequest& r, safety::Mode mode) noexcept;
  void publish(rt::LatestValue<ControllerSnapshot>& out) noexcept;  // rt: no alloc, no block
  // The whole-body controller can take over once the wrist F/T is tared (no tare being taken). rt
  bool ready() const noexcept;
  // Idle ticks: the estimator's start-up calibration (the robot lying still). rt: no alloc, no block
  void idle(const ControlInput& in) noexcept;
  // The controller's tick report (the estimate, the template's rest pose and displacements,
  // F_e, the QP's forces and status) into a telemetry record (the whole-body controller
  // only). rt: no alloc, no block
  void telemetry(TelemetryRecord& r) const noexcept;

  // The simulator's ground truth for the base, read by every control tick instead of the
  // estimate (springbok-sim, where a scenario asks for it; the caller keeps `truth` current
  // and alive); nullptr: the estimate, as on the robot. Start-up.
  void use_base_truth(const control::BaseTruth* truth) noexcept { base_truth_ = truth; }

  control::RobotController& controller() noexcept { return *control_; }
  const control::RobotController& controller() const noexcept { return *control_; }

 private:
  ControlModeKind kind_;
  JointPdHold hold_;
  std::unique_ptr<control::RobotController> control_;
  const control::BaseTruth* base_truth_ = nullptr;
};

static_assert(ControlLaw<ControlMode>);
static_assert(ControlLaw<JointPdHold>);

}  // namespace springbok::app
