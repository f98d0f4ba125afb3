// The trunk IMU and wrist F/T on the CAN bus (CAN.md section 6): frames built by hand
// from the spec's layout (little-endian int16, counter byte 6, status byte 7) decoded
// against hand-computed values; every rejection kind; counter wrap-around; newest-complete
// selection with interleaved and split samples; stale detection.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <vector>

#include "alloc_trap.hpp"
#include "springbok/can/sensors.hpp"

#include "frame_util.hpp"

namespace springbok::can {
namespace {

using frame_util::bytes;
using frame_util::frame_of;

constexpr std::uint8_t kValid = 0x01;

// One IMU sample's three frames with the given raw fields.
struct ImuRaw {
  std::array<std::int16_t, 3> q{0, 0, 0}, w{0, 0, 0}, a{0, 0, 0};
};
Frame imu_frame_raw(std::uint32_t id, const std::array<std::int16_t, 3>& v, std::uint8_t counter, std::uint8_t status) {
  SensorFrameFields ff;
  ff.v = v;
  ff.counter = counter;
  ff.status = status;
  Frame f;
  encode_sensor_frame(id, ff, f);
  return f;
}

class Imu : public ::testing::Test {
 protected:
  void SetUp() override {
    cfg.enabled = true;
    cfg.bus = "sensors";
    imu.configure(cfg, 0);
  }
  // Pushes the three frames of one sample; returns the last event.
  SensorEvent sample(std::uint8_t counter, std::uint64_t tick, std::uint8_t status = kValid, const ImuRaw& raw = {}) {
    imu.push(imu_frame_raw(0x6A0, raw.q, counter, status), tick);
    imu.push(imu_frame_raw(0x6A1, raw.w, counter, status), tick);
    return imu.push(imu_frame_raw(0x6A2, raw.a, counter, status), tick);
  }
  ImuConfig cfg;
  ImuAssembler imu;
};

TEST_F(Imu, DecodesHandBuiltFramesToTheSpecsScales) {
  // q = 90 deg about z: q_z = round(0.70710678 * 2^15) = 23170 = 0x5A82 (LE: 82 5A), counter 7, valid.
  EXPECT_EQ(imu.push(frame_of(0x6A0, {0x00, 0x00, 0x00, 0x00, 0x82, 0x5A, 0x07, 0x01}), 1), SensorEvent::stored);
  // w = (1024, -512, 32767) counts x 2^-10 = (1, -0.5, 31.9990234375) rad/s.
  EXPECT_EQ(imu.push(frame_of(0x6A1, {0x00, 0x04, 0x00, 0xFE, 0xFF, 0x7F, 0x07, 0x01}), 1), SensorEvent::stored);
  // a = (-128, 0, 5023) counts x 2^-9 = (-0.25, 0, 9.810546875) m/s^2.
  EXPECT_EQ(imu.push(frame_of(0x6A2, {0x80, 0xFF, 0x00, 0x00, 0x9F, 0x13, 0x07, 0x01}), 1), SensorEvent::accepted);
  imu.update(1);
  ASSERT_TRUE(imu.usable());
  const ImuReading r = imu.reading();
  EXPECT_EQ(r.orientation.x(), 0.0);
  EXPECT_EQ(r.orientation.y(), 0.0);
  EXPECT_EQ(r.orientation.z(), 0.70709228515625);           // 23170 / 32768
  EXPECT_NEAR(r.orientation.w(), 0.7071212769196755, 1e-15);  // +sqrt(1 - q_z^2)
  EXPECT_EQ(r.angular_rate_rad_s, Eigen::Vector3d(1.0, -0.5, 31.9990234375));
  EXPECT_EQ(r.linear_accel_m_s2, Eigen::Vector3d(-0.25, 0.0, 9.810546875));
  EXPECT_EQ(imu.diagnostics().last_counter, 7);
  EXPECT_EQ(imu.diagnostics().samples_accepted, 1u);
  EXPECT_FALSE(imu.diagnostics().not_ready);
}

TEST_F(Imu, EncoderProducesTheSameHandComputedBytes) {
  ImuReading r;
  r.orientation = Eigen::Quaterniond(Eigen::AngleAxisd(M_PI / 2, Eigen::Vector3d::UnitZ()));
  r.angular_rate_rad_s = Eigen::Vector3d(1.0, -0.5, 31.999);
  r.linear_accel_m_s2 = Eigen::Vector3d(-0.25, 0.0, 9.81);
  std::array<Frame, kImuFrames> f;
  ASSERT_TRUE(encode_imu_sample(cfg, r, 7, kValid, f));
  EXPECT_EQ(f[0].id, 0x6A0u);
  EXPECT_EQ(bytes(f[0]), (std::vector<int>{0x00, 0x00, 0x00, 0x00, 0x82, 0x5A, 0x07, 0x01}));
  EXPECT_EQ(bytes(f[1]), (std::vector<int>{0x00, 0x04, 0x00, 0xFE, 0xFF, 0x7F, 0x07, 0x01}));
  EXPECT_EQ(bytes(f[2]), (std::vector<int>{0x80, 0xFF, 0x00, 0x00, 0x9F, 0x13, 0x07, 0x01}));
  // The sensor sends q with q_w >= 0: -q encodes the same.
  std::array<Frame, kImuFrames> g;
  r.orientation.coeffs() *= -1.0;
  ASSERT_TRUE(encode_imu_sample(cfg, r, 7, kValid, g));
  EXPECT_EQ(bytes(g[0]), bytes(f[0]));
  // Saturation: 40 rad/s is beyond +-32 rad/s: 32767 and the clipping bit.
  r.angular_rate_rad_s.x() = 40.0;
  ASSERT_TRUE(encode_imu_sample(cfg, r, 8, kValid, g));
  EXPECT_EQ(bytes(g[1]), (std::vector<int>{0xFF, 0x7F, 0x00, 0xFE, 0xFF, 0x7F, 0x08, 0x05}));
  EXPECT_EQ(g[0].data[7], 0x05);
  // Not finite: refused.
  r.linear_accel_m_s2.z() = std::nan("");
  EXPECT_FALSE(encode_imu_sample(cfg, r, 9, kValid, g));
}

TEST_F(Imu, QuaternionNormLimitIsOnePlusTwoToTheMinusTen) {
  // 32767^2 + 1055^2 = 1074789314 <= 2^30 + 2^20 = 1074790400: accepted, q_w = 0.
  ImuRaw ok;
  ok.q = {32767, 1055, 0};
  EXPECT_EQ(sample(1, 1, kValid, ok), SensorEvent::accepted);
  imu.update(1);
  EXPECT_EQ(imu.reading().orientation.w(), 0.0);
  // 32767^2 + 1056^2 = 1074791425 > 2^30 + 2^20: corrupt.
  ImuRaw bad;
  bad.q = {32767, 1056, 0};
  EXPECT_EQ(sample(2, 2, kValid, bad), SensorEvent::bad_quaternion);
  EXPECT_EQ(imu.diagnostics().bad_quaternion, 1u);
  EXPECT_EQ(imu.diagnostics().samples_accepted, 1u);
  EXPECT_EQ(imu.diagnostics().last_counter, 1);
}

TEST_F(Imu, EveryRejectionKindIsCountedOnce) {
  EXPECT_EQ(sample(1, 1), SensorEvent::accepted);
  // Wrong DLC: 7 bytes; an FD frame; an error frame.
  EXPECT_EQ(imu.push(frame_of(0x6A1, {0, 0, 0, 0, 0, 0, 2}), 2), SensorEvent::wrong_dlc);
  Frame fd = imu_frame_raw(0x6A1, {0, 0, 0}, 2, kValid);
  fd.fd = true;
  EXPECT_EQ(imu.push(fd, 2), SensorEvent::wrong_dlc);
  EXPECT_EQ(imu.diagnostics().wrong_dlc, 2u);
  // Status not valid in one of the three frames.
  imu.push(imu_frame_raw(0x6A0, {0, 0, 0}, 2, kValid), 2);
  imu.push(imu_frame_raw(0x6A1, {0, 0, 0}, 2, 0x00), 2);
  EXPECT_EQ(imu.push(imu_frame_raw(0x6A2, {0, 0, 0}, 2, kValid), 2), SensorEvent::status_invalid);
  // Reserved status bits (bit 3).
  EXPECT_EQ(sample(3, 3, 0x09), SensorEvent::reserved_bits);
  // The same counter again after a complete sample: stale.
  EXPECT_EQ(sample(3, 4), SensorEvent::stale_counter);
  // A jump of 4 > stale_ticks (3): rejected, and counting resyncs to it.
  EXPECT_EQ(sample(7, 5), SensorEvent::counter_jump);
  EXPECT_EQ(sample(8, 6), SensorEvent::accepted);
  // A jump of exactly stale_ticks is accepted.
  EXPECT_EQ(sample(11, 7), SensorEvent::accepted);
  const SensorDiagnostics& d = imu.diagnostics();
  EXPECT_EQ(d.status_invalid, 1u);
  EXPECT_EQ(d.reserved_bits, 1u);
  EXPECT_EQ(d.stale_counters, 1u);
  EXPECT_EQ(d.counter_jumps, 1u);
  EXPECT_EQ(d.samples_accepted, 3u);
  EXPECT_EQ(d.last_counter, 11);
  EXPECT_EQ(d.frames, 3u * 7u + 2u);
}

TEST_F(Imu, ClippingIsUsedAndCountedAndAStreakIsReported) {
  cfg.clip_streak = 3;
  imu.configure(cfg, 0);
  ImuRaw raw;
  raw.w = {32767, 0, 0};
  for (int k = 1; k <= 2; ++k) EXPECT_EQ(sample(static_cast<std::uint8_t>(k), k, 0x05, raw), SensorEvent::accepted);
  EXPECT_FALSE(imu.diagnostics().clip_streak_fault);
  EXPECT_EQ(sample(3, 3, 0x05, raw), SensorEvent::accepted);
  EXPECT_TRUE(imu.diagnostics().clip_streak_fault);
  EXPECT_EQ(imu.diagnostics().clipped, 3u);
  imu.update(3);
  EXPECT_EQ(imu.reading().angular_rate_rad_s.x(), 32767.0 / 1024.0);  // the clipped sample is used
  EXPECT_EQ(sample(4, 4), SensorEvent::accepted);
  EXPECT_FALSE(imu.diagnostics().clip_streak_fault);
  EXPECT_EQ(imu.diagnostics().clip_streak, 0u);
  EXPECT_EQ(imu.diagnostics().clip_streak_max, 3u);
  // Not converged (bit 1): accepted and reported.
  EXPECT_EQ(sample(5, 5, 0x03), SensorEvent::accepted);
  EXPECT_TRUE(imu.diagnostics().not_ready);
}

// The IMU of hyq_gen3.urdf is mounted upside down (rpy 0 -pi 0): level, its quaternion is
// (0, 1, 0, 0), whose q_y = 1 is one count past the int16 range and goes out as 32767. That is
// no clipping: the sensor side sets no bit for it, and a sensor that does (a literal "a field
// saturated") makes no streak unless a rate or acceleration sits at the rail. (Before, the
// emulator flagged every level sample of a trot: an 86-sample streak, a latched fault.)
TEST_F(Imu, AUnitQuaternionComponentAtTheRailIsNoClipping) {
  const Eigen::Quaterniond level_upside_down(Eigen::AngleAxisd(-3.14159265359, Eigen::Vector3d::UnitY()));
  ImuReading r;
  r.orientation = level_upside_down;
  r.linear_accel_m_s2 = {0.0, 0.0, -9.81};
  std::array<Frame, kImuFrames> frames;
  ASSERT_TRUE(encode_imu_sample(cfg, r, 1, kValid, frames));
  SensorFrameFields q;
  ASSERT_EQ(decode_sensor_frame(frames[imu_frame::orientation], q), FrameStatus::ok);
  EXPECT_EQ(std::abs(q.v[1]), 32767);
  for (const Frame& f : frames) EXPECT_EQ(f.data[7] & sensor_status::clipping, 0) << std::hex << f.id;

  cfg.clip_streak = 3;
  imu.configure(cfg, 0);
  ImuRaw raw;
  raw.q = {0, 32767, 0};
  for (int k = 1; k <= 5; ++k) EXPECT_EQ(sample(static_cast<std::uint8_t>(k), k, 0x05, raw), SensorEvent::accepted);
  EXPECT_EQ(imu.diagnostics().clipped, 5u);  // the bit is counted
  EXPECT_EQ(imu.diagnostics().clip_streak_max, 0u);
  EXPECT_FALSE(imu.diagnostics().clip_streak_fault);
  raw.a = {0, 0, -32768};  // an acceleration at the rail: a streak
  for (int k = 6; k <= 8; ++k) EXPECT_EQ(sample(static_cast<std::uint8_t>(k), k, 0x05, raw), SensorEvent::accepted);
  EXPECT_TRUE(imu.diagnostics().clip_streak_fault);
}

// CAN.md 6.4: "clipping (the sample is used, the count rises; a streak is a fault)". A saturated
// measurement need not sit at the int16 rail: a gyro whose range is 31.9 rad/s (32666 counts),
// with the orientation off the rail, makes a streak on the bit alone (it made none before: only
// fields at the rail counted).
TEST_F(Imu, AClippingStreakBelowTheRailIsAFault) {
  cfg.clip_streak = 3;
  imu.configure(cfg, 0);
  ImuRaw raw;
  raw.q = {0, 30000, 0};
  raw.w = {32666, 0, 0};
  for (int k = 1; k <= 2; ++k) EXPECT_EQ(sample(static_cast<std::uint8_t>(k), k, 0x05, raw), SensorEvent::accepted);
  EXPECT_FALSE(imu.diagnostics().clip_streak_fault);
  EXPECT_EQ(sample(3, 3, 0x05, raw), SensorEvent::accepted);
  EXPECT_TRUE(imu.diagnostics().clip_streak_fault);
  EXPECT_EQ(imu.diagnostics().clip_streak_max, 3u);
  EXPECT_EQ(sample(4, 4, 0x01, raw), SensorEvent::accepted);  // the bit gone: the streak ends
  EXPECT_FALSE(imu.diagnostics().clip_streak_fault);
}

TEST_F(Imu, CounterWrapsAround) {
  std::uint64_t tick = 0;
  for (int c : {252, 253, 254, 255, 0, 1, 2}) EXPECT_EQ(sample(static_cast<std::uint8_t>(c), ++tick), SensorEvent::accepted) << c;
  EXPECT_EQ(imu.diagnostics().last_counter, 2);
  // 254 -> 2 across the wrap is a jump of 4.
  imu.configure(cfg, 0);
  EXPECT_EQ(sample(254, 1), SensorEvent::accepted);
  EXPECT_EQ(sample(2, 2), SensorEvent::counter_jump);
  // 255 -> 1 is a jump of 2: accepted.
  imu.configure(cfg, 0);
  EXPECT_EQ(sample(255, 1), SensorEvent::accepted);
  EXPECT_EQ(sample(1, 2), SensorEvent::accepted);
}

TEST_F(Imu, NewestCompleteSampleWinsAndFramesAreNeverMixed) {
  // Frames of samples 5 and 6 interleaved; each field carries its counter so a mix shows.
  const auto q = [](int c) { return std::array<std::int16_t, 3>{static_cast<std::int16_t>(100 * c), 0, 0}; };
  const auto w = [](int c) { return std::array<std::int16_t, 3>{static_cast<std::int16_t>(10 * c), 0, 0}; };
  EXPECT_EQ(imu.push(imu_frame_raw(0x6A0, q(5), 5, kValid), 1), SensorEvent::stored);
  EXPECT_EQ(imu.push(imu_frame_raw(0x6A0, q(6), 6, kValid), 1), SensorEvent::stored);
  EXPECT_EQ(imu.push(imu_frame_raw(0x6A1, w(6), 6, kValid), 1), SensorEvent::stored);
  EXPECT_EQ(imu.push(imu_frame_raw(0x6A1, w(5), 5, kValid), 1), SensorEvent::stored);
  EXPECT_EQ(imu.push(imu_frame_raw(0x6A2, w(6), 6, kValid), 1), SensorEvent::accepted);  // 6 complete first
  // Sample 5 completes after 6: late, never used; its partial was dropped.
  EXPECT_EQ(imu.push(imu_frame_raw(0x6A2, w(5), 5, kValid), 1), SensorEvent::late_frame);
  imu.update(1);
  const ImuReading r = imu.reading();
  EXPECT_EQ(r.orientation.x(), 600.0 / 32768.0);
  EXPECT_EQ(r.angular_rate_rad_s.x(), 60.0 / 1024.0);
  EXPECT_EQ(r.linear_accel_m_s2.x(), 60.0 / 512.0);
  EXPECT_EQ(imu.diagnostics().last_counter, 6);
  EXPECT_EQ(imu.diagnostics().late_frames, 1u);
  EXPECT_EQ(imu.diagnostics().incomplete_dropped, 1u);
  // Two samples complete within one tick: the newer one is the reading.
  sample(7, 2, kValid, ImuRaw{q(7), w(7), w(7)});
  sample(8, 2, kValid, ImuRaw{q(8), w(8), w(8)});
  imu.update(2);
  EXPECT_EQ(imu.reading().angular_rate_rad_s.x(), 80.0 / 1024.0);
  EXPECT_EQ(imu.diagnostics().age_ticks, 0u);
}

TEST_F(Imu, FramesOfOneSampleSplitAcrossTicks) {
  EXPECT_EQ(imu.push(imu_frame_raw(0x6A0, {0, 0, 0}, 9, kValid), 1), SensorEvent::stored);
  imu.update(1);
  EXPECT_FALSE(imu.usable());
  EXPECT_EQ(imu.push(imu_frame_raw(0x6A1, {0, 0, 0}, 9, kValid), 2), SensorEvent::stored);
  EXPECT_EQ(imu.push(imu_frame_raw(0x6A2, {0, 0, 0}, 9, kValid), 2), SensorEvent::accepted);
  imu.update(2);
  EXPECT_TRUE(imu.usable());
  EXPECT_EQ(imu.diagnostics().age_ticks, 0u);
}

TEST_F(Imu, StaleAfterStaleTicksThenRecovers) {
  imu.update(1);
  EXPECT_TRUE(imu.diagnostics().lost);  // nothing yet
  EXPECT_EQ(sample(1, 1), SensorEvent::accepted);
  for (std::uint64_t t = 1; t <= 4; ++t) {
    imu.update(t);
    EXPECT_FALSE(imu.diagnostics().lost) << t;
    EXPECT_EQ(imu.diagnostics().age_ticks, t - 1);
  }
  imu.update(5);  // age 4 > 3
  EXPECT_TRUE(imu.diagnostics().lost);
  EXPECT_FALSE(imu.usable());
  EXPECT_EQ(imu.diagnostics().lost_events, 1u);
  // After a long silence the stream resumes far ahead (even "behind" modulo 256): the first
  // sample resyncs the counter, the next one is accepted.
  EXPECT_EQ(sample(200, 300), SensorEvent::counter_jump);
  EXPECT_EQ(sample(201, 301), SensorEvent::accepted);
  imu.update(301);
  EXPECT_TRUE(imu.usable());
}

TEST_F(Imu, TooManyPartialSamplesEvictTheOldest) {
  for (int c = 1; c <= 5; ++c) imu.push(imu_frame_raw(0x6A0, {0, 0, 0}, static_cast<std::uint8_t>(c), kValid), 1);
  EXPECT_EQ(imu.diagnostics().incomplete_dropped, 1u);  // sample 1 made room for sample 5
  imu.push(imu_frame_raw(0x6A1, {0, 0, 0}, 5, kValid), 1);
  EXPECT_EQ(imu.push(imu_frame_raw(0x6A2, {0, 0, 0}, 5, kValid), 1), SensorEvent::accepted);
  EXPECT_EQ(imu.diagnostics().incomplete_dropped, 4u);  // 2, 3, 4 superseded by 5
}

TEST_F(Imu, PushUpdateAndReadingDoNotAllocate) {
  std::array<Frame, kImuFrames> f;
  ImuReading r;
  r.angular_rate_rad_s = Eigen::Vector3d(0.1, 0.2, 0.3);
  ASSERT_TRUE(encode_imu_sample(cfg, r, 0, kValid, f));
  double sum = 0.0;
  const std::size_t allocations = test::count_allocations([&] {
    for (int k = 1; k <= 600; ++k) {
      for (Frame& g : f) {
        g.data[6] = static_cast<std::uint8_t>(k);
        (void)imu.push(g, static_cast<std::uint64_t>(k));
      }
      imu.update(static_cast<std::uint64_t>(k));
      sum += imu.reading().angular_rate_rad_s.sum();
    }
  });
  EXPECT_EQ(allocations, 0u);
  EXPECT_EQ(imu.diagnostics().samples_accepted, 600u);  // counter wrapped twice
  EXPECT_NEAR(sum, 600 * (102 + 205 + 307) / 1024.0, 1e-9);
}

// ---- q_w where the wire leaves it vague (OrientationTrack) ------------------------------------
// A trunk that sways (pitch and roll of a few mrad around level, crossing zero, a 9 Hz
// vibration, a slow yaw) seen by an IMU mounted as robot/hyq_gen3.urdf's trunk_imu (rpy
// 0 -pi 0: upside down, so q_w ~ pitch / 2), sent as CAN.md 6.1 says (q_xyz and the rate
// rounded to counts, q_w >= 0). Each sample's true orientation and its decodings.
struct SwayRun {
  std::vector<Eigen::Quaterniond> truth, track, spec;
  std::vector<std::array<std::int16_t, 3>> counts;
};
// `sway` 0: a trunk standing still, pitched 5 mrad, rolled 3 mrad, no yaw rate; `with_accel` false: the
// track sees no accelerometer (the gyro and the wire alone). The accelerometer reads gravity.
struct SwayOptions {
  double rate_gain = 1.0;
  double sway = 1.0;
  bool with_accel = true;
  int samples = 4000;
};
void sway(const Eigen::Quaterniond& mount, const SwayOptions& o, SwayRun& run) {
  constexpr double kDt_s = 0.001, kPi = 3.14159265358979323846, kG_m_s2 = 9.80665;
  const ImuScales scales;
  const auto trunk = [&](double t) {
    const double pitch = 0.005 * (1.0 - o.sway) +
                         o.sway * (0.004 * std::sin(2 * kPi * 0.7 * t) + 0.0008 * std::sin(2 * kPi * 9.0 * t));
    const double roll = 0.003 * (1.0 - o.sway) + o.sway * 0.003 * std::sin(2 * kPi * 1.3 * t + 0.4);
    return Eigen::Quaterniond(Eigen::AngleAxisd(o.sway * 0.2 * t + 0.3, Eigen::Vector3d::UnitZ()) *
                              Eigen::AngleAxisd(pitch, Eigen::Vector3d::UnitY()) *
                              Eigen::AngleAxisd(roll, Eigen::Vector3d::UnitX()));
  };
  OrientationTrack track;
  for (int k = 0; k < o.samples; ++k) {
    const double t = k * kDt_s;
    const Eigen::Quaterniond q = trunk(t) * mount;
    // The rate in the sensor frame, from the motion over the sample's interval.
    Eigen::Quaterniond delta = (trunk(t - kDt_s) * mount).inverse() * q;
    if (delta.w() < 0.0) delta.coeffs() = -delta.coeffs();  // the short way round
    const Eigen::AngleAxisd step(delta);
    std::array<std::int16_t, 3> rate_counts{}, q_counts{};
    ASSERT_FALSE(encode_scaled(o.rate_gain * step.angle() / kDt_s * step.axis(), scales.rate_rad_s_per_count,
                               rate_counts));
    // An IMU that only rotates feels gravity alone (sensor frame).
    std::array<std::int16_t, 3> accel_counts{};
    ASSERT_FALSE(encode_scaled(q.inverse() * Eigen::Vector3d(0.0, 0.0, kG_m_s2), scales.accel_m_s2_per_count,
                               accel_counts));
    const Eigen::Vector3d accel = o.with_accel ? decode_scaled(accel_counts, scales.accel_m_s2_per_count)
                                               : Eigen::Vector3d::Constant(std::nan(""));
    ASSERT_FALSE(encode_quaternion(q, scales.orientation_per_count, q_counts));
    Eigen::Quaterniond spec;
    ASSERT_TRUE(decode_quaternion(q_counts, scales.orientation_per_count, spec));
    run.truth.push_back(q);
    run.spec.push_back(spec);
    run.counts.push_back(q_counts);
    run.track.push_back(track.update(q_counts, scales.orientation_per_count,
                                     decode_scaled(rate_counts, scales.rate_rad_s_per_count), accel,
                                     k == 0 ? 0.0 : kDt_s));
  }
}
double rms_angle(const std::vector<Eigen::Quaterniond>& a, const std::vector<Eigen::Quaterniond>& b) {
  double sum = 0.0;
  for (std::size_t i = 0; i < a.size(); ++i) sum += std::pow(a[i].angularDistance(b[i]), 2);
  return std::sqrt(sum / static_cast<double>(a.size()));
}
double max_angle(const std::vector<Eigen::Quaterniond>& a, const std::vector<Eigen::Quaterniond>& b) {
  double worst = 0.0;
  for (std::size_t i = 0; i < a.size(); ++i) worst = std::max(worst, a[i].angularDistance(b[i]));
  return worst;
}
const Eigen::Quaterniond kUpsideDown(Eigen::AngleAxisd(-3.14159265359, Eigen::Vector3d::UnitY()));

// Every estimate is one the wire allows: re-encoded, it gives the sample's counts (or their
// negation where q_w = 0: the same rotation).
void expect_consistent_with_the_wire(const SwayRun& run) {
  for (std::size_t k = 0; k < run.track.size(); ++k) {
    std::array<std::int16_t, 3> again{};
    ASSERT_FALSE(encode_quaternion(run.track[k], 1.0 / 32768.0, again));  // false: nothing clipped
    int same = 0, negated = 0;
    for (int i = 0; i < 3; ++i) {
      same = std::max(same, std::abs(again[i] - run.counts[k][i]));
      negated = std::max(negated, std::abs(again[i] + run.counts[k][i]));
    }
    ASSERT_LE(std::min(same, negated), 1) << "sample " << k;
  }
}

TEST(OrientationTrack, UpsideDownImuIsReadToTheWiresResolutionWhereTheSpecsQwIsMradOff) {
  SwayRun run;
  sway(kUpsideDown, SwayOptions{}, run);
  ASSERT_EQ(run.track.size(), 4000u);
  // After the first second (the set has narrowed from the first sample's interval).
  const std::vector<Eigen::Quaterniond> truth(run.truth.begin() + 1000, run.truth.end()),
      track(run.track.begin() + 1000, run.track.end()), spec(run.spec.begin() + 1000, run.spec.end());
  std::printf("upside-down IMU, orientation error after 1 s: q_w by CAN.md 6.1 rms %.2e rad max %.2e; "
              "tracked rms %.2e max %.2e (first second max %.2e)\n",
              rms_angle(spec, truth), max_angle(spec, truth), rms_angle(track, truth), max_angle(track, truth),
              max_angle(run.track, run.truth));
  EXPECT_GT(rms_angle(spec, truth), 2e-3);    // what the firmware saw: a trunk pitched by mrad that it is not
  EXPECT_LT(rms_angle(track, truth), 1e-4);   // a few counts of q_xyz
  EXPECT_LT(max_angle(track, truth), 2e-4);
  EXPECT_LT(max_angle(run.track, run.truth), 0.5 * max_angle(run.spec, run.truth));  // the first second too
  expect_consistent_with_the_wire(run);
  // No jumps where q_w changes sign (the wire's q_xyz flip).
  for (std::size_t k = 1; k < run.track.size(); ++k) {
    ASSERT_LT(run.track[k].angularDistance(run.track[k - 1]), 1e-3) << "sample " << k;
  }
}

TEST(OrientationTrack, UprightImuReadsAsTheSpecsDecoding) {
  SwayRun run;
  sway(Eigen::Quaterniond::Identity(), SwayOptions{}, run);
  ASSERT_EQ(run.track.size(), 4000u);
  EXPECT_LT(max_angle(run.track, run.truth), 1e-4);
  EXPECT_LT(max_angle(run.track, run.spec), 6e-5);  // q_w ~ 1: within a count of CAN.md 6.1's decoding
}

TEST(OrientationTrack, AWrongRateNeverLeavesWhatTheWireAllows) {
  // The gyro reads 3x the motion: the prediction leaves the consistent set, the set restarts
  // from the sample; the estimate stays one that the counts allow.
  SwayRun run;
  SwayOptions o;
  o.rate_gain = 3.0;
  sway(kUpsideDown, o, run);
  ASSERT_EQ(run.track.size(), 4000u);
  expect_consistent_with_the_wire(run);
  EXPECT_LT(max_angle(run.track, run.truth), max_angle(run.spec, run.truth));
}

TEST(OrientationTrack, GravityFindsQwOfATrunkStandingStillWhereTheGyroCannot) {
  // Still and upside down: no motion narrows the set of q_w the wire allows (one sample's, ~0.007
  // wide) and the gyro reads zero, so without the accelerometer the track keeps the fresh
  // start's error (CAN.md 6.1's decoding); with it the error decays with kAccelTimeConstant_s
  // down to what the accelerometer's count (2e-4 g) and the wire resolve.
  SwayOptions still;
  still.sway = 0.0;
  still.samples = 30000;  // 3 time constants
  SwayRun gyro_only, with_gravity;
  still.with_accel = false;
  sway(kUpsideDown, still, gyro_only);
  still.with_accel = true;
  sway(kUpsideDown, still, with_gravity);
  ASSERT_EQ(with_gravity.track.size(), 30000u);
  const auto last_second = [](const std::vector<Eigen::Quaterniond>& v) {
    return std::vector<Eigen::Quaterniond>(v.end() - 1000, v.end());
  };
  const double spec = rms_angle(last_second(with_gravity.spec), last_second(with_gravity.truth));
  const double drifted = rms_angle(last_second(gyro_only.track), last_second(gyro_only.truth));
  const double held = rms_angle(last_second(with_gravity.track), last_second(with_gravity.truth));
  std::printf("still upside-down IMU after 30 s: CAN.md 6.1's q_w %.2e rad, gyro and wire alone %.2e, with gravity %.2e\n",
              spec, drifted, held);
  EXPECT_GT(drifted, 0.5 * spec);
  // A first-order decay over 3 time constants, plus the accelerometer's resolution.
  EXPECT_LT(held, std::exp(-30.0 / OrientationTrack::kAccelTimeConstant_s) * spec + 2e-4);
  expect_consistent_with_the_wire(with_gravity);
}

TEST_F(Imu, TheFirstSampleAndOneAfterAGapAreDecodedAsTheSpecSays) {
  ImuRaw raw;
  raw.q = {1200, 32700, -900};  // |q_xyz| ~ 1: q_w small, the track's case
  raw.w = {0, 5000, 0};         // a large rate the track would integrate
  ASSERT_EQ(sample(1, 1, kValid, raw), SensorEvent::accepted);
  Eigen::Quaterniond spec;
  ASSERT_TRUE(decode_quaternion(raw.q, cfg.scales.orientation_per_count, spec));
  EXPECT_LT(imu.reading().orientation.angularDistance(spec), 1e-12);
  ASSERT_EQ(sample(2, 2, kValid, raw), SensorEvent::accepted);
  EXPECT_GT(imu.reading().orientation.angularDistance(spec), 1e-4);  // tracked: the rate moved q_w
  // Silent for longer than stale_ticks: the next sample starts afresh.
  ASSERT_EQ(sample(3, 2 + cfg.stale_ticks + 5, kValid, raw), SensorEvent::accepted);
  EXPECT_LT(imu.reading().orientation.angularDistance(spec), 1e-12);
}

TEST(Ft, DecodesHandBuiltFramesWithCountsPerUnit) {
  FtConfig cfg;
  cfg.enabled = true;
  FtAssembler ft;
  ft.configure(cfg, 0);
  // F = (640, -160, 6400) counts / 64 = (10, -2.5, 100) N; T = (1500, 0, -1) / 1000 = (1.5, 0, -0.001) N m.
  EXPECT_EQ(ft.push(frame_of(0x6B0, {0x80, 0x02, 0x60, 0xFF, 0x00, 0x19, 0xFF, 0x01}), 1), SensorEvent::stored);
  EXPECT_EQ(ft.push(frame_of(0x6B1, {0xDC, 0x05, 0x00, 0x00, 0xFF, 0xFF, 0xFF, 0x01}), 1), SensorEvent::accepted);
  ft.update(1);
  ASSERT_TRUE(ft.usable());
  EXPECT_EQ(ft.reading().force_n, Eigen::Vector3d(10.0, -2.5, 100.0));
  EXPECT_EQ(ft.reading().torque_nm, Eigen::Vector3d(1.5, 0.0, -0.001));
  // The encoder gives the same bytes.
  std::array<Frame, kFtFrames> f;
  ASSERT_TRUE(encode_ft_sample(cfg, Eigen::Vector3d(10.0, -2.5, 100.0), Eigen::Vector3d(1.5, 0.0, -0.001), 0xFF, kValid, f));
  EXPECT_EQ(bytes(f[0]), (std::vector<int>{0x80, 0x02, 0x60, 0xFF, 0x00, 0x19, 0xFF, 0x01}));
  EXPECT_EQ(bytes(f[1]), (std::vector<int>{0xDC, 0x05, 0x00, 0x00, 0xFF, 0xFF, 0xFF, 0x01}));
  // 600 N is beyond +-512 N: saturated, clipping bit; bias not taken (bit 1) is passed through.
  ASSERT_TRUE(encode_ft_sample(cfg, Eigen::Vector3d(600.0, 0, 0), Eigen::Vector3d::Zero(), 0, kValid | 0x02, f));
  EXPECT_EQ(bytes(f[0]), (std::vector<int>{0xFF, 0x7F, 0x00, 0x00, 0x00, 0x00, 0x00, 0x07}));
  // Counter 0xFF -> 0x00 wraps; clipped sample used; bias-not-taken reported.
  EXPECT_EQ(ft.push(f[0], 2), SensorEvent::stored);
  EXPECT_EQ(ft.push(f[1], 2), SensorEvent::accepted);
  EXPECT_TRUE(ft.diagnostics().not_ready);
  EXPECT_EQ(ft.diagnostics().clipped, 1u);
  ft.update(2);
  EXPECT_EQ(ft.reading().force_n.x(), 32767.0 / 64.0);
}

// The F/T's torque range is 32.7 N m (32700 counts at CPT 1000, CAN.md 6.2): a torque held
// there with the clipping bit makes a streak (a fault at clip_streak samples) though no field
// reaches the int16 rail.
TEST(Ft, AClippingStreakAtTheTorqueRangeIsAFault) {
  FtConfig cfg;
  cfg.enabled = true;
  cfg.clip_streak = 4;
  FtAssembler ft;
  ft.configure(cfg, 0);
  for (int k = 1; k <= 4; ++k) {
    const auto c = static_cast<std::uint8_t>(k);
    EXPECT_EQ(ft.push(frame_of(0x6B0, {0x00, 0x00, 0x00, 0x00, 0x00, 0x00, c, 0x05}), k), SensorEvent::stored);
    // T_x = 32700 counts = 0x7FBC.
    EXPECT_EQ(ft.push(frame_of(0x6B1, {0xBC, 0x7F, 0x00, 0x00, 0x00, 0x00, c, 0x05}), k), SensorEvent::accepted);
    EXPECT_EQ(ft.diagnostics().clip_streak_fault, k == 4) << "sample " << k;
  }
  EXPECT_EQ(ft.diagnostics().clipped, 4u);
}

TEST(Ft, OffsetExpressesTheWrenchInTheEndEffectorFrame) {
  FtConfig cfg;
  cfg.enabled = true;
  cfg.has_offset = true;
  cfg.offset.xyz_m = {0.0, 0.0, 0.1};        // sensor 10 cm along EE z
  cfg.offset.rpy_rad = {0.0, 0.0, M_PI / 2};  // turned 90 deg about z
  FtAssembler ft;
  ft.configure(cfg, 0);
  // Sensor reads F_s = (10, 0, 0) N, T_s = 0. In the EE frame: F = Rz(90) F_s = (0, 10, 0);
  // about the EE origin: T = p x F = (0, 0, 0.1) x (0, 10, 0) = (-1, 0, 0) N m.
  std::array<Frame, kFtFrames> f;
  ASSERT_TRUE(encode_ft_sample(cfg, Eigen::Vector3d(10, 0, 0), Eigen::Vector3d::Zero(), 1, kValid, f));
  ft.push(f[0], 1);
  ft.push(f[1], 1);
  ft.update(1);
  ASSERT_TRUE(ft.usable());
  EXPECT_NEAR((ft.reading().force_n - Eigen::Vector3d(0, 10, 0)).norm(), 0.0, 1e-12);
  EXPECT_NEAR((ft.reading().torque_nm - Eigen::Vector3d(-1, 0, 0)).norm(), 0.0, 1e-12);
  // And back (the emulator's direction).
  Eigen::Vector3d fs, ts;
  wrench_ee_to_sensor(wrench_transform(cfg.offset), ft.reading().force_n, ft.reading().torque_nm, fs, ts);
  EXPECT_NEAR((fs - Eigen::Vector3d(10, 0, 0)).norm(), 0.0, 1e-12);
  EXPECT_NEAR(ts.norm(), 0.0, 1e-12);
}

TEST(Ft, FrameOfAnotherIdOrWrongLengthIsRejected) {
  FtConfig cfg;
  cfg.enabled = true;
  FtAssembler ft;
  ft.configure(cfg, 0);
  EXPECT_EQ(ft.frame_index(0x6B2), -1);
  EXPECT_EQ(ft.push(frame_of(0x6B2, {0, 0, 0, 0, 0, 0, 0, 1}), 1), SensorEvent::wrong_dlc);
  EXPECT_EQ(ft.push(frame_of(0x6B0, {0, 0, 0, 0, 0, 0, 0, 1, 0}), 1), SensorEvent::wrong_dlc);
  EXPECT_EQ(ft.diagnostics().wrong_dlc, 2u);
}

}  // namespace
}  // namespace springbok::can
