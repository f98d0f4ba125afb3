// MIT mode (Ben Katz motorcontrol / Mini Cheetah / CubeMars "MIT mode"), CAN.md section 1.
// Pure codecs: no I/O. Fields big-endian, packed byte by byte.
#pragma once

#include <cstdint>

#include "springbok/can/frame.hpp"

namespace springbok::can::mit {

// Field ranges: per-drive configuration, both ends must agree (CAN.md 1.2).
struct Ranges {
  double p_min_rad = -12.5, p_max_rad = 12.5;
  double v_min_rad_s = -65.0, v_max_rad_s = 65.0;
  double kp_min = 0.0, kp_max = 500.0;
  double kd_min = 0.0, kd_max = 5.0;
  double t_min_nm = -18.0, t_max_nm = 18.0;
};

inline constexpr int kPositionBits = 16;
inline constexpr int kVelocityBits = 12;
inline constexpr int kGainBits = 12;
inline constexpr int kTorqueBits = 12;
inline constexpr int kCommandLen = 8;
inline constexpr int kReplyLen = 6;        // bgkatz firmware
inline constexpr int kReplyLenVendor = 8;  // CubeMars: + temperature, error code

struct Command {
  double p_rad = 0.0;
  double v_rad_s = 0.0;
  double kp = 0.0;     // Nm/rad
  double kd = 0.0;     // Nm s/rad
  double t_nm = 0.0;   // feed-forward torque
};

struct Reply {
  std::uint8_t drive_id = 0;
  double p_rad = 0.0;
  double v_rad_s = 0.0;
  double t_nm = 0.0;          // measured torque
  bool has_vendor_bytes = false;
  std::uint8_t temperature = 0;
  std::uint8_t error_code = 0;
};

// The three special frames (CAN.md 1.5); `none` for an ordinary command.
enum class Special : std::uint8_t { none = 0, enter_motor_mode = 0xFC, exit_motor_mode = 0xFD, set_zero = 0xFE };

// Host side: clamp to [lo, hi], round to nearest. Precondition: x finite.
std::uint32_t float_to_uint_rounded(double x, double lo, double hi, int bits) noexcept;
// Drive side, as the firmware: float arithmetic, truncation. The emulator
// clamps first (the firmware's callers do) so an out-of-range state cannot wrap.
std::uint32_t float_to_uint_truncated(float x, float lo, float hi, int bits) noexcept;
double uint_to_float(std::uint32_t u, double lo, double hi, int bits) noexcept;

// Host -> drive. Rejects a non-finite field (bad_value) and never encodes it.
// rt: no alloc
FrameStatus encode_command(std::uint8_t drive_id, const Command& cmd, const Ranges& r, Frame& out) noexcept;
// rt: no alloc
void encode_special(std::uint8_t drive_id, Special s, Frame& out) noexcept;

// Drive side of a host frame: which special it is, or the command it carries.
Special classify(const Frame& f) noexcept;
FrameStatus decode_command(const Frame& f, const Ranges& r, Command& out) noexcept;

// Drive -> host, as the firmware (truncating). `vendor` adds bytes 6..7.
void encode_reply(std::uint32_t reply_can_id, const Reply& reply, const Ranges& r, bool vendor, Frame& out) noexcept;
// Host side. The caller checks reply.drive_id against its bus (byte 0 is authoritative).
// rt: no alloc
FrameStatus decode_reply(const Frame& f, const Ranges& r, Reply& out) noexcept;

}  // namespace springbok::can::mit
