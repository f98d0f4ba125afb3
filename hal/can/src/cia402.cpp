#include "springbok/can/cia402.hpp"

#include <algorithm>
#include <cmath>

namespace springbok::can::cia402 {

namespace {

// The bytes an expedited SDO of `size` (1..4) bytes carries.
constexpr std::uint32_t expedited_mask(unsigned size) noexcept {
  return size >= 4 ? 0xFFFFFFFFu : ((1u << (8 * size)) - 1u);
}

// The size an expedited SDO command specifier announces (bits 2-3: 4 - size).
constexpr std::uint8_t expedited_size(std::uint8_t command) noexcept {
  return static_cast<std::uint8_t>(4 - ((command >> 2) & 0x3));
}

void put_u16(Frame& f, int at, std::uint16_t v) noexcept {
  f.data[at] = static_cast<std::uint8_t>(v & 0xFF);
  f.data[at + 1] = static_cast<std::uint8_t>(v >> 8);
}
void put_u32(Frame& f, int at, std::uint32_t v) noexcept {
  for (int i = 0; i < 4; ++i) f.data[at + i] = static_cast<std::uint8_t>((v >> (8 * i)) & 0xFF);
}
std::uint16_t get_u16(const Frame& f, int at) noexcept {
  return static_cast<std::uint16_t>(f.data[at] | (f.data[at + 1] << 8));
}
std::uint32_t get_u32(const Frame& f, int at) noexcept {
  std::uint32_t v = 0;
  for (int i = 0; i < 4; ++i) v |= std::uint32_t{f.data[at + i]} << (8 * i);
  return v;
}
Frame make(std::uint32_t id, std::uint8_t len) noexcept {
  Frame f;
  f.id = id;
  f.len = len;
  return f;
}
// Common checks: data frame, the expected identifier and length.
FrameStatus check(const Frame& f, std::uint32_t id, int len) noexcept {
  if (f.error) return FrameStatus::error_frame;
  if (f.id != id) return FrameStatus::unexpected_id;
  if (f.len != len) return FrameStatus::wrong_dlc;
  return FrameStatus::ok;
}
bool valid_node(std::uint8_t node) noexcept { return node >= 1 && node <= kMaxNode; }

}  // namespace

void encode_nmt(NmtCommand cs, std::uint8_t node, Frame& out) noexcept {
  out = make(cob::nmt, 2);
  out.data[0] = static_cast<std::uint8_t>(cs);
  out.data[1] = node;
}

FrameStatus decode_nmt(const Frame& f, NmtCommand& cs, std::uint8_t& node) noexcept {
  if (const FrameStatus s = check(f, cob::nmt, 2); s != FrameStatus::ok) return s;
  switch (f.data[0]) {
    case 0x01: case 0x02: case 0x80: case 0x81: case 0x82: break;
    default: return FrameStatus::bad_command;
  }
  if (f.data[1] > kMaxNode) return FrameStatus::bad_value;
  cs = static_cast<NmtCommand>(f.data[0]);
  node = f.data[1];
  return FrameStatus::ok;
}

void encode_sync(Frame& out) noexcept { out = make(cob::sync, 0); }

void encode_heartbeat(std::uint8_t node, NmtState state, Frame& out) noexcept {
  out = make(cob::heartbeat + node, 1);
  out.data[0] = static_cast<std::uint8_t>(state);
}

FrameStatus decode_heartbeat(const Frame& f, std::uint8_t node, NmtState& state) noexcept {
  if (const FrameStatus s = check(f, cob::heartbeat + node, 1); s != FrameStatus::ok) return s;
  switch (f.data[0]) {
    case 0x00: case 0x04: case 0x05: case 0x7F: state = static_cast<NmtState>(f.data[0]); return FrameStatus::ok;
    default: return FrameStatus::bad_value;
  }
}

void encode_emcy(std::uint8_t node, const Emcy& e, Frame& out) noexcept {
  out = make(cob::emcy + node, 8);
  put_u16(out, 0, e.error_code);
  out.data[2] = e.error_register;
  for (int i = 0; i < 5; ++i) out.data[3 + i] = e.manufacturer[i];
}

FrameStatus decode_emcy(const Frame& f, std::uint8_t node, Emcy& out) noexcept {
  if (!valid_node(node)) return FrameStatus::unexpected_id;
  if (const FrameStatus s = check(f, cob::emcy + node, 8); s != FrameStatus::ok) return s;
  out.error_code = get_u16(f, 0);
  out.error_register = f.data[2];
  for (int i = 0; i < 5; ++i) out.manufacturer[i] = f.data[3 + i];
  return FrameStatus::ok;
}

// ---- SDO -----------------------------------------------------------------------
void encode_sdo_request(std::uint8_t node, const SdoRequest& r, Frame& out) noexcept {
  out = make(cob::sdo_request + node, 8);
  switch (r.kind) {
    case SdoRequest::Kind::read: out.data[0] = 0x40; break;
    case SdoRequest::Kind::write: {
      const std::uint8_t size = std::clamp<std::uint8_t>(r.size, 1, 4);
      out.data[0] = static_cast<std::uint8_t>(0x20 | ((4 - size) << 2) | 0x3);
      put_u32(out, 4, r.value & expedited_mask(size));
      break;
    }
    case SdoRequest::Kind::abort: out.data[0] = 0x80; put_u32(out, 4, r.value); break;
  }
  put_u16(out, 1, r.index);
  out.data[3] = r.sub;
}

FrameStatus decode_sdo_request(const Frame& f, std::uint8_t node, SdoRequest& out) noexcept {
  if (const FrameStatus s = check(f, cob::sdo_request + node, 8); s != FrameStatus::ok) return s;
  out.index = get_u16(f, 1);
  out.sub = f.data[3];
  const std::uint8_t cs = f.data[0];
  if (cs == 0x40) {
    out.kind = SdoRequest::Kind::read;
    out.value = 0;
    out.size = 0;
  } else if (cs == 0x80) {
    out.kind = SdoRequest::Kind::abort;
    out.value = get_u32(f, 4);
    out.size = 4;
  } else if ((cs & 0xF3) == 0x23) {
    out.kind = SdoRequest::Kind::write;
    out.size = expedited_size(cs);
    out.value = get_u32(f, 4) & expedited_mask(out.size);
  } else {
    return FrameStatus::bad_command;
  }
  return FrameStatus::ok;
}

void encode_sdo_response(std::uint8_t node, const SdoResponse& r, Frame& out) noexcept {
  out = make(cob::sdo_response + node, 8);
  switch (r.kind) {
    case SdoResponse::Kind::write_ok: out.data[0] = 0x60; break;
    case SdoResponse::Kind::read_ok: {
      if (r.size == 0) {
        out.data[0] = 0x42;
        put_u32(out, 4, r.value);
      } else {
        const std::uint8_t size = std::clamp<std::uint8_t>(r.size, 1, 4);
        out.data[0] = static_cast<std::uint8_t>(0x40 | ((4 - size) << 2) | 0x3);
        put_u32(out, 4, r.value & expedited_mask(size));
      }
      break;
    }
    case SdoResponse::Kind::abort: out.data[0] = 0x80; put_u32(out, 4, r.value); break;
  }
  put_u16(out, 1, r.index);
  out.data[3] = r.sub;
}

FrameStatus decode_sdo_response(const Frame& f, std::uint8_t node, SdoResponse& out) noexcept {
  if (const FrameStatus s = check(f, cob::sdo_response + node, 8); s != FrameStatus::ok) return s;
  out.index = get_u16(f, 1);
  out.sub = f.data[3];
  const std::uint8_t cs = f.data[0];
  if (cs == 0x60) {
    out.kind = SdoResponse::Kind::write_ok;
    out.value = 0;
    out.size = 0;
  } else if (cs == 0x80) {
    out.kind = SdoResponse::Kind::abort;
    out.value = get_u32(f, 4);
    out.size = 4;
  } else if (cs == 0x42) {
    out.kind = SdoResponse::Kind::read_ok;
    out.value = get_u32(f, 4);
    out.size = 0;
  } else if ((cs & 0xF3) == 0x43) {
    out.kind = SdoResponse::Kind::read_ok;
    out.size = expedited_size(cs);
    out.value = get_u32(f, 4) & expedited_mask(out.size);
  } else {
    return FrameStatus::bad_command;  // includes 0x41 (segmented): not in this subset
  }
  return FrameStatus::ok;
}

const char* abort_code_name(std::uint32_t code) noexcept {
  switch (code) {
    case abort_code::timed_out: return "SDO protocol timed out";
    case abort_code::bad_command: return "command specifier not valid";
    case abort_code::unsupported_access: return "unsupported access to an object";
    case abort_code::read_only: return "attempt to write a read-only object";
    case abort_code::no_object: return "object does not exist";
    case abort_code::not_mappable: return "object cannot be mapped to the PDO";
    case abort_code::pdo_length_exceeded: return "PDO length exceeded";
    case abort_code::length_mismatch: return "data type length mismatch";
    case abort_code::no_subindex: return "sub-index does not exist";
    case abort_code::value_out_of_range: return "value out of range";
    case abort_code::wrong_state: return "not possible in the present device state";
    default: return "unknown abort code";
  }
}

// ---- state machine ------------------------------------------------------------------
State decode_statusword(std::uint16_t sw) noexcept {
  if ((sw & 0x4F) == 0x00) return State::not_ready_to_switch_on;
  if ((sw & 0x4F) == 0x40) return State::switch_on_disabled;
  if ((sw & 0x6F) == 0x21) return State::ready_to_switch_on;
  if ((sw & 0x6F) == 0x23) return State::switched_on;
  if ((sw & 0x6F) == 0x27) return State::operation_enabled;
  if ((sw & 0x6F) == 0x07) return State::quick_stop_active;
  if ((sw & 0x4F) == 0x0F) return State::fault_reaction_active;
  if ((sw & 0x4F) == 0x08) return State::fault;
  return State::unknown;
}

const char* to_string(State s) noexcept {
  switch (s) {
    case State::not_ready_to_switch_on: return "not ready to switch on";
    case State::switch_on_disabled: return "switch on disabled";
    case State::ready_to_switch_on: return "ready to switch on";
    case State::switched_on: return "switched on";
    case State::operation_enabled: return "operation enabled";
    case State::quick_stop_active: return "quick stop active";
    case State::fault_reaction_active: return "fault reaction active";
    case State::fault: return "fault";
    case State::unknown: return "unknown";
  }
  return "?";
}

std::uint16_t controlword_towards_enabled(State s, std::uint16_t previous) noexcept {
  switch (s) {
    case State::fault:
      // Fault reset acts on the rising edge of bit 7.
      return (previous & controlword::fault_reset) != 0 ? controlword::disable_voltage : controlword::fault_reset;
    case State::switch_on_disabled: return controlword::shutdown;
    case State::ready_to_switch_on: return controlword::switch_on;
    case State::switched_on: return controlword::enable_operation;
    case State::operation_enabled: return controlword::enable_operation;
    case State::quick_stop_active:
    case State::not_ready_to_switch_on:
    case State::fault_reaction_active:
    case State::unknown: return controlword::disable_voltage;
  }
  return controlword::disable_voltage;
}

// ---- PDO mapping ---------------------------------------------------------------------
int pdo_mapping_sequence(std::uint8_t node, Mapping m, std::array<SdoWrite, kMaxMappingWrites>& out) noexcept {
  int n = 0;
  const auto add = [&](std::uint16_t index, std::uint8_t sub, std::uint32_t value, std::uint8_t size,
                       bool optional = false) { out[n++] = SdoWrite{index, sub, value, size, optional}; };
  const auto map_pdo = [&](std::uint16_t comm, std::uint16_t map, std::uint32_t cob_id, const std::uint32_t* entries,
                           int count) {
    add(comm, 1, cob_id | kPdoInvalid, 4);
    add(map, 0, 0, 1);
    for (int i = 0; i < count; ++i) add(map, static_cast<std::uint8_t>(i + 1), entries[i], 4);
    add(map, 0, static_cast<std::uint32_t>(count), 1);
    add(comm, 2, 1, 1);  // synchronous, every SYNC
    add(comm, 1, cob_id, 4);
  };
  const std::uint32_t rpdo1[] = {mapping_entry(object::controlword, 0, 16), mapping_entry(object::target_torque, 0, 16)};
  map_pdo(object::rpdo_comm, object::rpdo_map, cob::rpdo1 + node, rpdo1, 2);
  if (m == Mapping::compact) {
    const std::uint32_t tpdo1[] = {mapping_entry(object::statusword, 0, 16), mapping_entry(object::position_actual, 0, 32),
                                   mapping_entry(object::torque_actual, 0, 16)};
    map_pdo(object::tpdo_comm, object::tpdo_map, cob::tpdo1 + node, tpdo1, 3);
    add(object::tpdo_comm + 1, 1, (cob::tpdo2 + node) | kPdoInvalid, 4, true);
  } else {
    const std::uint32_t tpdo1[] = {mapping_entry(object::statusword, 0, 16), mapping_entry(object::position_actual, 0, 32)};
    const std::uint32_t tpdo2[] = {mapping_entry(object::velocity_actual, 0, 32), mapping_entry(object::torque_actual, 0, 16)};
    map_pdo(object::tpdo_comm, object::tpdo_map, cob::tpdo1 + node, tpdo1, 2);
    map_pdo(object::tpdo_comm + 1, object::tpdo_map + 1, cob::tpdo2 + node, tpdo2, 2);
  }
  for (std::uint16_t k = 1; k < 4; ++k) {
    add(static_cast<std::uint16_t>(object::rpdo_comm + k), 1, (0x200u + 0x100u * k + node) | kPdoInvalid, 4, true);
  }
  for (std::uint16_t k = 2; k < 4; ++k) {
    add(static_cast<std::uint16_t>(object::tpdo_comm + k), 1, (0x180u + 0x100u * k + node) | kPdoInvalid, 4, true);
  }
  return n;
}

void encode_rpdo1(std::uint8_t node, const Rpdo1& r, Frame& out) noexcept {
  out = make(cob::rpdo1 + node, 4);
  put_u16(out, 0, r.controlword);
  put_u16(out, 2, static_cast<std::uint16_t>(r.target_torque));
}

FrameStatus decode_rpdo1(const Frame& f, std::uint8_t node, Rpdo1& out) noexcept {
  if (const FrameStatus s = check(f, cob::rpdo1 + node, 4); s != FrameStatus::ok) return s;
  out.controlword = get_u16(f, 0);
  out.target_torque = static_cast<std::int16_t>(get_u16(f, 2));
  return FrameStatus::ok;
}

FrameStatus decode_tpdo1(const Frame& f, std::uint8_t node, Mapping m, Feedback& out) noexcept {
  const int len = m == Mapping::compact ? 8 : 6;
  if (const FrameStatus s = check(f, cob::tpdo1 + node, len); s != FrameStatus::ok) return s;
  out.statusword = get_u16(f, 0);
  out.position = static_cast<std::int32_t>(get_u32(f, 2));
  if (m == Mapping::compact) out.torque = static_cast<std::int16_t>(get_u16(f, 6));
  return FrameStatus::ok;
}

FrameStatus decode_tpdo2(const Frame& f, std::uint8_t node, Feedback& out) noexcept {
  if (const FrameStatus s = check(f, cob::tpdo2 + node, 6); s != FrameStatus::ok) return s;
  out.velocity = static_cast<std::int32_t>(get_u32(f, 0));
  out.torque = static_cast<std::int16_t>(get_u16(f, 4));
  return FrameStatus::ok;
}

std::int16_t torque_to_permille(double torque_nm, double rated_torque_nm, double gear_ratio,
                                std::uint16_t max_permille) noexcept {
  if (!std::isfinite(torque_nm) || !(rated_torque_nm > 0.0) || !(gear_ratio > 0.0)) return 0;
  const double limit = std::min<double>(max_permille, 32767.0);
  const double permille = std::clamp(std::round(1000.0 * torque_nm / (gear_ratio * rated_torque_nm)), -limit, limit);
  return static_cast<std::int16_t>(permille);
}

double permille_to_torque(std::int16_t permille, double rated_torque_nm, double gear_ratio) noexcept {
  return static_cast<double>(permille) * gear_ratio * rated_torque_nm / 1000.0;
}

TorqueScaleStatus make_torque_scale(std::uint32_t rated_mnm, double gear_ratio, double joint_limit_nm,
                                    std::uint16_t cap_permille, TorqueScale& out) noexcept {
  out = TorqueScale{};
  if (rated_mnm == 0) return TorqueScaleStatus::zero_rating;
  const double step_nm = gear_ratio * static_cast<double>(rated_mnm) / 1e6;  // mNm -> Nm, per mille
  if (!(step_nm > 0.0) || !(joint_limit_nm > 0.0) || step_nm > joint_limit_nm) return TorqueScaleStatus::too_coarse;
  double max_permille = std::min(std::round(joint_limit_nm / step_nm), 32767.0);  // >= 1: step <= limit
  if (cap_permille > 0) max_permille = std::min<double>(max_permille, cap_permille);
  out.nm_per_permille = step_nm;
  out.permille_per_nm = 1.0 / step_nm;
  out.max_permille = static_cast<std::uint16_t>(max_permille);
  return TorqueScaleStatus::ok;
}

std::int16_t torque_to_permille(double torque_nm, const TorqueScale& s) noexcept {
  if (!std::isfinite(torque_nm)) return 0;
  const double limit = s.max_permille;
  return static_cast<std::int16_t>(std::clamp(std::round(torque_nm * s.permille_per_nm), -limit, limit));
}

double permille_to_torque(std::int16_t permille, const TorqueScale& s) noexcept {
  return static_cast<double>(permille) * s.nm_per_permille;
}

}  // namespace springbok::can::cia402
