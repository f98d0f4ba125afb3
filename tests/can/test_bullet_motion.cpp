// The drive emulator's Bullet motion (lockstep with the host's ticks), in process:
// 19 MIT drives on sim_hal's robot, driven through the real frames by a host that
// encodes commands and decodes replies with the codecs of hal/can.
#include <gtest/gtest.h>

#include <cmath>
#include <memory>
#include <numbers>
#include <vector>

#include "springbok/can/config.hpp"
#include "springbok/can/mit.hpp"
#include "springbok/can/sensors.hpp"
#include "springbok/drive_emulator/bullet_motion.hpp"
#include "springbok/drive_emulator/sensors.hpp"

namespace springbok::emu {
namespace {

using can::Frame;

// The decoded IMU quaternion against a true one. The vector part is quantized to 2^-15
// (half an LSB per field); q_w is rebuilt as sqrt(1 - |q_xyz|^2), which near q_w = 0 (the
// trunk_imu mounting is upside down: roll pi) turns the quantization of |q_xyz|^2 (at most
// 2 sqrt(3) 2^-16) into |dq_w| <= sqrt(2 sqrt(3) 2^-16 + 3 2^-32): CAN.md 6.1's own limit.
void expect_quaternion_near(const Eigen::Quaterniond& decoded, const Eigen::Quaterniond& truth, int k) {
  const Eigen::Vector3d v = truth.normalized().vec();
  const double half_lsb = 1.0 / 65536.0;
  const double vec_err = std::min((decoded.vec() - v).norm(), (decoded.vec() + v).norm());
  EXPECT_LE(vec_err, std::sqrt(3.0) * half_lsb + 1e-9) << k;
  const double dw_max = std::sqrt(2.0 * std::sqrt(3.0) * half_lsb + 3.0 * half_lsb * half_lsb);
  EXPECT_LE(std::abs(decoded.w() - std::abs(truth.normalized().w())), dw_max + 1e-9) << k;
  EXPECT_LE(decoded.angularDistance(truth), 2.0 * std::hypot(dw_max, std::sqrt(3.0) * half_lsb) + 1e-9) << k;
}

BulletOptions settle_half_second() {
  BulletOptions o;
  o.settle_s = 0.5;
  return o;
}

struct Rig {
  BulletMotion world;  // lies unpowered 0.5 s first
  std::vector<std::unique_ptr<MitDrive>> drives;
  std::vector<Frame> out;
  explicit Rig(const BulletOptions& options = settle_half_second()) : world(nullptr, 1, options) {
    for (int j = 0; j < kNj; ++j) {
      can::DriveConfig cfg = can::default_drive(j, can::Protocol::mit);
      cfg.mit_ranges.kp_max = 2000.0;
      cfg.mit_ranges.kd_max = 50.0;
      drives.push_back(std::make_unique<MitDrive>(cfg, false, make_joint_model(j, 0.0), std::vector<Fault>{}, 0));
      drives.back()->attach(&world);
    }
  }
  void send_all(const can::mit::Command* per_joint, bool special_enter = false) {
    out.clear();
    for (int j = 0; j < kNj; ++j) {
      Frame f;
      const auto id = static_cast<std::uint8_t>(j + 1);
      if (special_enter) {
        can::mit::encode_special(id, can::mit::Special::enter_motor_mode, f);
      } else {
        EXPECT_EQ(can::mit::encode_command(id, per_joint[j], drives[static_cast<std::size_t>(j)]->config().mit_ranges, f),
                  can::FrameStatus::ok);
      }
      drives[static_cast<std::size_t>(j)]->on_frame(f, 0, out);
    }
  }
  // Decoded replies of the last send, by joint.
  std::vector<can::mit::Reply> replies() const {
    std::vector<can::mit::Reply> r(kNj);
    for (const Frame& f : out) {
      can::mit::Reply rep;
      const int j = f.data[0] - 1;
      EXPECT_EQ(can::mit::decode_reply(f, drives[static_cast<std::size_t>(j)]->config().mit_ranges, rep), can::FrameStatus::ok);
      r[static_cast<std::size_t>(j)] = rep;
    }
    return r;
  }
};

TEST(BulletMotion, StepsOncePerTickAndRepliesWithTheStateBeforeTheStep) {
  Rig rig;
  can::mit::Command zero[kNj]{};
  rig.send_all(zero, true);  // enter motor mode: not a cyclic command
  EXPECT_EQ(rig.world.truth().steps, 0u);
  for (int k = 1; k <= 20; ++k) {
    std::vector<double> before(kNj);
    for (int j = 0; j < kNj; ++j) before[static_cast<std::size_t>(j)] = rig.world.state(j).q_rad;
    rig.send_all(zero);
    EXPECT_EQ(rig.world.truth().steps, static_cast<std::uint64_t>(k));
    const std::vector<can::mit::Reply> r = rig.replies();
    ASSERT_EQ(rig.out.size(), static_cast<std::size_t>(kNj));
    const double lsb = 25.0 / 65535.0;
    for (int j = 0; j < kNj; ++j) EXPECT_NEAR(r[static_cast<std::size_t>(j)].p_rad, before[static_cast<std::size_t>(j)], lsb) << j;
  }
  EXPECT_EQ(rig.world.truth().forced_steps, 0u);
  EXPECT_NEAR(rig.world.truth().time_s, 0.020, 1e-12);
  // A drive commanded twice before the others (frames lost) steps the world first.
  Frame f;
  can::mit::encode_command(1, can::mit::Command{}, rig.drives[0]->config().mit_ranges, f);
  rig.drives[0]->on_frame(f, 0, rig.out);
  rig.drives[0]->on_frame(f, 0, rig.out);
  EXPECT_EQ(rig.world.truth().steps, 21u);
  EXPECT_EQ(rig.world.truth().forced_steps, 1u);
}

TEST(BulletMotion, JointPdThroughTheFramesStandsTheRobotUp) {
  Rig rig;
  can::mit::Command cmd[kNj]{};
  rig.send_all(cmd, true);
  for (int k = 0; k < 300; ++k) rig.send_all(cmd);  // limp: settles from the crouch
  const double lying_z = rig.world.truth().trunk_z_m;
  std::vector<can::mit::Reply> r = rig.replies();
  const double stand[3] = {0.0, 0.7, -1.4};
  std::vector<double> start(kNj);
  for (int j = 0; j < kNj; ++j) start[static_cast<std::size_t>(j)] = r[static_cast<std::size_t>(j)].p_rad;
  double z_min = 1e9, z_max = -1e9;
  for (int k = 0; k < 3000; ++k) {
    const double s = std::min(1.0, k / 1500.0), blend = s * s * (3 - 2 * s);
    for (int j = 0; j < kNj; ++j) {
      const double target = j < 12 ? (j / 3 < 2 ? 1.0 : -1.0) * stand[j % 3] : 0.0;
      cmd[j] = can::mit::Command{start[static_cast<std::size_t>(j)] + blend * (target - start[static_cast<std::size_t>(j)]),
                                 0.0, j < 12 ? 1000.0 : 40.0, j < 12 ? 20.0 : 1.0, 0.0};
    }
    rig.send_all(cmd);
    if (k >= 2000) {
      z_min = std::min(z_min, rig.world.truth().trunk_z_m);
      z_max = std::max(z_max, rig.world.truth().trunk_z_m);
    }
  }
  std::printf("lying trunk z %.3f m; standing %.4f .. %.4f m, tilt %.4f rad\n", lying_z, z_min, z_max,
              rig.world.truth().trunk_tilt_rad);
  EXPECT_LT(lying_z, z_min - 0.2);  // it stood up from lying
  EXPECT_GT(z_min, 0.5);
  EXPECT_LT(z_max - z_min, 0.01);
  EXPECT_FALSE(rig.world.truth().non_foot_ground_contact);
  EXPECT_EQ(rig.world.truth().forced_steps, 0u);
}

// CAN.md 6.5: the emulator publishes the IMU and the F/T from the world, one sample per
// step; the host's assemblers decode them back to the world's values. Oracles: the
// trunk's ground-truth orientation through the trunk_imu mounting (URDF), and the force
// scripted on the hand (20 N along world -z from 0.1 s), seen through the EE orientation.
TEST(BulletMotion, SensorsPublishedFromTheWorldDecodeBackToItsValues) {
  BulletOptions o = settle_half_second();
  o.hand_force = true;
  o.hand.force_n = 20.0;
  o.hand.axis_world = -Eigen::Vector3d::UnitZ();
  o.hand.start_s = 0.1;
  Rig rig(o);
  can::SensorsConfig cfg;
  cfg.imu.enabled = cfg.wrist_ft.enabled = true;
  SensorEmulator sensors(cfg, {});
  can::ImuAssembler imu;
  can::FtAssembler ft;
  imu.configure(cfg.imu, 0);
  ft.configure(cfg.wrist_ft, 0);
  hal::Imu world_imu;
  hal::Wrench world_wrist;
  std::uint64_t tick = 0;
  int checked = 0, pushed = 0;
  double worst_angle_rad = 0.0;
  rig.world.set_step_callback([&](const hal::Imu& i, const hal::Wrench& w) {
    world_imu = i;
    world_wrist = w;
    std::vector<Frame> imu_out, ft_out;
    sensors.publish(i, w, imu_out, ft_out);
    ++tick;
    for (const Frame& f : imu_out) EXPECT_NE(imu.push(f, tick), can::SensorEvent::late_frame);
    for (const Frame& f : ft_out) EXPECT_NE(ft.push(f, tick), can::SensorEvent::late_frame);
    imu.update(tick);
    ft.update(tick);
  });
  const Eigen::Quaterniond trunk_from_imu = [] {
    const auto& p = robot::kFrames[kImuFrame].placement;
    Eigen::Matrix3d r;
    for (int k = 0; k < 9; ++k) r(k / 3, k % 3) = p.rotation[static_cast<std::size_t>(k)];
    return Eigen::Quaterniond(r);
  }();
  can::mit::Command zero[kNj]{};
  rig.send_all(zero, true);
  for (int k = 1; k <= 200; ++k) {
    rig.send_all(zero);  // limp: the robot sags, the trunk moves, the hand is pushed from 0.1 s
    ASSERT_EQ(tick, static_cast<std::uint64_t>(k));
    ASSERT_TRUE(imu.usable() && ft.usable()) << k;
    const can::ImuReading r = imu.reading();
    // Against the world's IMU (what sim_hal measured): quantization only.
    expect_quaternion_near(r.orientation, world_imu.orientation, k);
    EXPECT_LE((r.angular_rate_rad_s - world_imu.angular_rate_rad_s).cwiseAbs().maxCoeff(), 0.5 / 1024.0 + 1e-12) << k;
    EXPECT_LE((r.linear_accel_m_s2 - world_imu.linear_accel_m_s2).cwiseAbs().maxCoeff(), 0.5 / 512.0 + 1e-12) << k;
    // Against the ground truth: the trunk's orientation through the IMU mounting.
    const Eigen::Quaterniond expected = rig.world.truth().trunk_orientation * trunk_from_imu;
    expect_quaternion_near(r.orientation, expected, k);
    worst_angle_rad = std::max(worst_angle_rad, r.orientation.angularDistance(expected));
    // The F/T: zero before 0.1 s, then the scripted 20 N along world -z at the EE origin (no torque).
    const Eigen::Vector3d f_world = rig.world.truth().ee_orientation * ft.reading().force_n;
    const Eigen::Vector3d f_expected = rig.world.truth().time_s >= 0.1 - 1e-9 ? Eigen::Vector3d(0, 0, -20.0)
                                                                              : Eigen::Vector3d::Zero();
    EXPECT_LT((f_world - f_expected).norm(), std::sqrt(3.0) * 0.5 / 64.0 + 1e-9) << k << " t " << rig.world.truth().time_s;
    EXPECT_LT(ft.reading().torque_nm.norm(), std::sqrt(3.0) * 0.5 / 1000.0 + 1e-9) << k;
    pushed += f_expected.norm() > 0.0 ? 1 : 0;
    ++checked;
  }
  EXPECT_EQ(checked, 200);
  EXPECT_GT(pushed, 90);  // the push was on for the last ~100 steps
  EXPECT_EQ(imu.diagnostics().samples_accepted, 200u);
  EXPECT_EQ(ft.diagnostics().samples_accepted, 200u);
  std::printf("IMU orientation through the frames vs ground truth: worst %.2e rad (q_w near 0: upside-down mounting)\n",
              worst_angle_rad);
}

// --sensors-preset mems: the IMU the emulator publishes is sim_hal's BMI088-class model (16-bit
// gyro on +-2000 deg/s, its accelerometer held at 800 Hz, a turn-on bias from the seed) and the
// wrist F/T the Mini45-class one (1/16 N steps, an offset); the same seed, the same samples.
TEST(BulletMotion, TheSensorsPresetShapesThePublishedSamples) {
  const auto run = [](SensorsPreset preset, std::uint64_t seed) {
    BulletOptions o;
    o.sensors_preset = preset;
    o.sensors_seed = seed;
    Rig rig(o);
    std::vector<hal::Imu> imu;
    std::vector<hal::Wrench> ft;
    rig.world.set_step_callback([&](const hal::Imu& i, const hal::Wrench& w) {
      imu.push_back(i);
      ft.push_back(w);
    });
    can::mit::Command zero[kNj]{};
    rig.send_all(zero, true);
    for (int k = 0; k < 100; ++k) rig.send_all(zero);
    return std::pair{imu, ft};
  };
  const auto [imu, ft] = run(SensorsPreset::mems, 4);
  const auto [ideal_imu, ideal_ft] = run(SensorsPreset::ideal, 4);
  ASSERT_EQ(imu.size(), 100u);
  ASSERT_EQ(ideal_imu.size(), 100u);
  const double gyro_lsb = std::numbers::pi / 180.0 / 16.384;
  int accel_repeats = 0;
  for (std::size_t k = 0; k < imu.size(); ++k) {
    for (int i = 0; i < 3; ++i) {
      const double counts = imu[k].angular_rate_rad_s[i] / gyro_lsb;
      EXPECT_NEAR(counts, std::round(counts), 1e-6) << k;
      EXPECT_NEAR(ft[k].force_n[i] * 16.0, std::round(ft[k].force_n[i] * 16.0), 1e-9) << k;
    }
    if (k > 0 && imu[k].linear_accel_m_s2 == imu[k - 1].linear_accel_m_s2) ++accel_repeats;
    EXPECT_FALSE(imu[k].clipping) << k;
  }
  EXPECT_GE(accel_repeats, 19);  // 800 Hz at 1 kHz: one tick in five holds
  EXPECT_GT((imu[50].angular_rate_rad_s - ideal_imu[50].angular_rate_rad_s).norm(), 1e-4);  // bias: ~6 mrad/s per axis
  EXPECT_GT((ft[50].force_n - ideal_ft[50].force_n).norm(), 0.1);  // the turn-on offset (1 N std)
  const auto [again, again_ft] = run(SensorsPreset::mems, 4);
  for (std::size_t k = 0; k < imu.size(); ++k) EXPECT_EQ(again[k].angular_rate_rad_s, imu[k].angular_rate_rad_s) << k;
}

// A known gyro turn-on bias (a HIL case's 20 mrad/s): on the exact IMU every published rate is
// the world's plus the offset, and the emulator's truth reports it as the bias.
TEST(BulletMotion, AGyroBiasOffsetAddsToEveryRateAndIsReported) {
  const Eigen::Vector3d offset(0.02, -0.01, 0.03);
  const auto run = [](const Eigen::Vector3d& gyro_offset, Eigen::Vector3d& reported) {
    BulletOptions o;
    o.gyro_bias_offset_rad_s = gyro_offset;
    Rig rig(o);
    std::vector<hal::Imu> imu;
    rig.world.set_step_callback([&](const hal::Imu& i, const hal::Wrench&) { imu.push_back(i); });
    can::mit::Command zero[kNj]{};
    rig.send_all(zero, true);
    for (int k = 0; k < 50; ++k) rig.send_all(zero);
    reported = rig.world.truth().imu_gyro_bias_rad_s;
    return imu;
  };
  Eigen::Vector3d reported, reported_exact;
  const std::vector<hal::Imu> biased = run(offset, reported), exact = run(Eigen::Vector3d::Zero(), reported_exact);
  ASSERT_EQ(biased.size(), 50u);
  ASSERT_EQ(exact.size(), 50u);
  for (std::size_t k = 0; k < biased.size(); ++k) {
    EXPECT_LT((biased[k].angular_rate_rad_s - exact[k].angular_rate_rad_s - offset).norm(), 1e-12) << k;
    EXPECT_EQ(biased[k].linear_accel_m_s2, exact[k].linear_accel_m_s2) << k;
  }
  EXPECT_EQ(reported, offset);
  EXPECT_EQ(reported_exact, Eigen::Vector3d::Zero());
}

}  // namespace
}  // namespace springbok::emu
