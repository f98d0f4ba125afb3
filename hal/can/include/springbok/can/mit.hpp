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
inline constexpr int kReplyLen = 6;         // bgkatz firmware before July 2023
inline constexpr int kReplyLenVoltage = 7;  // bgkatz firmware since: + bus voltage
inline constexpr int kReplyLenVendor = 8;   // CubeMars: + temperature, error code
// Byte 6 of a 7-byte reply: the drive's bus voltage, 8 bits on [VB_MIN, VB_MAX] (CAN.md 1.4).
inline constexpr int kBusVoltageBits = 8;
inline constexpr double kBusVoltageMinV = 0.0;
inline constexpr double kBusVoltageMaxV = 40.0;

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
  bool has_bus_voltage = false;  // a 7-byte reply
  double bus_voltage_v = 0.0;
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

// Drive -> host, as the firmware (truncating), `len` bytes: kReplyLen, kReplyLenVoltage (byte 6:
// the bus voltage) or kReplyLenVendor (bytes 6..7: temperature, error code).
void encode_reply(std::uint32_t reply_can_id, const Reply& reply, const Ranges& r, int len, Frame& out) noexcept;
// Host side: a reply of 6, 7 or 8 bytes (CAN.md 1.4); any other length is wrong_dlc. The caller
// checks reply.drive_id against its bus (byte 0 is authoritative).
// rt: no alloc
FrameStatus decode_reply(const Frame& f, const Ranges& r, Reply& out) noexcept;

// A joint's velocity from its replies. The reply's velocity is coarse: 12 bits (0.0317
// rad/s at +-65 rad/s) and truncated by the drive, so a joint at rest reads -0.016 rad/s
// and one creeping at a few mrad/s reads a constant code; the WBC's template renders
// those as forces (a 30 N push rendered with a 14 % NRMSE instead of 0.6 %, in HIL and
// in tests/app/timing). The 16-bit position (0.38 mrad) is finer. A second-order observer
// integrates the reply's velocity plus a correction b that it learns from the position
// residual, so that the velocity integrates to the measured position:
//     q^ += dt (v + b);   e = q - q^;   q^ += dt l1 e;   b += dt l2 e;   velocity = v + b
// with l1 = 2 zeta w, l2 = w^2 (zeta = 0.7): b follows the quantisation error below w
// [rad/s]; above it the reply's velocity passes unchanged (no added lag). b is bounded by
// `max_correction` (a few LSB: the truncation error is below one).
class VelocityObserver {
 public:
  // w = 0: the reply's velocity as sent. Start-up only.
  void configure(double bandwidth_rad_s, double max_correction_rad_s) noexcept {
    l1_ = 1.4 * bandwidth_rad_s;
    l2_ = bandwidth_rad_s * bandwidth_rad_s;
    max_correction_ = max_correction_rad_s;
    started_ = false;
  }
  // One reply, `dt_s` after the previous one: 0 for a second reply in the same tick (no
  // update), < 0 (no previous reply) or too long for the observer: restart from this reply.
  // Returns the joint velocity. rt: no alloc
  double update(double q_rad, double v_rad_s, double dt_s) noexcept {
    if (l2_ <= 0.0) return v_rad_s;
    if (!started_ || !(dt_s >= 0.0 && dt_s * l1_ < 1.0)) {
      started_ = true;
      q_hat_ = q_rad;
      correction_ = 0.0;
      return v_rad_s;
    }
    if (dt_s == 0.0) return v_rad_s + correction_;
    q_hat_ += dt_s * (v_rad_s + correction_);
    const double e = q_rad - q_hat_;
    q_hat_ += dt_s * l1_ * e;
    correction_ += dt_s * l2_ * e;
    if (correction_ > max_correction_) correction_ = max_correction_;
    if (correction_ < -max_correction_) correction_ = -max_correction_;
    return v_rad_s + correction_;
  }
  double correction_rad_s() const noexcept { return correction_; }

 private:
  double l1_ = 0.0, l2_ = 0.0, max_correction_ = 0.0;
  bool started_ = false;
  double q_hat_ = 0.0, correction_ = 0.0;
};

// The LSB of the reply's velocity field for these ranges [rad/s].
inline double velocity_lsb_rad_s(const Ranges& r) noexcept {
  return (r.v_max_rad_s - r.v_min_rad_s) / static_cast<double>((1u << kVelocityBits) - 1u);
}

}  // namespace springbok::can::mit
