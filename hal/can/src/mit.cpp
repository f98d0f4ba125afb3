#include "springbok/can/mit.hpp"

#include <algorithm>
#include <cmath>

namespace springbok::can {

const char* to_string(FrameStatus s) noexcept {
  switch (s) {
    case FrameStatus::ok: return "ok";
    case FrameStatus::wrong_dlc: return "wrong DLC";
    case FrameStatus::unexpected_id: return "unexpected id";
    case FrameStatus::bad_value: return "bad value";
    case FrameStatus::bad_command: return "bad command";
    case FrameStatus::error_frame: return "error frame";
  }
  return "?";
}

}  // namespace springbok::can

namespace springbok::can::mit {

namespace {
constexpr std::uint32_t max_uint(int bits) noexcept { return (1u << bits) - 1u; }
}  // namespace

std::uint32_t float_to_uint_rounded(double x, double lo, double hi, int bits) noexcept {
  const double clamped = std::clamp(x, lo, hi);
  const double scaled = (clamped - lo) * static_cast<double>(max_uint(bits)) / (hi - lo) + 0.5;
  const auto u = static_cast<std::uint32_t>(scaled);
  return std::min(u, max_uint(bits));
}

std::uint32_t float_to_uint_truncated(float x, float lo, float hi, int bits) noexcept {
  const float clamped = std::isnan(x) ? lo : std::clamp(x, lo, hi);
  const float span = hi - lo;
  const auto u = static_cast<std::uint32_t>((clamped - lo) * static_cast<float>(max_uint(bits)) / span);
  return std::min(u, max_uint(bits));
}

double uint_to_float(std::uint32_t u, double lo, double hi, int bits) noexcept {
  return static_cast<double>(u) * (hi - lo) / static_cast<double>(max_uint(bits)) + lo;
}

FrameStatus encode_command(std::uint8_t drive_id, const Command& c, const Ranges& r, Frame& out) noexcept {
  if (!std::isfinite(c.p_rad) || !std::isfinite(c.v_rad_s) || !std::isfinite(c.kp) || !std::isfinite(c.kd) ||
      !std::isfinite(c.t_nm)) {
    return FrameStatus::bad_value;
  }
  const std::uint32_t p = float_to_uint_rounded(c.p_rad, r.p_min_rad, r.p_max_rad, kPositionBits);
  const std::uint32_t v = float_to_uint_rounded(c.v_rad_s, r.v_min_rad_s, r.v_max_rad_s, kVelocityBits);
  const std::uint32_t kp = float_to_uint_rounded(c.kp, r.kp_min, r.kp_max, kGainBits);
  const std::uint32_t kd = float_to_uint_rounded(c.kd, r.kd_min, r.kd_max, kGainBits);
  const std::uint32_t t = float_to_uint_rounded(c.t_nm, r.t_min_nm, r.t_max_nm, kTorqueBits);
  out = Frame{};
  out.id = drive_id;
  out.len = kCommandLen;
  out.data[0] = static_cast<std::uint8_t>(p >> 8);
  out.data[1] = static_cast<std::uint8_t>(p & 0xFF);
  out.data[2] = static_cast<std::uint8_t>(v >> 4);
  out.data[3] = static_cast<std::uint8_t>(((v & 0xF) << 4) | (kp >> 8));
  out.data[4] = static_cast<std::uint8_t>(kp & 0xFF);
  out.data[5] = static_cast<std::uint8_t>(kd >> 4);
  out.data[6] = static_cast<std::uint8_t>(((kd & 0xF) << 4) | (t >> 8));
  out.data[7] = static_cast<std::uint8_t>(t & 0xFF);
  // Every field at the top of its range and t in its top codes spell a special frame
  // (FF .. FF FC/FD/FE: enter or exit motor mode, or set zero, CAN.md 1.5). Such a
  // command takes the position one code lower (one 16-bit step, at the range's end).
  if (classify(out) != Special::none) out.data[1] = 0xFE;
  return FrameStatus::ok;
}

void encode_special(std::uint8_t drive_id, Special s, Frame& out) noexcept {
  out = Frame{};
  out.id = drive_id;
  out.len = kCommandLen;
  for (int i = 0; i < 7; ++i) out.data[i] = 0xFF;
  out.data[7] = static_cast<std::uint8_t>(s);
}

Special classify(const Frame& f) noexcept {
  if (f.len != kCommandLen) return Special::none;
  for (int i = 0; i < 7; ++i) {
    if (f.data[i] != 0xFF) return Special::none;
  }
  switch (f.data[7]) {
    case 0xFC: return Special::enter_motor_mode;
    case 0xFD: return Special::exit_motor_mode;
    case 0xFE: return Special::set_zero;
    default: return Special::none;
  }
}

FrameStatus decode_command(const Frame& f, const Ranges& r, Command& out) noexcept {
  if (f.error) return FrameStatus::error_frame;
  if (f.len != kCommandLen) return FrameStatus::wrong_dlc;
  const std::uint32_t p = (std::uint32_t{f.data[0]} << 8) | f.data[1];
  const std::uint32_t v = (std::uint32_t{f.data[2]} << 4) | (f.data[3] >> 4);
  const std::uint32_t kp = ((std::uint32_t{f.data[3]} & 0xF) << 8) | f.data[4];
  const std::uint32_t kd = (std::uint32_t{f.data[5]} << 4) | (f.data[6] >> 4);
  const std::uint32_t t = ((std::uint32_t{f.data[6]} & 0xF) << 8) | f.data[7];
  out.p_rad = uint_to_float(p, r.p_min_rad, r.p_max_rad, kPositionBits);
  out.v_rad_s = uint_to_float(v, r.v_min_rad_s, r.v_max_rad_s, kVelocityBits);
  out.kp = uint_to_float(kp, r.kp_min, r.kp_max, kGainBits);
  out.kd = uint_to_float(kd, r.kd_min, r.kd_max, kGainBits);
  out.t_nm = uint_to_float(t, r.t_min_nm, r.t_max_nm, kTorqueBits);
  return FrameStatus::ok;
}

void encode_reply(std::uint32_t reply_can_id, const Reply& reply, const Ranges& r, int len, Frame& out) noexcept {
  const auto f = [](double x) { return static_cast<float>(x); };
  const std::uint32_t p = float_to_uint_truncated(f(reply.p_rad), f(r.p_min_rad), f(r.p_max_rad), kPositionBits);
  const std::uint32_t v = float_to_uint_truncated(f(reply.v_rad_s), f(r.v_min_rad_s), f(r.v_max_rad_s), kVelocityBits);
  const std::uint32_t i = float_to_uint_truncated(f(reply.t_nm), f(r.t_min_nm), f(r.t_max_nm), kTorqueBits);
  out = Frame{};
  out.id = reply_can_id;
  out.len = static_cast<std::uint8_t>(len);
  out.data[0] = reply.drive_id;
  out.data[1] = static_cast<std::uint8_t>(p >> 8);
  out.data[2] = static_cast<std::uint8_t>(p & 0xFF);
  out.data[3] = static_cast<std::uint8_t>(v >> 4);
  out.data[4] = static_cast<std::uint8_t>(((v & 0xF) << 4) | (i >> 8));
  out.data[5] = static_cast<std::uint8_t>(i & 0xFF);
  if (len == kReplyLenVoltage) {
    out.data[6] = static_cast<std::uint8_t>(float_to_uint_truncated(
        f(reply.bus_voltage_v), f(kBusVoltageMinV), f(kBusVoltageMaxV), kBusVoltageBits));
  } else if (len == kReplyLenVendor) {
    out.data[6] = reply.temperature;
    out.data[7] = reply.error_code;
  }
}

FrameStatus decode_reply(const Frame& f, const Ranges& r, Reply& out) noexcept {
  if (f.error) return FrameStatus::error_frame;
  if (f.len != kReplyLen && f.len != kReplyLenVoltage && f.len != kReplyLenVendor) return FrameStatus::wrong_dlc;
  const std::uint32_t p = (std::uint32_t{f.data[1]} << 8) | f.data[2];
  const std::uint32_t v = (std::uint32_t{f.data[3]} << 4) | (f.data[4] >> 4);
  const std::uint32_t i = ((std::uint32_t{f.data[4]} & 0xF) << 8) | f.data[5];
  out.drive_id = f.data[0];
  out.p_rad = uint_to_float(p, r.p_min_rad, r.p_max_rad, kPositionBits);
  out.v_rad_s = uint_to_float(v, r.v_min_rad_s, r.v_max_rad_s, kVelocityBits);
  out.t_nm = uint_to_float(i, r.t_min_nm, r.t_max_nm, kTorqueBits);
  out.has_bus_voltage = f.len == kReplyLenVoltage;
  out.bus_voltage_v =
      out.has_bus_voltage ? uint_to_float(f.data[6], kBusVoltageMinV, kBusVoltageMaxV, kBusVoltageBits) : 0.0;
  out.has_vendor_bytes = f.len == kReplyLenVendor;
  out.temperature = out.has_vendor_bytes ? f.data[6] : 0;
  out.error_code = out.has_vendor_bytes ? f.data[7] : 0;
  return FrameStatus::ok;
}

}  // namespace springbok::can::mit
