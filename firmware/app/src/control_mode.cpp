#include "springbok/app/control_mode.hpp"

namespace springbok::app {

control::ControlParams control_params(const AppConfig& config) {
  control::ControlParams p;
  p.wbc = config.wbc;
  p.estimator = config.estimator;
  p.gait = config.gait;
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
const char* ControlMode::request(const ControllerRequest& r, safety::Mode mode) noexcept {
  if (kind_ != ControlModeKind::wbc) return kNotTheWbc;
  switch (r.kind) {
    case ControllerRequest::Kind::gait:
      if (mode != safety::Mode::control) return "gait changes need mode control";
      return control_->request_gait(r.gait) ? nullptr : "gait parameters out of range";
    case ControllerRequest::Kind::tare:
      control_->request_tare();  // collected while the robot stands (observe)
      return nullptr;
    case ControllerRequest::Kind::walk:
      if (mode != safety::Mode::control || control_->gait_state() != control::GaitState::trot) {
        return "walking needs the trot (mode control, gait trot)";
      }
      return control_->request_velocity(Vec3(r.velocity[0], r.velocity[1], r.velocity[2]))
                 ? nullptr
                 : "walking velocity out of range";
  }
  return "unknown request";
}

// rt: no alloc, no block
void ControlMode::publish(rt::LatestValue<ControllerSnapshot>& out) noexcept {
  ControllerSnapshot s;
  s.wbc = kind_ == ControlModeKind::wbc;
  if (s.wbc) {
    const control::WholeBodyControl& c = *control_;
    s.engaged = c.engaged();
    s.gait = c.gait_state();
    s.trot = c.trot().params();
    s.last_tick = last_status_;
    s.stance = c.state().stance;
    s.failed_ticks = c.failed_ticks();
    s.stance_changes = c.stance_changes();
    s.tare = c.tare();
    s.wrist_force_n = c.wrist_force_n();
    s.base_position_m = c.state().q.head<3>();
    s.base_velocity_m_s = c.state().rotation_wb * c.state().v.head<3>();
  }
  out.publish(s);
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
