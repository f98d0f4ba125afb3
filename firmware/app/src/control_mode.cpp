#include "springbok/app/control_mode.hpp"

#include <algorithm>
#include <cmath>

#include <Eigen/Geometry>

namespace springbok::app {

control::ControlParams control_params(const AppConfig& config) {
  control::ControlParams p;
  p.wbc = config.wbc;
  p.estimator = config.estimator;
  p.gait = config.gait;
  p.push_stepping = config.push_stepping;
  p.tare_samples = config.wrist_tare_samples;
  return p;
}

ControlMode::ControlMode(const AppConfig& config)
    : kind_(config.control_mode),
      hold_(config),
      control_(std::make_unique<control::RobotController>(control_params(config))) {}

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
    case ControllerRequest::Kind::hand:
      if (mode != safety::Mode::control) return "hand moves need mode control";
      return control_->request_hand_move(Vec3(r.hand_target[0], r.hand_target[1], r.hand_target[2]),
                                         Vec3(r.hand_rotation[0], r.hand_rotation[1], r.hand_rotation[2]),
                                         r.hand_duration_s);
    case ControllerRequest::Kind::tune:
      if (mode != safety::Mode::control) return "tuning needs mode control";
      return control_->request_tuning(r.tune);
  }
  return "unknown request";
}

// rt: no alloc, no block
void ControlMode::publish(rt::LatestValue<ControllerSnapshot>& out) noexcept {
  ControllerSnapshot s;
  s.wbc = kind_ == ControlModeKind::wbc;
  if (s.wbc) {
    const control::RobotController& c = *control_;
    s.engaged = c.engaged();
    s.gait = c.gait_state();
    s.stepping_for_push = c.stepping_for_push();
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
void ControlMode::telemetry(TelemetryRecord& r) const noexcept {
  r.wbc = kind_ == ControlModeKind::wbc;
  if (!r.wbc) return;
  const control::RobotController& c = *control_;
  const auto put = [](Triple& to, const Vec3& from) { to = {from.x(), from.y(), from.z()}; };
  const auto put_quaternion = [](std::array<double, 4>& to, const Mat3& from) {
    const Quat q(from);
    to = {q.x(), q.y(), q.z(), q.w()};
  };
  // The base: the estimate (what the controller uses; also before it engages).
  const est::BaseEstimate& e = c.estimate();
  const Quat quat = Quat(e.q[6], e.q[3], e.q[4], e.q[5]).normalized();
  const Mat3 rot = quat.toRotationMatrix();
  put(r.base_position_m, e.q.head<3>());
  r.base_quaternion_xyzw = {quat.x(), quat.y(), quat.z(), quat.w()};
  r.base_rpy_rad = {std::atan2(rot(2, 1), rot(2, 2)), std::asin(std::clamp(-rot(2, 0), -1.0, 1.0)),
                    std::atan2(rot(1, 0), rot(0, 0))};
  put(r.base_velocity_m_s, rot * e.v.head<3>());
  put(r.base_rate_rad_s, rot * e.v.segment<3>(3));
  r.engaged = c.engaged();
  r.tick_status = static_cast<std::uint8_t>(last_status_);
  for (int f = 0; f < kFeet; ++f) r.stance[static_cast<std::size_t>(f)] = c.state().stance[f];
  if (!r.engaged) return;
  const wbc::WbcOutput& o = c.output();
  const wbc::WbcReference& ref = c.wbc().reference();
  r.qp_status = static_cast<std::uint8_t>(o.qp_status);
  r.qp_iterations = o.qp_iterations;
  r.arm_overloaded = o.arm_overloaded;
  r.support_limited = o.support_limited;
  r.stepping_for_push = c.stepping_for_push();
  put(r.base_rest_m, ref.base_position_m);
  put(r.hand_rest_m, ref.ee_position_m);
  put(r.base_displacement_m, o.base_displacement_m);
  put(r.hand_displacement_m, o.ee_displacement_m);
  put(r.hand_position_m, ref.ee_position_m + o.ee_displacement_m);
  put_quaternion(r.hand_quaternion_xyzw, o.ee_rotation);
  put_quaternion(r.hand_rest_quaternion_xyzw, ref.ee_rotation);
  put(r.external_force_n, o.external_force_world_n);
  put(r.external_torque_nm, o.external_torque_world_nm);
  put(r.unmeasured_force_n, c.input().unmeasured_force_world_n);
  for (int f = 0; f < kFeet; ++f) put(r.foot_force_n[static_cast<std::size_t>(f)], o.foot_force_n[f]);
}

// rt: no alloc, no block
safety::ControllerReport ControlMode::compute(const ControlInput& in, hal::JointCommands& cmd) noexcept {
  if (kind_ == ControlModeKind::joint_pd) return hold_.compute(in, cmd);
  if (in.ticks_in_mode == 0) control_->disengage();  // entering the control mode: engage anew
  last_status_ = control_->tick(*in.meas, in.dt_s, cmd, base_truth_);
  safety::ControllerReport report;
  report.ok = last_status_ == control::TickStatus::ok;
  return report;
}

}  // namespace springbok::app
