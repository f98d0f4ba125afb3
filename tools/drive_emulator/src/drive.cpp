// What the drives of both protocols share: the joint they move, the fault script's names, the
// fault injection and the frames' way out (the protocols: mit_drive.cpp, cia402_drive.cpp).
#include "springbok/drive_emulator/drives.hpp"

#include <algorithm>
#include <cmath>

#include "springbok/can/socketcan.hpp"
#include "springbok/model/model.hpp"

namespace springbok::emu {

using can::Frame;

void JointModel::step(double tau_cmd_nm, double dt_s) noexcept {
  tau_nm = tau_cmd_nm;
  const double qdd = (tau_cmd_nm - viscous_nms_per_rad * qd_rad_s) / inertia_kgm2;
  qd_rad_s = std::clamp(qd_rad_s + qdd * dt_s, -v_max_rad_s, v_max_rad_s);
  q_rad += qd_rad_s * dt_s;
  if (bounded && (q_rad < lower_rad || q_rad > upper_rad)) {
    q_rad = std::clamp(q_rad, lower_rad, upper_rad);
    qd_rad_s = 0.0;
  }
}

JointModel make_joint_model(int joint, double q0_rad) {
  const auto& lim = robot::kJoints[static_cast<std::size_t>(joint)].limits;
  JointModel m;
  m.q_rad = q0_rad;
  m.v_max_rad_s = 0.9 * lim.velocity_rad_s;  // below the host's plausibility bound
  m.bounded = lim.bounded;
  m.lower_rad = lim.lower_rad;
  m.upper_rad = lim.upper_rad;
  return m;
}

const char* to_string(FaultKind k) noexcept {
  switch (k) {
    case FaultKind::drop: return "drop";
    case FaultKind::delay: return "delay";
    case FaultKind::duplicate: return "duplicate";
    case FaultKind::corrupt: return "corrupt";
    case FaultKind::silent: return "silent";
    case FaultKind::no_heartbeat: return "no_heartbeat";
    case FaultKind::rated_torque: return "rated_torque";
    case FaultKind::mode_display_delay: return "mode_display_delay";
    case FaultKind::enable_blocked: return "enable_blocked";
    case FaultKind::vendor_error: return "vendor_error";
    case FaultKind::emcy: return "emcy";
    case FaultKind::bus_off: return "bus_off";
    case FaultKind::restarted: return "restarted";
    case FaultKind::error_passive: return "error_passive";
    case FaultKind::error_active: return "error_active";
    case FaultKind::wrong_dlc: return "wrong_dlc";
    case FaultKind::unexpected_id: return "unexpected_id";
    case FaultKind::stale_counter: return "stale_counter";
    case FaultKind::status_invalid: return "status_invalid";
    case FaultKind::corrupt_quaternion: return "corrupt_quaternion";
    case FaultKind::saturate: return "saturate";
    case FaultKind::split: return "split";
    case FaultKind::not_ready: return "not_ready";
  }
  return "?";
}

bool is_property(FaultKind k) noexcept {
  return k == FaultKind::rated_torque || k == FaultKind::mode_display_delay || k == FaultKind::vendor_error ||
         k == FaultKind::enable_blocked;
}

const char* to_string(SensorId s) noexcept {
  switch (s) {
    case SensorId::none: return "none";
    case SensorId::imu: return "imu";
    case SensorId::wrist_ft: return "wrist_ft";
  }
  return "?";
}

// ---- Drive: fault injection common to both protocols ---------------------------------------------
Drive::Drive(const can::DriveConfig& cfg, bool fd_bus, JointModel model, std::vector<Fault> faults)
    : cfg_(cfg), fd_bus_(fd_bus), model_(model), faults_(std::move(faults)) {}

void Drive::attach(Motion* motion) {
  motion_ = motion;
  if (motion_ != nullptr) {
    motion_->set_enabled(cfg_.joint, enabled_);
    sync_from_motion();
  }
}

void Drive::set_enabled(bool enabled) {
  enabled_ = enabled;
  if (motion_ != nullptr) motion_->set_enabled(cfg_.joint, enabled);
}

void Drive::sync_from_motion() {
  if (motion_ == nullptr) return;
  const JointState s = motion_->state(cfg_.joint);
  model_.q_rad = s.q_rad;
  model_.qd_rad_s = s.qd_rad_s;
  model_.tau_nm = s.tau_nm;
}

void Drive::step_joint(const DriveLaw& law, double tau_nm) {
  if (motion_ == nullptr) {
    model_.step(tau_nm, 1e-3);
    return;
  }
  const JointState s = motion_->command(cfg_.joint, law);
  model_.q_rad = s.q_rad;
  model_.qd_rad_s = s.qd_rad_s;
  model_.tau_nm = s.tau_nm;
}

bool Drive::active(const Fault& flt) const noexcept {
  if (flt.at_frame != 0 || tick_ < flt.at_tick) return false;  // at_frame: take_frame() unplugs
  return flt.kind == FaultKind::silent || flt.kind == FaultKind::no_heartbeat || tick_ < flt.at_tick + flt.count;
}

bool Drive::take_frame() noexcept {
  ++frames_addressed_;
  for (const Fault& flt : faults_) {
    if (flt.kind == FaultKind::silent && flt.at_frame != 0 && frames_addressed_ >= flt.at_frame) unplugged_ = true;
  }
  return !unplugged_;
}

void Drive::emit(const Frame& f, std::vector<Frame>& out) {
  Frame g = f;
  if (fd_bus_ && !g.error) g.fd = true;
  out.push_back(g);
  ++replies_out_;
}

void Drive::begin_tick(std::vector<Frame>& out) {
  ++tick_;
  for (auto it = delayed_.begin(); it != delayed_.end();) {
    if (it->first <= tick_) {
      emit(it->second, out);
      it = delayed_.erase(it);
    } else {
      ++it;
    }
  }
  for (const Fault& flt : faults_) {
    const bool event = flt.kind == FaultKind::emcy || flt.kind == FaultKind::bus_off || flt.kind == FaultKind::restarted ||
                       flt.kind == FaultKind::error_passive || flt.kind == FaultKind::error_active;
    if (event && flt.at_sdo == 0 && flt.at_tick == tick_) on_fault_event(flt, out);
  }
}

void Drive::emit_cyclic(Frame f, std::vector<Frame>& out) {
  int copies = 1;
  for (const Fault& flt : faults_) {
    if (!active(flt)) continue;
    switch (flt.kind) {
      case FaultKind::drop:
      case FaultKind::silent: return;
      case FaultKind::corrupt: corrupt(f); break;
      case FaultKind::wrong_dlc: f.len = static_cast<std::uint8_t>(f.len - 1); break;
      case FaultKind::unexpected_id:
        if (cfg_.protocol == can::Protocol::mit) {
          f.data[0] = static_cast<std::uint8_t>(flt.param);
        } else {
          f.id = (f.id & 0x780) | (flt.param & 0x7F);
        }
        break;
      case FaultKind::duplicate: copies = 2; break;
      case FaultKind::delay: delayed_.emplace_back(tick_ + std::max<std::uint32_t>(1, flt.param), f); return;
      default: break;
    }
  }
  for (int i = 0; i < copies; ++i) emit(f, out);
}

}  // namespace springbok::emu
