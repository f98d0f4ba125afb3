#include "springbok/app/control_mode.hpp"

namespace springbok::app {

control::ControlParams control_params(const AppConfig& config) {
  control::ControlParams p;
  p.wbc = config.wbc;
  p.estimator = config.estimator;
  p.tare_samples = config.wrist_tare_samples;
  return p;
}

ControlMode::ControlMode(const AppConfig& config)
    : kind_(config.control_mode),
      hold_(config),
      control_(std::make_unique<control::WholeBodyControl>(control_params(config))) {}

ControlMode::~ControlMode() = default;

// rt: no alloc, no block
void ControlMode::observe(const ControlInput& in) noexcept {
  if (kind_ == ControlModeKind::wbc) control_->observe(*in.meas, in.dt_s, in.mode == safety::Mode::stand);
}

// rt: no alloc, no block
safety::ControllerReport ControlMode::compute(const ControlInput& in, hal::JointCommands& cmd) noexcept {
  if (kind_ == ControlModeKind::joint_pd) return hold_.compute(in, cmd);
  if (in.ticks_in_mode == 0) control_->disengage();  // entering the control mode: engage anew
  last_status_ = control_->tick(*in.meas, in.dt_s, cmd);
  safety::ControllerReport report;
  report.ok = last_status_ == control::TickStatus::ok;
  return report;
}

}  // namespace springbok::app
