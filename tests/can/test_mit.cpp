// MIT mode codec against CAN.md section 1.6 (worked example), byte by byte.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <numbers>
#include <random>

#include "alloc_trap.hpp"
#include "springbok/can/mit.hpp"

#include "frame_util.hpp"

namespace springbok::can::mit {
namespace {

using frame_util::frame_of;

std::array<std::uint8_t, 8> bytes8(const Frame& f) {
  std::array<std::uint8_t, 8> b{};
  for (int i = 0; i < 8; ++i) b[i] = f.data[i];
  return b;
}

TEST(MitCodec, WorkedExampleFieldsTruncatedLikeTheFirmware) {
  const Ranges r;  // Mini Cheetah defaults
  EXPECT_EQ(float_to_uint_truncated(1.0f, -12.5f, 12.5f, 16), 35388u);
  EXPECT_EQ(float_to_uint_truncated(-2.0f, -65.f, 65.f, 12), 1984u);
  EXPECT_EQ(float_to_uint_truncated(50.f, 0.f, 500.f, 12), 409u);
  EXPECT_EQ(float_to_uint_truncated(1.0f, 0.f, 5.f, 12), 819u);
  EXPECT_EQ(float_to_uint_truncated(3.0f, -18.f, 18.f, 12), 2388u);
  (void)r;
}

TEST(MitCodec, WorkedExampleDriveDecodesTheTruncatedFrame) {
  const Frame f = frame_of(0x003, {0x8A, 0x3C, 0x7C, 0x01, 0x99, 0x33, 0x39, 0x54});
  EXPECT_EQ(classify(f), Special::none);
  Command c;
  ASSERT_EQ(decode_command(f, Ranges{}, c), FrameStatus::ok);
  EXPECT_NEAR(c.p_rad, 0.999657, 1e-6);
  EXPECT_NEAR(c.v_rad_s, -2.015873, 1e-6);
  EXPECT_NEAR(c.kp, 49.938950, 1e-6);
  EXPECT_NEAR(c.kd, 1.000000, 1e-6);
  EXPECT_NEAR(c.t_nm, 2.993406, 1e-6);
}

TEST(MitCodec, WorkedExampleHostCommandRoundsToNearest) {
  Frame f;
  ASSERT_EQ(encode_command(3, Command{1.0, -2.0, 50.0, 1.0, 3.0}, Ranges{}, f), FrameStatus::ok);
  EXPECT_EQ(f.id, 0x003u);
  EXPECT_EQ(f.len, 8);
  EXPECT_FALSE(f.fd);
  const std::array<std::uint8_t, 8> expected{0x8A, 0x3D, 0x7C, 0x11, 0x9A, 0x33, 0x39, 0x55};
  EXPECT_EQ(bytes8(f), expected);
}

TEST(MitCodec, WorkedExampleReplyEncodedAndDecoded) {
  Frame f;
  Reply in;
  in.drive_id = 3;
  in.p_rad = 0.5;
  in.v_rad_s = 1.25;
  in.t_nm = -2.0;
  encode_reply(0x103, in, Ranges{}, kReplyLen, f);
  EXPECT_EQ(f.id, 0x103u);
  ASSERT_EQ(f.len, 6);
  const std::array<std::uint8_t, 6> expected{0x03, 0x85, 0x1E, 0x82, 0x67, 0x1C};
  for (int i = 0; i < 6; ++i) EXPECT_EQ(f.data[i], expected[i]) << "byte " << i;

  Reply out;
  ASSERT_EQ(decode_reply(f, Ranges{}, out), FrameStatus::ok);
  EXPECT_EQ(out.drive_id, 3);
  EXPECT_NEAR(out.p_rad, 0.499924, 1e-6);
  // CAN.md's 1.222221 was computed in float; the double decode is the exact closed form.
  EXPECT_NEAR(out.v_rad_s, 1.222221, 2e-6);
  EXPECT_NEAR(out.v_rad_s, 2086.0 * 130.0 / 4095.0 - 65.0, 1e-12);
  EXPECT_NEAR(out.t_nm, -2.000000, 1e-6);
  EXPECT_FALSE(out.has_vendor_bytes);
}

TEST(MitCodec, ClampsOutOfRangeInsteadOfWrapping) {
  Frame f;
  // t far below T_MIN must become 0 (full negative), never wrap to the positive end.
  ASSERT_EQ(encode_command(1, Command{-100.0, 1000.0, -5.0, 99.0, -200.0}, Ranges{}, f), FrameStatus::ok);
  Command c;
  ASSERT_EQ(decode_command(f, Ranges{}, c), FrameStatus::ok);
  EXPECT_DOUBLE_EQ(c.p_rad, -12.5);
  EXPECT_DOUBLE_EQ(c.v_rad_s, 65.0);
  EXPECT_DOUBLE_EQ(c.kp, 0.0);
  EXPECT_DOUBLE_EQ(c.kd, 5.0);
  EXPECT_DOUBLE_EQ(c.t_nm, -18.0);
}

TEST(MitCodec, RejectsNonFiniteAndLeavesTheFrameAlone) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  Frame f = frame_of(0x7, {1, 2, 3});
  const Frame before = f;
  EXPECT_EQ(encode_command(1, Command{nan, 0, 0, 0, 0}, Ranges{}, f), FrameStatus::bad_value);
  EXPECT_EQ(encode_command(1, Command{0, 0, 0, 0, inf}, Ranges{}, f), FrameStatus::bad_value);
  EXPECT_EQ(encode_command(1, Command{0, 0, nan, 0, 0}, Ranges{}, f), FrameStatus::bad_value);
  EXPECT_EQ(f.id, before.id);
  EXPECT_EQ(f.len, before.len);
}

TEST(MitCodec, RoundTripErrorIsAtMostHalfAnLsb) {
  // Oracle: rounding to nearest on a uniform grid errs by at most LSB / 2.
  Ranges r;
  r.t_min_nm = -150.0;
  r.t_max_nm = 150.0;
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  const double lsb_p = 25.0 / 65535.0, lsb_v = 130.0 / 4095.0, lsb_kp = 500.0 / 4095.0, lsb_kd = 5.0 / 4095.0,
               lsb_t = 300.0 / 4095.0;
  for (int k = 0; k < 2000; ++k) {
    const Command in{-12.5 + 25.0 * u(rng), -65.0 + 130.0 * u(rng), 500.0 * u(rng), 5.0 * u(rng), -150.0 + 300.0 * u(rng)};
    Frame f;
    ASSERT_EQ(encode_command(9, in, r, f), FrameStatus::ok);
    Command out;
    ASSERT_EQ(decode_command(f, r, out), FrameStatus::ok);
    EXPECT_LE(std::abs(out.p_rad - in.p_rad), lsb_p / 2 + 1e-12);
    EXPECT_LE(std::abs(out.v_rad_s - in.v_rad_s), lsb_v / 2 + 1e-12);
    EXPECT_LE(std::abs(out.kp - in.kp), lsb_kp / 2 + 1e-12);
    EXPECT_LE(std::abs(out.kd - in.kd), lsb_kd / 2 + 1e-12);
    EXPECT_LE(std::abs(out.t_nm - in.t_nm), lsb_t / 2 + 1e-12);
  }
}

TEST(MitCodec, SpecialFrames) {
  Frame f;
  encode_special(5, Special::enter_motor_mode, f);
  EXPECT_EQ(f.id, 5u);
  const std::array<std::uint8_t, 8> enter{0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFC};
  EXPECT_EQ(bytes8(f), enter);
  EXPECT_EQ(classify(f), Special::enter_motor_mode);
  encode_special(5, Special::exit_motor_mode, f);
  EXPECT_EQ(f.data[7], 0xFD);
  EXPECT_EQ(classify(f), Special::exit_motor_mode);
  encode_special(5, Special::set_zero, f);
  EXPECT_EQ(f.data[7], 0xFE);
  EXPECT_EQ(classify(f), Special::set_zero);
  // All-FF with another last byte is an ordinary (extreme) command.
  EXPECT_EQ(classify(frame_of(5, {0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFB})), Special::none);
}

// A command with every field at the top of its range and t in its top codes would spell a
// special frame (FF .. FF FC/FD/FE, CAN.md 1.5: set zero must never go out by accident):
// the encoder takes the position one code lower.
TEST(MitCodec, ASaturatedCommandNeverSpellsASpecialFrame) {
  const Ranges r;
  const double t_lsb = (r.t_max_nm - r.t_min_nm) / 4095.0;
  for (int code = 0xFFA; code <= 0xFFF; ++code) {
    const Command c{.p_rad = r.p_max_rad + 1.0, .v_rad_s = r.v_max_rad_s + 1.0, .kp = r.kp_max, .kd = r.kd_max,
                    .t_nm = r.t_min_nm + code * t_lsb};
    Frame f;
    ASSERT_EQ(encode_command(7, c, r, f), FrameStatus::ok);
    EXPECT_EQ(classify(f), Special::none) << std::hex << code;
    Command back;
    ASSERT_EQ(decode_command(f, r, back), FrameStatus::ok);
    const double p_lsb = (r.p_max_rad - r.p_min_rad) / 65535.0;
    EXPECT_LE(r.p_max_rad - back.p_rad, p_lsb + 1e-12) << std::hex << code;  // at most one code below the top
    EXPECT_NEAR(back.t_nm, c.t_nm, t_lsb / 2 + 1e-12);
  }
}

TEST(MitCodec, DecodersRejectBadFrames) {
  Reply rep;
  Command cmd;
  // CAN.md 1.4: 6, 7 or 8 bytes; any other length is malformed.
  EXPECT_EQ(decode_reply(frame_of(0x103, {3, 0, 0, 0, 0}), Ranges{}, rep), FrameStatus::wrong_dlc);
  EXPECT_EQ(decode_reply(frame_of(0x103, {}), Ranges{}, rep), FrameStatus::wrong_dlc);
  Frame long_reply = frame_of(0x103, {3, 0x85, 0x1E, 0x82, 0x67, 0x1C, 0, 0});
  long_reply.fd = true;
  long_reply.len = 12;
  EXPECT_EQ(decode_reply(long_reply, Ranges{}, rep), FrameStatus::wrong_dlc);
  EXPECT_EQ(decode_command(frame_of(0x3, {1, 2, 3, 4, 5, 6}), Ranges{}, cmd), FrameStatus::wrong_dlc);
  Frame err = frame_of(0x40, {0, 0, 0, 0, 0, 0});
  err.error = true;
  EXPECT_EQ(decode_reply(err, Ranges{}, rep), FrameStatus::error_frame);
  // The CubeMars 8-byte variant carries temperature and an error code.
  ASSERT_EQ(decode_reply(frame_of(0x103, {3, 0x85, 0x1E, 0x82, 0x67, 0x1C, 40, 7}), Ranges{}, rep), FrameStatus::ok);
  EXPECT_TRUE(rep.has_vendor_bytes);
  EXPECT_EQ(rep.temperature, 40);
  EXPECT_EQ(rep.error_code, 7);
}

// CAN.md 1.4: the reference firmware since July 2023 adds byte 6, the bus voltage on 0..40 V in
// 8 bits; bytes 0..5 mean what they mean in a 6-byte reply.
TEST(MitCodec, ASevenByteReplyCarriesTheBusVoltage) {
  Reply rep;
  ASSERT_EQ(decode_reply(frame_of(0x103, {3, 0x85, 0x1E, 0x82, 0x67, 0x1C, 153}), Ranges{}, rep), FrameStatus::ok);
  EXPECT_EQ(rep.drive_id, 3);
  EXPECT_NEAR(rep.p_rad, 0.499924, 1e-6);
  EXPECT_NEAR(rep.t_nm, -2.0, 1e-6);
  EXPECT_TRUE(rep.has_bus_voltage);
  EXPECT_DOUBLE_EQ(rep.bus_voltage_v, 24.0);  // 153 / 255 * 40
  EXPECT_FALSE(rep.has_vendor_bytes);
  ASSERT_EQ(decode_reply(frame_of(0x103, {3, 0x85, 0x1E, 0x82, 0x67, 0x1C, 255}), Ranges{}, rep), FrameStatus::ok);
  EXPECT_DOUBLE_EQ(rep.bus_voltage_v, 40.0);
  ASSERT_EQ(decode_reply(frame_of(0x103, {3, 0x85, 0x1E, 0x82, 0x67, 0x1C}), Ranges{}, rep), FrameStatus::ok);
  EXPECT_FALSE(rep.has_bus_voltage);

  // The drive side, truncating as the firmware does: 24 V is code 153, 23.99 V code 152.
  Reply in;
  in.drive_id = 3;
  in.p_rad = 0.5;
  in.v_rad_s = 1.25;
  in.t_nm = -2.0;
  in.bus_voltage_v = 24.0;
  Frame f;
  encode_reply(0x103, in, Ranges{}, kReplyLenVoltage, f);
  ASSERT_EQ(f.len, 7);
  const std::array<std::uint8_t, 7> expected{0x03, 0x85, 0x1E, 0x82, 0x67, 0x1C, 153};
  for (int i = 0; i < 7; ++i) EXPECT_EQ(f.data[i], expected[i]) << "byte " << i;
  in.bus_voltage_v = 23.99;
  encode_reply(0x103, in, Ranges{}, kReplyLenVoltage, f);
  EXPECT_EQ(f.data[6], 152);
}

TEST(MitCodec, EncodeAndDecodeDoNotAllocate) {
  Frame f;
  Reply r;
  VelocityObserver obs;
  obs.configure(40.0, 0.1);
  double v = 0.0;
  const std::size_t n = test::count_allocations([&] {
    for (int k = 0; k < 100; ++k) {
      (void)encode_command(3, Command{1.0, -2.0, 50.0, 1.0, 3.0 + k}, Ranges{}, f);
      (void)decode_reply(f, Ranges{}, r);
      v += obs.update(r.p_rad, r.v_rad_s, k == 0 ? -1.0 : 0.001);
    }
  });
  EXPECT_TRUE(std::isfinite(v));
  EXPECT_EQ(n, 0u);
}

// A joint's true motion through the drive's truncating reply and the host's decoder.
Reply through_the_wire(double q_rad, double v_rad_s, const Ranges& r) {
  Frame f;
  encode_reply(0x101, Reply{1, q_rad, v_rad_s, 0.0}, r, kReplyLen, f);
  Reply out;
  EXPECT_EQ(decode_reply(f, r, out), FrameStatus::ok);
  return out;
}

// The reply's velocity is 0.0317 rad/s coarse and truncated: at rest it reads -0.016 rad/s,
// creeping at 5 mrad/s it reads one constant code. The observer recovers both from the finer
// position within a few time constants; the correction stays within its bound.
TEST(MitVelocityObserver, RemovesTheTruncationBiasAndTheDeadbandOfTheVelocityField) {
  const Ranges r;
  const double lsb = velocity_lsb_rad_s(r);
  EXPECT_NEAR(lsb, 130.0 / 4095.0, 1e-12);
  for (const double v_true : {0.0, 0.005, -0.025, 0.41}) {
    VelocityObserver obs;
    obs.configure(40.0, 3.0 * lsb);
    double q = 0.3, raw_bias = 0.0, bias = 0.0, worst = 0.0;
    constexpr int kTicks = 2000, kSettled = 500;
    for (int k = 0; k < kTicks; ++k) {
      q += 0.001 * v_true;
      const Reply rep = through_the_wire(q, v_true, r);
      const double v = obs.update(rep.p_rad, rep.v_rad_s, k == 0 ? -1.0 : 0.001);
      if (k >= kSettled) {
        raw_bias += (rep.v_rad_s - v_true) / (kTicks - kSettled);
        bias += (v - v_true) / (kTicks - kSettled);
        worst = std::max(worst, std::abs(v - v_true));
      }
      EXPECT_LE(std::abs(obs.correction_rad_s()), 3.0 * lsb);
    }
    EXPECT_GT(std::abs(raw_bias), 0.3 * lsb) << v_true;  // the raw field: a constant error of a fraction of an LSB
    EXPECT_LT(std::abs(bias), 0.03 * lsb) << v_true;     // the observer's: its mean is the true velocity
    EXPECT_LT(worst, 0.15 * lsb) << v_true;              // within the position's quantisation ripple
  }
}

// Above its bandwidth the observer passes the reply's velocity through: a 10 Hz oscillation
// of 0.5 rad/s keeps its amplitude (no lag added to the control loop's damping).
TEST(MitVelocityObserver, PassesFastMotionThroughAndRestartsAfterAGap) {
  const Ranges r;
  VelocityObserver obs;
  obs.configure(40.0, 3.0 * velocity_lsb_rad_s(r));
  double err_max = 0.0;
  for (int k = 0; k < 2000; ++k) {
    const double t = 0.001 * k, w = 2.0 * std::numbers::pi * 10.0;
    const double q = 0.05 / w * std::sin(w * t) * 10.0, v = 0.5 * std::cos(w * t);
    const Reply rep = through_the_wire(q, v, r);
    const double out = obs.update(rep.p_rad, rep.v_rad_s, k == 0 ? -1.0 : 0.001);
    if (k > 200) err_max = std::max(err_max, std::abs(out - v));
  }
  EXPECT_LT(err_max, 1.5 * velocity_lsb_rad_s(r));
  // A same-tick duplicate changes nothing; a gap longer than the observer can bridge restarts it.
  const double c = obs.correction_rad_s();
  EXPECT_DOUBLE_EQ(obs.update(0.0, 0.25, 0.0), 0.25 + c);
  EXPECT_DOUBLE_EQ(obs.update(0.0, 0.25, 1.0), 0.25);
  EXPECT_DOUBLE_EQ(obs.correction_rad_s(), 0.0);
  VelocityObserver off;
  off.configure(0.0, 1.0);
  EXPECT_DOUBLE_EQ(off.update(1.0, -0.3, 0.001), -0.3);
}

}  // namespace
}  // namespace springbok::can::mit
