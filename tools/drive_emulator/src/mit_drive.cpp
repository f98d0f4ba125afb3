// The MIT mode drive (CAN.md 1): one reply per command frame, the motor-mode commands, its fault injection.
#include "springbok/drive_emulator/drives.hpp"

#include <algorithm>
#include <cmath>

#include "springbok/can/mit.hpp"
#include "springbok/can/socketcan.hpp"

namespace springbok::emu {

using can::Frame;

MitDrive::MitDrive(const can::DriveConfig& cfg, bool fd_bus, JointModel model, std::vector<Fault> faults,
                   std::uint32_t can_timeout_ms, const MitReplyOptions& reply)
    : Drive(cfg, fd_bus, model, std::move(faults)), can_timeout_ms_(can_timeout_ms), reply_(reply) {
  if (reply_.dlc == 0) reply_.dlc = cfg_.mit_vendor_reply ? can::mit::kReplyLenVendor : can::mit::kReplyLen;
  for (const Fault& flt : faults_) {
    if (flt.kind == FaultKind::vendor_error) error_code_ = static_cast<std::uint8_t>(flt.param);
  }
}

Frame MitDrive::reply() const {
  can::mit::Reply r;
  r.drive_id = cfg_.drive_id;
  r.p_rad = model_.q_rad;
  r.v_rad_s = model_.qd_rad_s;
  r.t_nm = model_.tau_nm;
  r.error_code = error_code_;
  r.temperature = 40;
  r.bus_voltage_v = reply_.bus_voltage_v;
  Frame f;
  if (reply_.dlc < can::mit::kReplyLen) {  // malformed: the 6 bytes cut short
    can::mit::encode_reply(cfg_.mit_reply_id, r, cfg_.mit_ranges, can::mit::kReplyLen, f);
    f.len = static_cast<std::uint8_t>(reply_.dlc);
    return f;
  }
  can::mit::encode_reply(cfg_.mit_reply_id, r, cfg_.mit_ranges, reply_.dlc, f);
  return f;
}

void MitDrive::corrupt(Frame& f) const {
  f.data[1] = static_cast<std::uint8_t>(~f.data[1]);
  f.data[2] = static_cast<std::uint8_t>(~f.data[2]);
}

void MitDrive::on_fault_event(const Fault& flt, std::vector<Frame>& out) {
  Frame e;
  switch (flt.kind) {
    case FaultKind::emcy: error_code_ = static_cast<std::uint8_t>(flt.param == 0 ? 1 : flt.param); break;
    case FaultKind::bus_off: can::make_bus_off_frame(e); emit(e, out); break;
    case FaultKind::restarted: can::make_restarted_frame(e); emit(e, out); break;
    case FaultKind::error_passive: can::make_error_passive_frame(e); emit(e, out); break;
    case FaultKind::error_active: can::make_error_active_frame(e); emit(e, out); break;
    default: break;
  }
}

void MitDrive::on_frame(const Frame& f, std::int64_t now_ns, std::vector<Frame>& out) {
  if (f.error || f.id != cfg_.drive_id || f.len != can::mit::kCommandLen) return;
  if (fd_bus_ && !f.fd) {  // an FD bus's drives speak FD (CAN.md 3.3): a classic frame is not a command
    ++classic_frames_;
    return;
  }
  if (!take_frame()) return;
  ++frames_in_;
  last_rx_ns_ = now_ns;
  sync_from_motion();
  switch (can::mit::classify(f)) {
    case can::mit::Special::enter_motor_mode: set_enabled(true); emit(reply(), out); return;
    case can::mit::Special::exit_motor_mode: set_enabled(false); emit(reply(), out); return;
    case can::mit::Special::set_zero: ++zero_frames_; model_.q_rad = 0.0; emit(reply(), out); return;
    case can::mit::Special::none: break;
  }
  can::mit::Command c;
  (void)can::mit::decode_command(f, cfg_.mit_ranges, c);
  p_des_ = c.p_rad;
  v_des_ = c.v_rad_s;
  kp_ = c.kp;
  kd_ = c.kd;
  t_ff_ = c.t_nm;
  if (!enabled_) {  // stored, answered, no motion
    emit(reply(), out);
    return;
  }
  begin_tick(out);
  const double tau = std::clamp(kp_ * (p_des_ - model_.q_rad) + kd_ * (v_des_ - model_.qd_rad_s) + t_ff_,
                                cfg_.mit_ranges.t_min_nm, cfg_.mit_ranges.t_max_nm);
  step_joint(DriveLaw{p_des_, v_des_, kp_, kd_, t_ff_}, tau);
  emit_cyclic(reply(), out);
}

bool MitDrive::cyclic(const Frame& f) const noexcept {
  return enabled_ && !f.error && f.id == cfg_.drive_id && f.len == can::mit::kCommandLen &&
         can::mit::classify(f) == can::mit::Special::none;
}

void MitDrive::on_time(std::int64_t now_ns, std::vector<Frame>&) {
  if (can_timeout_ms_ > 0 && enabled_ && now_ns - last_rx_ns_ > 1000000LL * can_timeout_ms_) {
    p_des_ = v_des_ = kp_ = kd_ = t_ff_ = 0.0;  // CAN_TIMEOUT: a dead host means zero torque
  }
}

}  // namespace springbok::emu
