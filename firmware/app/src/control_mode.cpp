#include "springbok/app/control_mode.hpp"

#include <algorithm>
#include <cmath>

#include <Eigen/Geometry>

namespace springbok::app {

ControlMode::ControlMode(const AppConfig& config)
    : kind_(config.control_mode),
      hold_(config),
      control_(std::make_unique<control::RobotController>(config.control)) {}

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
void ControlMode::idle(const ControlInput& in) noexcept {
  if (kind_ == ControlModeKind::wbc) control_->calibrate(*in.meas, in.dt_s);
}

// rt: no alloc, no block
bool ControlMode::ready() const noexcept { return kind_ != ControlModeKind::wbc || !control_->tare().running; }

// rt: no alloc, no block
void ControlMode::publish(rt::LatestValue<ControllerSnapshot>& out) noexcept {
  ControllerSnapshot s;
  s.wbc = kind_ == ControlModeKind::wbc;
  if (s.wbc) s.report = control_->report();
  out.publish(s);
}

// rt: no alloc, no block
void ControlMode::telemetry(TelemetryRecord& t) const noexcept {
  t.wbc = kind_ == ControlModeKind::wbc;
  if (!t.wbc) return;
  const control::TickReport& r = control_->report();
  const auto put = [](Triple& to, const Vec3& from) { to = {from.x(), from.y(), from.z()}; };
  const auto put_quaternion = [](std::array<double, 4>& to, const Mat3& from) {
    const Quat q(from);
    to = {q.x(), q.y(), q.z(), q.w()};
  };
  // The base: the estimate (what the controller uses; also before it engages).
  const Quat quat = Quat(r.base_pose[6], r.base_pose[3], r.base_pose[4], r.base_pose[5]).normalized();
  const Mat3 rot = quat.toRotationMatrix();
  put(t.base_position_m, r.base_pose.head<3>());
  t.base_quaternion_xyzw = {quat.x(), quat.y(), quat.z(), quat.w()};
  t.base_rpy_rad = {std::atan2(rot(2, 1), rot(2, 2)), std::asin(std::clamp(-rot(2, 0), -1.0, 1.0)),
                    std::atan2(rot(1, 0), rot(0, 0))};
  put(t.base_velocity_m_s, rot * r.base_twist.head<3>());
  put(t.base_rate_rad_s, rot * r.base_twist.tail<3>());
  t.engaged = r.engaged;
  t.tick_status = static_cast<std::uint8_t>(r.status);
  for (int f = 0; f < kFeet; ++f) t.stance[static_cast<std::size_t>(f)] = r.stance[f];
  if (!t.engaged) return;
  t.qp_status = static_cast<std::uint8_t>(r.qp_status);
  t.qp_iterations = r.qp_iterations;
  t.arm_overloaded = r.arm_overloaded;
  t.support_limited = r.support_limited;
  t.stepping_for_push = r.stepping_for_push;
  put(t.base_rest_m, r.base_rest_m);
  put(t.hand_rest_m, r.hand_rest_m);
  put(t.base_displacement_m, r.base_displacement_m);
  put(t.hand_displacement_m, r.hand_displacement_m);
  put(t.hand_position_m, r.hand_rest_m + r.hand_displacement_m);
  put_quaternion(t.hand_quaternion_xyzw, r.hand_rotation);
  put_quaternion(t.hand_rest_quaternion_xyzw, r.hand_rest_rotation);
  put(t.external_force_n, r.external_force_world_n);
  put(t.external_torque_nm, r.external_torque_world_nm);
  put(t.unmeasured_force_n, r.unmeasured_force_world_n);
  for (int f = 0; f < kFeet; ++f) put(t.foot_force_n[static_cast<std::size_t>(f)], r.foot_force_n[f]);
}

// rt: no alloc, no block
safety::ControllerReport ControlMode::compute(const ControlInput& in, hal::JointCommands& cmd) noexcept {
  if (kind_ == ControlModeKind::joint_pd) return hold_.compute(in, cmd);
  if (in.ticks_in_mode == 0) control_->disengage();  // entering the control mode: engage anew
  safety::ControllerReport report;
  report.ok = control_->tick(*in.meas, in.dt_s, cmd, base_truth_) == control::TickStatus::ok;
  return report;
}

}  // namespace springbok::app
