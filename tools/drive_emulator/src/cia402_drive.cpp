// The CiA 402 drive (CAN.md 2-4): NMT, SDO, PDOs at SYNC, the state machine, heartbeat and EMCY, its fault injection.
#include "springbok/drive_emulator/drives.hpp"

#include <algorithm>
#include <cmath>

#include "springbok/can/cia402.hpp"
#include "springbok/can/socketcan.hpp"
#include "springbok/model/model.hpp"

namespace springbok::emu {

using can::Frame;
namespace c4 = can::cia402;

Cia402Drive::Cia402Drive(const can::DriveConfig& cfg, JointModel model, std::vector<Fault> faults, std::int64_t now_ns,
                         const Cia402Options& options)
    : Drive(cfg, false, model, std::move(faults)), options_(options) {
  // 0x6076: the config's rated torque, else the joint's peak torque limit, unless the script says otherwise.
  const double rated_nm = cfg_.rated_torque_nm > 0.0 ? cfg_.rated_torque_nm : torque_limit_peak_nm(cfg_.joint);
  rated_torque_mnm_ = static_cast<std::uint32_t>(std::lround(rated_nm * 1000.0));
  for (const Fault& flt : faults_) {
    if (flt.kind == FaultKind::rated_torque) rated_torque_mnm_ = flt.param;
    if (flt.kind == FaultKind::mode_display_delay) mode_display_delay_ms_ = flt.param;
    if (flt.kind == FaultKind::enable_blocked) enable_blocked_ = true;
  }
  reset_communication();
  next_heartbeat_ns_ = now_ns;
}

void Cia402Drive::reset_communication() {
  const std::uint8_t n = cfg_.drive_id;
  last_sync_ns_ = 0;
  heartbeat_ms_ = options_.stored_heartbeat_ms;
  error_behaviour_ = 1;
  cycle_period_us_ = 0;
  // Vendor defaults: event-driven PDOs with the drive's own mapping (the host must re-map and disable).
  for (int k = 0; k < 4; ++k) {
    rpdo_[k] = Pdo{0x200u + 0x100u * k + n, 255, 0, {}};
    tpdo_[k] = Pdo{0x180u + 0x100u * k + n, 255, 0, {}};
  }
  rpdo_[0].count = 1;
  rpdo_[0].entries[0] = c4::mapping_entry(c4::object::controlword, 0, 16);
  tpdo_[0].count = 1;
  tpdo_[0].entries[0] = c4::mapping_entry(c4::object::statusword, 0, 16);
}

void Cia402Drive::boot(std::int64_t now_ns, std::vector<Frame>& out) {
  nmt_ = 0x7F;
  Frame f;
  c4::encode_heartbeat(cfg_.drive_id, c4::NmtState::boot_up, f);
  emit(f, out);
  next_heartbeat_ns_ = now_ns + 1000000LL * std::max<int>(heartbeat_ms_, 1);
}

std::uint16_t Cia402Drive::status_word() const noexcept {
  switch (state_) {
    case St::not_ready: return 0x0000;
    case St::switch_on_disabled: return 0x0250;
    case St::ready: return 0x0231;
    case St::switched_on: return 0x0233;
    case St::enabled: return 0x0237;
    case St::quick_stop: return 0x0217;
    case St::fault: return 0x0218;
  }
  return 0;
}

Cia402Drive::St Cia402Drive::transition(St from) const noexcept {
  const std::uint16_t cw = applied_controlword_;
  switch (from) {
    case St::fault: break;  // handled with the edge in on_sync
    case St::not_ready: return St::switch_on_disabled;
    case St::switch_on_disabled:
      if ((cw & 0x87) == 0x06) return St::ready;
      break;
    case St::ready:
      if ((cw & 0x8F) == 0x07 || (cw & 0x8F) == 0x0F) return St::switched_on;
      if ((cw & 0x02) == 0 || (cw & 0x86) == 0x02) return St::switch_on_disabled;
      break;
    case St::switched_on:
      if ((cw & 0x8F) == 0x0F) return enable_blocked_ ? from : St::enabled;
      if ((cw & 0x87) == 0x06) return St::ready;
      if ((cw & 0x02) == 0 || (cw & 0x86) == 0x02) return St::switch_on_disabled;
      break;
    case St::enabled:
      if ((cw & 0x8F) == 0x07) return St::switched_on;
      if ((cw & 0x87) == 0x06) return St::ready;
      if ((cw & 0x02) == 0) return St::switch_on_disabled;
      if ((cw & 0x86) == 0x02) return St::quick_stop;
      break;
    case St::quick_stop:
      if ((cw & 0x8F) == 0x0F && !enable_blocked_) return St::enabled;
      if ((cw & 0x02) == 0) return St::switch_on_disabled;
      break;
  }
  return from;
}

void Cia402Drive::step_state_machine() {
  if (options_.state_step_ms == 0 && options_.brake_ms == 0) {
    state_ = transition(state_);
    return;
  }
  // A transition under way completes at its time; the controlword applied meanwhile picks where
  // it goes (the last command wins, CAN.md 2.5), not when.
  if (step_pending_ && now_ns_ >= step_due_ns_) {
    step_pending_ = false;
    state_ = step_target_;
  }
  const St next = transition(state_);
  if (next == state_) {
    step_pending_ = false;
    return;
  }
  const bool brake = state_ == St::enabled || next == St::enabled;
  const std::uint32_t step_ms = brake ? std::max(options_.state_step_ms, options_.brake_ms) : options_.state_step_ms;
  if (step_ms == 0) {
    step_pending_ = false;
    state_ = next;
    return;
  }
  if (!step_pending_) step_due_ns_ = now_ns_ + 1000000LL * step_ms;
  step_pending_ = true;
  step_target_ = next;
}

void Cia402Drive::hold_answers(std::vector<Frame>& out, std::size_t first) {
  if (options_.answer_delay_ms == 0 || first >= out.size()) return;
  const bool late = state_ != St::enabled;
  if (!late && late_.empty()) return;
  // Behind the answers held back already: the bus keeps their order.
  std::int64_t due = late ? now_ns_ + 1000000LL * options_.answer_delay_ms : now_ns_;
  if (!late_.empty()) due = std::max(due, late_.back().first);
  for (std::size_t i = first; i < out.size(); ++i) late_.emplace_back(due, out[i]);
  out.resize(first);
  release_answers(out);
}

void Cia402Drive::release_answers(std::vector<Frame>& out) {
  while (!late_.empty() && late_.front().first <= now_ns_) {
    out.push_back(late_.front().second);
    late_.pop_front();
  }
}

void Cia402Drive::on_sync(std::vector<Frame>& out) {
  if (nmt_ != 0x05) return;
  last_sync_ns_ = now_ns_;
  // The RPDO received before this SYNC takes effect now (CAN.md 2.6).
  const std::uint16_t previous = applied_controlword_;
  applied_controlword_ = controlword_;
  applied_target_torque_ = target_torque_;
  if (state_ == St::fault) {
    step_pending_ = false;  // a fault ends a transition under way
    if ((applied_controlword_ & 0x80) != 0 && (previous & 0x80) == 0) {
      state_ = St::switch_on_disabled;
      error_code_ = 0;
      error_register_ = 0;
    }
  } else {
    step_state_machine();
  }
  set_enabled(state_ == St::enabled);
  if (enabled_) {
    begin_tick(out);
    const std::int16_t permille = std::clamp<std::int16_t>(applied_target_torque_, static_cast<std::int16_t>(-max_torque_),
                                                           static_cast<std::int16_t>(max_torque_));
    const double tau_nm = c4::permille_to_torque(permille, rated_torque_nm(), cfg_.gear_ratio);
    step_joint(DriveLaw{0.0, 0.0, 0.0, 0.0, tau_nm}, tau_nm);
  } else if (motion_ == nullptr) {
    model_.step(0.0, 1e-3);
  } else {
    sync_from_motion();  // a disabled drive does not step the shared world
  }
  // Synchronous TPDOs, packed from their mapping (little-endian).
  for (int k = 0; k < 4; ++k) {
    const Pdo& p = tpdo_[k];
    if ((p.cob_id & c4::kPdoInvalid) != 0 || p.transmission == 0 || p.transmission > 240) continue;
    Frame f;
    f.id = p.cob_id & 0x7FF;
    int bit = 0;
    for (int e = 0; e < p.count; ++e) {
      const int bits = static_cast<int>(p.entries[e] & 0xFF);
      const std::uint32_t v = object_value(p.entries[e]);
      for (int b = 0; b < bits / 8; ++b) f.data[(bit / 8) + b] = static_cast<std::uint8_t>((v >> (8 * b)) & 0xFF);
      bit += bits;
    }
    f.len = static_cast<std::uint8_t>(bit / 8);
    if (enabled_ || state_ == St::fault) {
      emit_cyclic(f, out);
    } else {
      emit(f, out);
    }
  }
}

std::uint32_t Cia402Drive::object_value(std::uint32_t entry) const {
  std::uint32_t v = 0;
  std::uint8_t size = 0;
  (void)read_object(static_cast<std::uint16_t>(entry >> 16), static_cast<std::uint8_t>((entry >> 8) & 0xFF), v, size);
  return v;
}

std::uint32_t Cia402Drive::read_object(std::uint16_t index, std::uint8_t sub, std::uint32_t& value,
                                       std::uint8_t& size) const {
  using namespace c4::object;
  const auto one = [&](std::uint32_t v, std::uint8_t s) -> std::uint32_t {
    if (sub != 0) return c4::abort_code::no_subindex;
    value = v;
    size = s;
    return 0;
  };
  const auto pdo_comm = [&](const Pdo& p) -> std::uint32_t {
    if (sub == 0) { value = 2; size = 1; return 0; }
    if (sub == 1) { value = p.cob_id; size = 4; return 0; }
    if (sub == 2) { value = p.transmission; size = 1; return 0; }
    return c4::abort_code::no_subindex;
  };
  const auto pdo_map = [&](const Pdo& p) -> std::uint32_t {
    if (sub == 0) { value = p.count; size = 1; return 0; }
    if (sub <= 8) { value = p.entries[sub - 1]; size = 4; return 0; }
    return c4::abort_code::no_subindex;
  };
  const double q = model_.q_rad, qd = model_.qd_rad_s;
  switch (index) {
    case error_register: return one(error_register_, 1);
    case cycle_period: return one(cycle_period_us_, 4);
    case producer_heartbeat: return one(heartbeat_ms_, 2);
    case error_behaviour:
      if (sub > 1) return c4::abort_code::no_subindex;
      value = sub == 0 ? 1u : error_behaviour_;
      size = 1;
      return 0;
    case error_code: return one(error_code_, 2);
    case abort_connection: return one(static_cast<std::uint16_t>(abort_connection_), 2);
    case controlword: return one(controlword_, 2);
    case statusword: return one(status_word(), 2);
    case modes_of_operation: return one(static_cast<std::uint8_t>(mode_), 1);
    case modes_display: return one(static_cast<std::uint8_t>(mode_shown()), 1);
    case position_actual: return one(static_cast<std::uint32_t>(static_cast<std::int32_t>(std::lround(q * cfg_.counts_per_rad))), 4);
    case velocity_actual: return one(static_cast<std::uint32_t>(static_cast<std::int32_t>(std::lround(qd * cfg_.velocity_units_per_rad_s))), 4);
    case target_torque: return one(static_cast<std::uint16_t>(target_torque_), 2);
    case max_torque: return one(max_torque_, 2);
    case rated_torque: return one(rated_torque_mnm_, 4);
    case torque_actual:
      return one(static_cast<std::uint16_t>(c4::torque_to_permille(model_.tau_nm, rated_torque_nm(), cfg_.gear_ratio, 32767)), 2);
    case interpolation_period:
      if (sub == 0) { value = 2; size = 1; return 0; }
      if (sub == 1) { value = ip_value_; size = 1; return 0; }
      if (sub == 2) { value = static_cast<std::uint8_t>(ip_index_); size = 1; return 0; }
      return c4::abort_code::no_subindex;
    case supported_modes: return one(c4::kSupportedModeCstBit | (1u << 7) | (1u << 8), 4);
    default: break;
  }
  if (!has_pdo(index)) return c4::abort_code::no_object;
  if (index >= rpdo_comm && index < rpdo_comm + 4) return pdo_comm(rpdo_[index - rpdo_comm]);
  if (index >= rpdo_map && index < rpdo_map + 4) return pdo_map(rpdo_[index - rpdo_map]);
  if (index >= tpdo_comm && index < tpdo_comm + 4) return pdo_comm(tpdo_[index - tpdo_comm]);
  if (index >= tpdo_map && index < tpdo_map + 4) return pdo_map(tpdo_[index - tpdo_map]);
  return c4::abort_code::no_object;
}

std::uint32_t Cia402Drive::write_object(std::uint16_t index, std::uint8_t sub, std::uint32_t value, std::uint8_t size) {
  using namespace c4::object;
  const auto need = [&](std::uint8_t want_sub, std::uint8_t want_size) -> std::uint32_t {
    if (sub != want_sub) return c4::abort_code::no_subindex;
    if (size != want_size) return c4::abort_code::length_mismatch;
    return 0;
  };
  std::uint32_t err = 0;
  switch (index) {
    case error_register: case error_code: case statusword: case modes_display: case position_actual:
    case velocity_actual: case rated_torque: case torque_actual: case supported_modes:
      return c4::abort_code::read_only;
    case cycle_period: if ((err = need(0, 4)) != 0) return err; cycle_period_us_ = value; return 0;
    case producer_heartbeat: if ((err = need(0, 2)) != 0) return err; heartbeat_ms_ = static_cast<std::uint16_t>(value); return 0;
    case error_behaviour: if ((err = need(1, 1)) != 0) return err; error_behaviour_ = static_cast<std::uint8_t>(value); return 0;
    case abort_connection: if ((err = need(0, 2)) != 0) return err; abort_connection_ = static_cast<std::int16_t>(value); return 0;
    case controlword: if ((err = need(0, 2)) != 0) return err; controlword_ = static_cast<std::uint16_t>(value); return 0;
    case modes_of_operation:
      if ((err = need(0, 1)) != 0) return err;
      if (static_cast<std::int8_t>(value) != c4::kModeCst && static_cast<std::int8_t>(value) != 0) return c4::abort_code::value_out_of_range;
      mode_before_ = mode_shown();
      mode_ = static_cast<std::int8_t>(value);
      mode_display_at_ns_ = now_ns_ + 1000000LL * mode_display_delay_ms_;
      return 0;
    case target_torque: if ((err = need(0, 2)) != 0) return err; target_torque_ = static_cast<std::int16_t>(value); return 0;
    case max_torque: if ((err = need(0, 2)) != 0) return err; max_torque_ = static_cast<std::uint16_t>(std::min<std::uint32_t>(value, 32767)); return 0;
    case interpolation_period:
      if (size != 1) return c4::abort_code::length_mismatch;
      if (sub == 1) { ip_value_ = static_cast<std::uint8_t>(value); return 0; }
      if (sub == 2) { ip_index_ = static_cast<std::int8_t>(value); return 0; }
      return c4::abort_code::no_subindex;
    default: break;
  }
  const bool is_rpdo = (index >= rpdo_comm && index < rpdo_comm + 4) || (index >= rpdo_map && index < rpdo_map + 4);
  const bool is_comm = (index >= rpdo_comm && index < rpdo_comm + 4) || (index >= tpdo_comm && index < tpdo_comm + 4);
  const bool is_map = (index >= rpdo_map && index < rpdo_map + 4) || (index >= tpdo_map && index < tpdo_map + 4);
  if ((!is_comm && !is_map) || !has_pdo(index)) return c4::abort_code::no_object;
  if (nmt_ == 0x05) return c4::abort_code::wrong_state;  // PDO parameters only in Pre-operational
  Pdo& p = is_rpdo ? rpdo_[(index & 0xFF) % 4] : tpdo_[(index & 0xFF) % 4];
  if (is_comm) {
    if (sub == 1) {
      if (size != 4) return c4::abort_code::length_mismatch;
      p.cob_id = value;
      return 0;
    }
    if (sub == 2) {
      if (size != 1) return c4::abort_code::length_mismatch;
      p.transmission = static_cast<std::uint8_t>(value);
      return 0;
    }
    return c4::abort_code::no_subindex;
  }
  // Mapping: only while the PDO is invalid (CiA 301 mapping procedure).
  if ((p.cob_id & c4::kPdoInvalid) == 0) return c4::abort_code::wrong_state;
  if (sub == 0) {
    if (size != 1) return c4::abort_code::length_mismatch;
    if (value > 8) return c4::abort_code::value_out_of_range;
    int bits = 0;
    for (std::uint32_t e = 0; e < value; ++e) bits += static_cast<int>(p.entries[e] & 0xFF);
    if (bits > 64) return c4::abort_code::pdo_length_exceeded;
    p.count = static_cast<std::uint8_t>(value);
    return 0;
  }
  if (sub > 8) return c4::abort_code::no_subindex;
  if (size != 4) return c4::abort_code::length_mismatch;
  if (p.count != 0) return c4::abort_code::wrong_state;
  const auto obj = static_cast<std::uint16_t>(value >> 16);
  const bool mappable = is_rpdo ? (obj == controlword || obj == target_torque)
                                : (obj == statusword || obj == position_actual || obj == velocity_actual || obj == torque_actual);
  if (!mappable) return c4::abort_code::not_mappable;
  std::uint32_t v = 0;
  std::uint8_t s = 0;
  if (read_object(obj, static_cast<std::uint8_t>((value >> 8) & 0xFF), v, s) != 0 || (value & 0xFF) != 8u * s) {
    return c4::abort_code::length_mismatch;
  }
  p.entries[sub - 1] = value;
  return 0;
}

std::int8_t Cia402Drive::mode_shown() const noexcept { return now_ns_ >= mode_display_at_ns_ ? mode_ : mode_before_; }

void Cia402Drive::handle_sdo(const Frame& f, std::vector<Frame>& out) {
  c4::SdoRequest req;
  c4::SdoResponse res;
  const can::FrameStatus st = c4::decode_sdo_request(f, cfg_.drive_id, req);
  if (st != can::FrameStatus::ok) {
    if (f.len != 8) return;  // not an SDO we can answer
    res.kind = c4::SdoResponse::Kind::abort;
    res.index = static_cast<std::uint16_t>(f.data[1] | (f.data[2] << 8));
    res.sub = f.data[3];
    res.value = c4::abort_code::bad_command;
  } else if (req.kind == c4::SdoRequest::Kind::abort) {
    return;
  } else {
    res.index = req.index;
    res.sub = req.sub;
    std::uint32_t abort = 0;
    if (req.kind == c4::SdoRequest::Kind::read) {
      std::uint32_t v = 0;
      std::uint8_t size = 0;
      abort = read_object(req.index, req.sub, v, size);
      res.kind = c4::SdoResponse::Kind::read_ok;
      res.value = v;
      res.size = size;
    } else {
      abort = write_object(req.index, req.sub, req.value, req.size);
      res.kind = c4::SdoResponse::Kind::write_ok;
    }
    if (abort != 0) {
      res.kind = c4::SdoResponse::Kind::abort;
      res.value = abort;
    }
  }
  Frame a;
  c4::encode_sdo_response(cfg_.drive_id, res, a);
  emit(a, out);
  if (options_.repeat_sdo_answers) emit(a, out);
  ++sdo_requests_;
  for (const Fault& flt : faults_) {
    if (flt.kind == FaultKind::emcy && flt.at_sdo == sdo_requests_) on_fault_event(flt, out);
  }
}

void Cia402Drive::on_fault_event(const Fault& flt, std::vector<Frame>& out) {
  Frame e;
  switch (flt.kind) {
    case FaultKind::emcy:
      error_code_ = static_cast<std::uint16_t>(flt.param == 0 ? 0x2310 : flt.param);
      error_register_ = 0x03;  // generic + current
      state_ = St::fault;
      c4::encode_emcy(cfg_.drive_id, c4::Emcy{error_code_, error_register_, {}}, e);
      emit(e, out);
      break;
    case FaultKind::bus_off: can::make_bus_off_frame(e); emit(e, out); break;
    case FaultKind::restarted: can::make_restarted_frame(e); emit(e, out); break;
    case FaultKind::error_passive: can::make_error_passive_frame(e); emit(e, out); break;
    case FaultKind::error_active: can::make_error_active_frame(e); emit(e, out); break;
    default: break;
  }
}

void Cia402Drive::corrupt(Frame& f) const {
  if ((f.id & 0x780) == c4::cob::tpdo1 && f.len >= 6) {
    for (int i = 2; i < 6; ++i) f.data[i] = static_cast<std::uint8_t>(f.data[i] ^ 0x5A);
  }
}

void Cia402Drive::on_frame(const Frame& f, std::int64_t now_ns, std::vector<Frame>& out) {
  if (f.error || nmt_ == 0x00) return;
  now_ns_ = now_ns;
  sync_from_motion();
  const std::uint8_t n = cfg_.drive_id;
  if (f.id == c4::cob::nmt) {
    c4::NmtCommand cs{};
    std::uint8_t node = 0;
    if (c4::decode_nmt(f, cs, node) != can::FrameStatus::ok || (node != 0 && node != n)) return;
    if (!take_frame()) return;
    ++frames_in_;
    if (options_.nmt_delay_ms > 0) {  // taken in the drive's own cycle (on_time)
      nmt_pending_ = true;
      pending_nmt_ = cs;
      nmt_due_ns_ = now_ns + 1000000LL * options_.nmt_delay_ms;
      return;
    }
    take_nmt(cs, now_ns, out);
    return;
  }
  if (f.id == c4::cob::sync) {
    if (f.len != 0) return;
    if (!take_frame()) return;
    ++frames_in_;
    const std::size_t first = out.size();
    on_sync(out);
    hold_answers(out, first);
    return;
  }
  if (f.id == c4::cob::sdo_request + n) {
    if (!take_frame()) return;
    ++frames_in_;
    if (nmt_ == 0x04) return;  // Stopped: no SDO
    const std::size_t first = out.size();
    handle_sdo(f, out);
    hold_answers(out, first);
    return;
  }
  for (int k = 0; k < 4; ++k) {
    const Pdo& p = rpdo_[k];
    if ((p.cob_id & c4::kPdoInvalid) != 0 || f.id != (p.cob_id & 0x7FF)) continue;
    if (!take_frame()) return;
    ++frames_in_;
    if (nmt_ != 0x05) return;
    int bit = 0;
    int need_bits = 0;
    for (int e = 0; e < p.count; ++e) need_bits += static_cast<int>(p.entries[e] & 0xFF);
    if (f.len * 8 < need_bits) return;  // too short: ignored (a real drive would send EMCY 0x8210)
    for (int e = 0; e < p.count; ++e) {
      const int bits = static_cast<int>(p.entries[e] & 0xFF);
      std::uint32_t v = 0;
      for (int b = 0; b < bits / 8; ++b) v |= std::uint32_t{f.data[(bit / 8) + b]} << (8 * b);
      bit += bits;
      (void)write_object(static_cast<std::uint16_t>(p.entries[e] >> 16), static_cast<std::uint8_t>((p.entries[e] >> 8) & 0xFF),
                         v, static_cast<std::uint8_t>(bits / 8));
    }
    return;
  }
}

void Cia402Drive::take_nmt(c4::NmtCommand cs, std::int64_t now_ns, std::vector<Frame>& out) {
  switch (cs) {
    case c4::NmtCommand::start: nmt_ = 0x05; break;
    case c4::NmtCommand::stop: nmt_ = 0x04; break;
    case c4::NmtCommand::enter_pre_operational: nmt_ = 0x7F; break;
    case c4::NmtCommand::reset_node:
      ++nmt_resets_;
      state_ = St::switch_on_disabled;
      step_pending_ = false;
      mode_ = mode_before_ = 0;
      mode_display_at_ns_ = 0;
      [[fallthrough]];
    case c4::NmtCommand::reset_communication:
      if (cs == c4::NmtCommand::reset_communication) ++nmt_resets_;
      reset_communication();
      boot(now_ns, out);
      break;
  }
}

bool Cia402Drive::has_pdo(std::uint16_t index) const noexcept {
  using namespace c4::object;
  if (!options_.only_used_pdos) return true;
  return index == rpdo_comm || index == rpdo_map || index == tpdo_comm || index == tpdo_map || index == tpdo_comm + 1 ||
         index == tpdo_map + 1;
}

bool Cia402Drive::cyclic(const Frame& f) const noexcept {
  return !f.error && f.id == c4::cob::sync && f.len == 0 && nmt_ == 0x05 && state_ == St::enabled;
}

void Cia402Drive::on_time(std::int64_t now_ns, std::vector<Frame>& out) {
  now_ns_ = now_ns;
  if (!unplugged_) release_answers(out);
  if (nmt_pending_ && now_ns >= nmt_due_ns_ && nmt_ != 0x00 && !unplugged_) {
    nmt_pending_ = false;
    take_nmt(pending_nmt_, now_ns, out);
  }
  if (options_.sync_timeout_ms > 0 && nmt_ == 0x05 && state_ == St::enabled && abort_connection_ == 3 &&
      last_sync_ns_ > 0 && now_ns - last_sync_ns_ > 1000000LL * options_.sync_timeout_ms) {
    state_ = St::quick_stop;  // lost communication: the host went silent
    ++sync_timeouts_;
  }
  if (nmt_ == 0x00 || unplugged_ || heartbeat_ms_ == 0 || now_ns < next_heartbeat_ns_) return;
  for (const Fault& flt : faults_) {
    if ((flt.kind == FaultKind::silent || flt.kind == FaultKind::no_heartbeat) && active(flt)) return;
  }
  Frame f;
  c4::encode_heartbeat(cfg_.drive_id, static_cast<c4::NmtState>(nmt_), f);
  emit(f, out);
  next_heartbeat_ns_ = now_ns + 1000000LL * heartbeat_ms_;
}

}  // namespace springbok::emu
