// One firmware from simulation to the robot: springbok-sim runs app::Firmware (supervisor,
// mode controller, control mode, loop) in lockstep with the Bullet robot, the scenario as its
// operator. Its firmware ticks are recorded (the measurements each read, the command each
// wrote) with the operator's requests; the recording is then replayed through a second
// app::Firmware, built from the same configuration as springbok-on-sim and springbok build
// theirs (run_firmware), over a HAL that plays the measurements back: every tick's command,
// every field, must be the tool's bit for bit, and the modes the same. Estimated base (no
// ground truth: the robot has none), a push at the hand, stand and trot.
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <unistd.h>

#include "scenario.hpp"
#include "sim_scenario_text.hpp"
#include "springbok/app/firmware.hpp"
#include "springbok/yaml/reader.hpp"
#include "wbc_adapter.hpp"

namespace {
using namespace springbok;

std::string scenario_yaml(bool trot) {
  std::string y =
      "name: one_controller\n" +
      test::wbc_scenario_head("2.0", "0.5", "{mass: 92, damping: 610, stiffness: 1000}", "{mass: 10, damping: 142, stiffness: 500}") +
      "    estimator: {filter: complementary, velocity_gain: 30, position_gain: 10}\n";
  if (trot) y += "    gait: {step_frequency: 1.4, duty_factor: 0.65, step_height: 0.08}\n";
  y += "external_wrenches:\n"
       "  - {frame: end_effector, axis: [1, 0, 0], profile: step, amplitude: 40, start_s: 0.8}\n";
  return y;
}

struct ToolRun {
  std::vector<simtool::WbcAdapter::FirmwareTick> ticks;
  std::vector<simtool::WbcAdapter::Posted> posted;
  app::AppConfig config;
  Eigen::Vector2d start_xy;
  std::uint64_t stance_changes = 0;
};

// springbok-sim's loop: the adapter's tick, then the physics step.
ToolRun run_tool(const std::filesystem::path& file) {
  simtool::Scenario s = simtool::load_scenario(file.string());
  simtool::apply_feet_clearance(s);
  sim::BulletRobot robot(s.sim);
  EXPECT_TRUE(robot.configure().ok);
  for (const auto& w : s.wrenches) robot.add_external_wrench(w.wrench);
  EXPECT_TRUE(robot.activate().ok);
  ToolRun run;
  run.start_xy = robot.ground_truth().q.head<2>();
  yaml::Errors errors;
  simtool::WbcAdapter adapter(s, yaml::Field(s.controller_params, "controller.params", errors), robot);
  EXPECT_TRUE(errors.empty()) << errors.joined();
  adapter.record(&run.ticks);
  const auto ticks = std::llround(s.duration_s / s.sim.step_s);
  std::string row;
  for (std::int64_t k = 0; k < ticks; ++k) {
    EXPECT_TRUE(adapter.tick(robot, k));
    robot.step();
    row.clear();
    adapter.after_step(robot.ground_truth(), row);
  }
  run.posted = adapter.posted();
  run.config = adapter.config();
  run.stance_changes = adapter.controller().stance_changes();
  return run;
}

// A HAL that plays recorded measurements back, one per read, and keeps every command written.
class PlaybackHardware final : public hal::Hardware {
 public:
  explicit PlaybackHardware(const std::vector<simtool::WbcAdapter::FirmwareTick>& ticks) : ticks_(ticks) {}
  std::string_view name() const noexcept override { return "playback"; }
  hal::LifecycleResult configure() override { return hal::LifecycleResult::success(); }
  hal::LifecycleResult activate() override { return hal::LifecycleResult::success(); }
  hal::IoStatus read(hal::Measurements& out) noexcept override {
    if (next_ >= ticks_.size()) return hal::IoStatus::error;
    out = ticks_[next_++].meas;
    return hal::IoStatus::ok;
  }
  hal::IoStatus write(const hal::JointCommands& cmd) noexcept override {
    written.push_back(cmd);
    return hal::IoStatus::ok;
  }
  void deactivate() noexcept override {}

  std::vector<hal::JointCommands> written;

 private:
  const std::vector<simtool::WbcAdapter::FirmwareTick>& ticks_;
  std::size_t next_ = 0;
};

void expect_same_command(const hal::JointCommands& a, const hal::JointCommands& b, std::size_t tick) {
  ASSERT_EQ(a.mode, b.mode) << "tick " << tick;
  ASSERT_EQ(a.sequence, b.sequence) << "tick " << tick;
  for (int j = 0; j < kNj; ++j) {
    ASSERT_EQ(a.q_des_rad[j], b.q_des_rad[j]) << "q_des, joint " << j << ", tick " << tick;
    ASSERT_EQ(a.qd_des_rad_s[j], b.qd_des_rad_s[j]) << "qd_des, joint " << j << ", tick " << tick;
    ASSERT_EQ(a.kp_nm_per_rad[j], b.kp_nm_per_rad[j]) << "kp, joint " << j << ", tick " << tick;
    ASSERT_EQ(a.kd_nms_per_rad[j], b.kd_nms_per_rad[j]) << "kd, joint " << j << ", tick " << tick;
    ASSERT_EQ(a.tau_ff_nm[j], b.tau_ff_nm[j]) << "tau_ff, joint " << j << ", tick " << tick;
  }
}

void expect_firmware_replays_the_tool(bool trot) {
  const std::filesystem::path dir =
      std::filesystem::temp_directory_path() / ("springbok_one_controller_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  const std::filesystem::path file = dir / (trot ? "trot.yaml" : "stand.yaml");
  std::ofstream(file) << scenario_yaml(trot);
  const ToolRun tool = run_tool(file);
  std::filesystem::remove_all(dir);
  ASSERT_EQ(tool.config.control_mode, app::ControlModeKind::wbc);
  ASSERT_EQ(tool.config.control.gait.kind, trot ? control::GaitKind::trot : control::GaitKind::stand);

  PlaybackHardware playback(tool.ticks);
  app::Firmware firmware(playback, tool.config, nullptr);
  firmware.control().controller().set_start_position_xy(tool.start_xy);
  std::size_t next_request = 0;
  std::uint64_t control_ticks = 0;
  for (std::size_t k = 0; k < tool.ticks.size(); ++k) {
    while (next_request < tool.posted.size() && tool.posted[next_request].tick == k) {
      ASSERT_TRUE(firmware.mailbox().requests.push(tool.posted[next_request++].request));
    }
    rt::TickInfo info;
    info.index = k;
    info.elapsed_ns = 1'000'000;
    info.scheduled_ns = static_cast<std::int64_t>(k) * info.elapsed_ns;
    info.wake_ns = info.scheduled_ns;
    firmware.loop().tick(info);
    ASSERT_EQ(firmware.loop().computed_mode(), tool.ticks[k].mode) << "tick " << k;
    ASSERT_EQ(playback.written.size(), k + 1);
    expect_same_command(playback.written[k], tool.ticks[k].cmd, k);
    if (tool.ticks[k].mode == safety::Mode::control) ++control_ticks;
    app::OperatorReply reply;
    while (firmware.mailbox().replies.pop(reply)) EXPECT_TRUE(reply.accepted) << "tick " << k;
  }
  EXPECT_EQ(next_request, tool.posted.size());
  EXPECT_GE(tool.posted.size(), 2u);  // start, mode control
  EXPECT_EQ(control_ticks, 1500u);    // 1.5 s of control, the push from 0.8 s included
  EXPECT_EQ(firmware.supervisor().mode(), safety::Mode::control);
  EXPECT_EQ(firmware.control().controller().stance_changes(), tool.stance_changes);
  if (trot) {
    EXPECT_GT(tool.stance_changes, 4u);  // the trot ran
  } else {
    EXPECT_EQ(tool.stance_changes, 0u);
  }
}

TEST(OneController, SpringbokOnSimsFirmwareReplaysTheToolsCommandsBitForBitStanding) {
  expect_firmware_replays_the_tool(false);
}

TEST(OneController, SpringbokOnSimsFirmwareReplaysTheToolsCommandsBitForBitTrotting) {
  expect_firmware_replays_the_tool(true);
}

}  // namespace
