// The control mode's controller, as configured (control.controller):
//
//   wbc:      the paper's whole-body controller (springbok::wbc) on the base
//             state estimated from the IMU and leg kinematics (springbok::est),
//             F_e from the wrist F/T sensor, all four feet in stance. On entry
//             (ticks_in_mode == 0) the estimator is reset over the four feet and
//             the WBC takes the pose of that instant as its reference. A tick
//             whose estimate is not ok (no IMU, a non-finite sensor, ...) or whose
//             QP fails reports a failure (the supervisor's streak moves to damping)
//             and commands safe torques: the stand posture's joint PD.
//   joint_pd: hold the stand posture with gains.control (bring-up, no IMU).
#pragma once

#include <memory>

#include "springbok/app/config.hpp"
#include "springbok/app/posture_control.hpp"
#include "springbok/estimation/base_estimator.hpp"
#include "springbok/wbc/whole_body_controller.hpp"

namespace springbok::app {

class ControlMode {
 public:
  explicit ControlMode(const AppConfig& config);
  ~ControlMode();

  // rt: no alloc, no block
  safety::ControllerReport compute(const ControlInput& in, hal::JointCommands& cmd) noexcept;

  const est::BaseEstimate& estimate() const noexcept { return estimator_->estimate(); }
  const wbc::WbcOutput& wbc_output() const noexcept { return wbc_->output(); }
  std::uint64_t failed_ticks() const noexcept { return failed_ticks_; }

 private:
  safety::ControllerReport hold(const ControlInput& in, hal::JointCommands& cmd) noexcept;

  ControlModeKind kind_;
  JointPdHold hold_;
  std::unique_ptr<est::BaseEstimator> estimator_;
  std::unique_ptr<wbc::WholeBodyController> wbc_;
  std::unique_ptr<wbc::WbcInput> input_;
  bool engaged_ = false;  // reset and reference taken in this control mode
  std::uint64_t failed_ticks_ = 0;
};

static_assert(ControlModeController<ControlMode>);
static_assert(ControlModeController<JointPdHold>);

}  // namespace springbok::app
