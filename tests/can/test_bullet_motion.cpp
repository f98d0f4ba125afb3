// The drive emulator's Bullet motion (lockstep with the host's ticks), in process:
// 19 MIT drives on sim_hal's robot, driven through the real frames by a host that
// encodes commands and decodes replies with the codecs of hal/can.
#include <gtest/gtest.h>

#include <cmath>
#include <memory>
#include <vector>

#include "springbok/can/config.hpp"
#include "springbok/can/mit.hpp"
#include "springbok/drive_emulator/bullet_motion.hpp"

namespace springbok::emu {
namespace {

using can::Frame;

struct Rig {
  BulletMotion world{nullptr, 1, 0.5};  // lies unpowered 0.5 s first
  std::vector<std::unique_ptr<MitDrive>> drives;
  std::vector<Frame> out;
  Rig() {
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

}  // namespace
}  // namespace springbok::emu
