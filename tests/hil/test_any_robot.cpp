// HIL for the robot this build is for, from its robot folder alone: the deployed binary
// (`springbok`) with the folder's shipped springbok.yaml, moved onto vcan and slowed for the VM,
// stands the robot up from lying on its folded legs against the drive emulator's Bullet robot
// (lockstep, every drive in the config's protocol, the IMU and wrist F/T on their bus) and holds
// it. The HyQ + Gen3 build runs its own suite instead (test_bring_up.cpp, test_bus_faults.cpp,
// test_deployed.cpp: tests/hil/CMakeLists.txt).
#include <yaml-cpp/yaml.h>

#include "deployed_rig.hpp"
#include "hil_rig.hpp"

namespace springbok::can {
namespace {

using namespace hil;

// The shipped config as the HIL runs it: on vcan, no real-time scheduling (the emulator shares
// the VM's CPUs), the VM's stalls tolerated (as tests/hil/config's), the operator socket, the
// log and the recorder in /tmp, no telemetry. Everything else (gains, stand-up, layout,
// protocol, sensors, start pose) is the robot folder's.
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
  can["timing"]["missed_replies_lost"] = 25;
  can["timing"]["rx_deadline_us"] = 15000;  // wall time; below the slowed tick (--time-scale 20: 20 ms)
  YAML::Emitter out;
  out << c;
  return out.c_str();
}

TEST(Hil, DeployedBinaryStandsItsRobotUpFromLyingAndHoldsIt) {
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

  Emulator emu(config, "", {"--motion", "bullet", "--truth-log", truth, "--settle-s", "0.1"});
  ASSERT_TRUE(emu.ready());
  ::unlink(socket_path.c_str());
  Firmware fw(config, time_scale);
  const double wall_per_sim_s = time_scale * 1.3 + 5.0;  // generous: the wall time a simulated second may take
  const StandUp up = stand_up(fw, socket_path, truth, (loaded.config.stand_up_duration_s + 3.0) * wall_per_sim_s);
  ASSERT_TRUE(up.ok()) << up.started << "\n" << up.status << "\n" << fw.stop() << emu.stop();
  const double lying_z_m = up.first_z_m;
  const double t_stand_s = truth_time(truth);
  constexpr double kHold_s = 3.0;
  ASSERT_TRUE(wait_for(fw, (kHold_s + 1.0) * wall_per_sim_s, [&] { return truth_time(truth) >= t_stand_s + kHold_s; }));
  const std::string status = operator_line(socket_path, "status");
  EXPECT_NE(status.find("mode=stand faults=none"), std::string::npos) << status;
  const std::string fw_out = fw.stop();
  EXPECT_TRUE(WIFEXITED(fw.exit_status()) && WEXITSTATUS(fw.exit_status()) == 0) << fw_out;
  const std::string summary = emu.stop();
  const std::vector<TruthSample> samples = read_truth(truth);
  ::unlink(truth.c_str());
  ::unlink(config.c_str());

  const Standing st = standing(samples, t_stand_s, t_stand_s + kHold_s, t_stand_s + 1.0);
  // The oracle: the trunk height at which the stand posture puts the feet on the flat ground.
  const double z_stand_m = standing_height_m(loaded.config.stand_posture_rad);
  std::printf("HIL %s: lying %.4f m; standing %.2f .. %.2f s: trunk z %.4f .. %.4f m (last 2 s %.4f .. %.4f; the stand "
              "posture on flat ground %.4f m), max tilt %.4f rad\n",
              std::string(robot::kRobotName).c_str(), lying_z_m, t_stand_s, t_stand_s + kHold_s, st.z_min, st.z_max,
              st.z_min_settled, st.z_max_settled, z_stand_m, st.tilt_max);
  EXPECT_GE(st.samples, 200) << "trace samples while standing";
  EXPECT_LT(lying_z_m, z_stand_m - 0.05) << "it stood up from lying";
  EXPECT_NEAR(st.z_min_settled, z_stand_m, 0.03);
  EXPECT_NEAR(st.z_max_settled, z_stand_m, 0.03);
  EXPECT_LT(st.z_max_settled - st.z_min_settled, 0.005) << "it holds still";
  EXPECT_LT(st.tilt_max, 0.05);
  EXPECT_EQ(st.non_foot, 0) << "only the feet touch the ground";
  EXPECT_NE(summary.find("forced_steps 0\n"), std::string::npos) << "lockstep: every step had every drive's command\n"
                                                                 << summary;
}

}  // namespace
}  // namespace springbok::can
