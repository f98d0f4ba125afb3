// HIL for the robot this build is for, from its robot folder alone: the deployed binary
// (`springbok`) with the folder's shipped springbok.yaml, moved onto vcan and slowed for the VM,
// against the drive emulator's Bullet robot (lockstep, every drive in the config's protocol, the
// IMU and wrist F/T on their bus with the MEMS preset's errors): it stands the robot up from lying
// on its folded legs and holds it, renders a push at the hand as the folder's template, then
// trots. The HyQ + Gen3 build runs its own suite instead (test_bring_up.cpp, test_bus_faults.cpp,
// test_deployed.cpp: tests/hil/CMakeLists.txt).
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <chrono>

#include "springbok/app/mode_controller.hpp"
#include "springbok/drive_emulator/drives.hpp"

#include "deployed_rig.hpp"
#include "hil_rig.hpp"

namespace springbok::can {
namespace {

using namespace hil;

// The shipped config as the HIL runs it: on vcan, no real-time scheduling (the emulator shares
// the VM's CPUs), the VM's stalls tolerated (as tests/hil/config's), the operator socket, the
// log and the recorder in /tmp, no telemetry; the whole-body controller compensates the
// emulator's joint friction (below). Everything else (gains, template, stand-up, layout, protocol,
// sensors, start pose) is the robot folder's.
std::string hil_config(const std::string& socket_path, const std::string& recorder_dir) {
  YAML::Node c = YAML::LoadFile(SPRINGBOK_APP_CONFIG);
  c["loop"]["warmup_ticks"] = 0;
  YAML::Node rt;
  rt["enabled"] = false;
  rt["require"] = false;
  rt["priority"] = 80;
  rt["cpu"] = -1;
  rt["lock_memory"] = false;
  rt["prefault_heap_mib"] = 0;
  rt["cpu_dma_latency"] = false;
  c["rt"] = rt;
  c["safety"]["overrun_streak"] = 20;
  c["safety"]["overrun_rate_per_s"] = 200;
  c["safety"]["hal_watchdog_ticks"] = 25;
  c["operator"]["socket"] = socket_path;
  c["log"]["path"] = "-";
  c["recorder"]["dir"] = recorder_dir;
  c["recorder"]["seconds"] = 10;
  c["telemetry"]["enabled"] = false;
  YAML::Node can = c["can"];
  can["interface_prefix"] = "vcan";
  if (can["extra_buses"]) {
    for (std::size_t i = 0; i < can["extra_buses"].size(); ++i) {
      const std::string iface = can["extra_buses"][i]["interface"].as<std::string>();
      can["extra_buses"][i]["interface"] = "vcan" + iface.substr(iface.find_first_of("0123456789"));
    }
  }
  if (can["sensors"]) {
    for (const char* sensor : {"imu", "wrist_ft"}) {
      if (can["sensors"][sensor]) can["sensors"][sensor]["stale_ticks"] = 10;
    }
  }
  // The emulated gearboxes' viscous friction b, which the emulator renders up to what one 1 ms step
  // can (kd <= I / dt, bullet_motion.cpp), compensated at 80 % (c < b keeps the joint passive
  // whatever the CAN delay), as tests/hil/config/wbc_mit8.yaml does for HyQ + Gen3. On a robot
  // this is a measured value per joint.
  YAML::Node viscous;
  const double b = emu::JointModel{}.viscous_nms_per_rad;
  for (int j = 0; j < kNj; ++j) viscous.push_back(0.8 * std::min(b, joint_own_axis_inertia_kgm2(j) / 0.001));
  viscous.SetStyle(YAML::EmitterStyle::Flow);
  c["control"]["wbc"]["joint_friction"]["viscous"] = viscous;
  can["timing"]["missed_replies_lost"] = 25;
  can["timing"]["rx_deadline_us"] = 15000;  // wall time; below the slowed tick (--time-scale 20: 20 ms)
  YAML::Emitter out;
  out << c;
  return out.c_str();
}

// Lying on its folded legs, the robot is stood up by the operator's `start`; it holds the stand
// posture at the height the posture gives on flat ground. Then the wrist F/T is tared, the
// control mode entered, and a 30 N step along x at the hand is rendered as the robot folder's
// template (NRMSE hand <= 5 %, base <= 10 %, the end displacements within 2 % of F/K: the bounds
// of HyQ + Gen3's deployed case); then the robot trots in place on the operator's command.
TEST(Hil, DeployedBinaryStandsItsRobotUpRendersAPushThenTrots) {
  REQUIRE_VCAN(8);
  const int time_scale = hil_time_scale(20);
  ASSERT_GE(time_scale, 1);
  const std::string tag = std::to_string(::getpid());
  const std::string config = "/tmp/springbok_hil_any_" + tag + ".yaml";
  const std::string socket_path = "/tmp/springbok_hil_any_" + tag + ".sock";
  const std::string truth = "/tmp/springbok_hil_any_truth_" + tag + ".txt";
  std::ofstream(config) << hil_config(socket_path, "/tmp/springbok_hil_any_recorder_" + tag);
  const app::ConfigResult loaded = app::load_config_file(config);
  ASSERT_TRUE(loaded.ok) << (loaded.errors.empty() ? "" : loaded.errors.front());
  ASSERT_EQ(loaded.config.control_mode, app::ControlModeKind::wbc);
  const CanConfig can_config = [&] {
    const ConfigResult r = load_can_config_file(config);
    EXPECT_TRUE(r.ok) << r.error;
    return r.config;
  }();
  ASSERT_TRUE(can_config.start_pose.given) << "the robot folder's config names the lying pose";

  // The stand-up's length from lying (app::stand_up_ramp_s), then the hold, the tare and the push.
  const VecNj lying_rad = Eigen::Map<const VecNj>(can_config.start_pose.q_rad.data());
  const double stand_up_s =
      app::stand_up_ramp_s(loaded.config.stand_posture_rad - lying_rad, loaded.config.stand_up_duration_s);
  constexpr double kSettle_s = 0.1, kHold_s = 2.0, kForce_n = 30.0, kPush_s = 3.5, kTrot_s = 4.5;
  const double push_start_s = std::ceil(stand_up_s + kHold_s + 1.5);
  const double push_end_s = push_start_s + kPush_s, trot_at_s = push_end_s + 0.5, trot_until_s = trot_at_s + kTrot_s;
  Emulator emu(config, "",
               {"--motion", "bullet", "--truth-log", truth, "--truth-every", "1", "--settle-s", std::to_string(kSettle_s),
                "--sensors-preset", "mems", "--hand-force-n", std::to_string(kForce_n), "--hand-force-axis", "x",
                "--hand-force-start-s", std::to_string(push_start_s), "--hand-force-duration-s", std::to_string(kPush_s)});
  ASSERT_TRUE(emu.ready());
  ::unlink(socket_path.c_str());
  const auto wall_start = std::chrono::steady_clock::now();
  Firmware fw(config, time_scale);
  const double wall_per_sim_s = time_scale * 1.3 + 5.0;  // generous: the wall time a simulated second may take
  const StandUp up = stand_up(fw, socket_path, truth, (stand_up_s + 1.0) * wall_per_sim_s);
  ASSERT_TRUE(up.ok()) << up.started << "\n" << up.status << "\n" << fw.stop() << emu.stop();
  const double lying_z_m = up.first_z_m;
  const double t_stand_s = truth_time(truth);
  ASSERT_TRUE(wait_for(fw, (kHold_s + 1.0) * wall_per_sim_s, [&] { return truth_time(truth) >= t_stand_s + kHold_s; }));
  std::string status = operator_line(socket_path, "status");
  EXPECT_NE(status.find("mode=stand faults=none"), std::string::npos) << status;

  // Tared in the stand; the control mode before the push.
  std::string reply;
  ASSERT_TRUE(wait_for(fw, 1.0 * wall_per_sim_s, [&] {
    return (reply = operator_line(socket_path, "controller")).find("tare=done") != std::string::npos;
  })) << reply;
  reply = operator_line(socket_path, "mode control");
  ASSERT_EQ(reply.rfind("ok mode control", 0), 0u) << reply;
  const double t_control_s = truth_time(truth);
  ASSERT_LT(t_control_s, push_start_s - 0.5) << "the control mode must settle before the push";
  ASSERT_TRUE(wait_for(fw, (trot_at_s - t_control_s + 1.0) * wall_per_sim_s, [&] { return truth_time(truth) >= trot_at_s; }));
  status = operator_line(socket_path, "status");
  EXPECT_NE(status.find("mode=control faults=none"), std::string::npos) << status;
  const std::string trot = operator_line(socket_path, "gait trot step_frequency=1.4 duty_factor=0.65");
  EXPECT_EQ(trot.rfind("ok gait trot (mode=control faults=none)", 0), 0u) << trot;
  const double t_trot_s = truth_time(truth);
  ASSERT_TRUE(wait_for(fw, (trot_until_s - t_trot_s + 1.0) * wall_per_sim_s, [&] { return truth_time(truth) >= trot_until_s; }));
  status = operator_line(socket_path, "status");
  EXPECT_NE(status.find("mode=control faults=none"), std::string::npos) << status;
  const std::string fw_out = fw.stop();
  const double wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - wall_start).count();
  EXPECT_TRUE(WIFEXITED(fw.exit_status()) && WEXITSTATUS(fw.exit_status()) == 0) << fw_out;
  const std::string summary = emu.stop();
  const std::vector<TruthSample> samples = read_truth(truth);
  ::unlink(truth.c_str());
  ::unlink(config.c_str());

  // The stand. The oracle: the trunk height at which the stand posture puts the feet on the flat ground.
  const Standing st = standing(samples, t_stand_s, t_stand_s + kHold_s, t_stand_s + 1.0);
  const double z_stand_m = standing_height_m(loaded.config.stand_posture_rad);
  // The push against the template.
  const test::PushScore push = score_push(samples, test::template_axis_x(loaded.config.control.wbc.template_params),
                                          push_start_s, push_end_s);
  // The trot.
  const Standing trotting = standing(samples, t_trot_s, trot_until_s, t_trot_s);
  std::printf("HIL %s (time scale %d, wall %.0f s): lying %.4f m; stand-up %.2f s; standing %.2f .. %.2f s: trunk z "
              "%.4f .. %.4f m (last 1 s %.4f .. %.4f; the stand posture on flat ground %.4f m), max tilt %.4f rad; "
              "control from %.3f s; %.0f N push %.1f .. %.1f s: NRMSE base %.2f %% hand %.2f %%, end displacement base "
              "%.4f m (F/K %.4f) hand %.4f m (%.4f); trot %.2f .. %.2f s: lifted %d%d%d%d, trunk z %.3f .. %.3f m, max "
              "tilt %.3f rad\n",
              std::string(robot::kRobotName).c_str(), time_scale, wall_s, lying_z_m, stand_up_s, t_stand_s,
              t_stand_s + kHold_s, st.z_min, st.z_max, st.z_min_settled, st.z_max_settled, z_stand_m, st.tilt_max,
              t_control_s, kForce_n, push_start_s, push_end_s, 100 * push.nrmse_base(), 100 * push.nrmse_hand(),
              push.end_base_m(), push.static_base_m(kForce_n), push.end_hand_m(), push.static_hand_m(kForce_n), t_trot_s,
              trot_until_s, trotting.lifted[0], trotting.lifted[1], trotting.lifted[2], trotting.lifted[3],
              trotting.z_min, trotting.z_max, trotting.tilt_max);
  EXPECT_GE(st.samples, 1500) << "trace samples while standing";
  EXPECT_LT(lying_z_m, z_stand_m - 0.05) << "it stood up from lying";
  EXPECT_NEAR(st.z_min_settled, z_stand_m, 0.03);
  EXPECT_NEAR(st.z_max_settled, z_stand_m, 0.03);
  EXPECT_LT(st.z_max_settled - st.z_min_settled, 0.005) << "it holds still";
  EXPECT_LT(st.tilt_max, 0.05);
  EXPECT_EQ(st.non_foot, 0) << "only the feet touch the ground";

  ASSERT_GT(push.samples(), 3000);
  ASSERT_GT(push.end_samples(), 400);
  EXPECT_LE(push.nrmse_base(), 0.10);
  EXPECT_LE(push.nrmse_hand(), 0.05);
  EXPECT_NEAR(push.end_base_m(), push.static_base_m(kForce_n), 0.02 * push.static_base_m(kForce_n));
  EXPECT_NEAR(push.end_hand_m(), push.static_hand_m(kForce_n), 0.02 * push.static_hand_m(kForce_n));

  for (int f = 0; f < kFeet; ++f) EXPECT_TRUE(trotting.lifted[static_cast<std::size_t>(f)]) << "foot " << f;
  EXPECT_EQ(trotting.non_foot, 0) << "only the feet touch the ground";
  EXPECT_GT(trotting.z_min, z_stand_m - 0.1);
  EXPECT_LT(trotting.tilt_max, 0.3);
  EXPECT_NE(summary.find("forced_steps 0\n"), std::string::npos) << "lockstep: every step had every drive's command\n"
                                                                 << summary;
}

}  // namespace
}  // namespace springbok::can
