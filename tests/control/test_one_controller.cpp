// One controller from simulation to the robot: springbok-sim's path (the tool's
// WbcAdapter around control::RobotController under the safety supervisor, in
// lockstep with the Bullet robot) is recorded tick by tick; the same measurements
// are then replayed through the deployed firmware's control mode (app::ControlMode,
// what `springbok` and `springbok-on-sim` run) and every control tick's torques
// must be the tool's, bit for bit. Estimated base (no ground truth: the firmware
// has none), a push at the hand, stand and trot.
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <unistd.h>

#include "scenario.hpp"
#include "sim_scenario_text.hpp"
#include "springbok/app/control_mode.hpp"
#include "springbok/yaml/reader.hpp"
#include "springbok/estimation/base_estimator.hpp"
#include "springbok/gait/trot.hpp"
#include "springbok/params/controller_params.hpp"
#include "wbc_adapter.hpp"

namespace {
using namespace springbok;

struct Recorded {
  hal::Measurements meas;
  safety::Mode mode;
  control::TickStatus status;
  VecNj tau_ff_nm;
};

std::string scenario_yaml(bool trot) {
  std::string y =
      "name: one_controller\n" +
      test::wbc_scenario_head("2.0", "0.5", "{mass: 92, damping: 610, stiffness: 1000}", "{mass: 10, damping: 142, stiffness: 500}") +
      "    estimator: {velocity_gain: 30, position_gain: 10}\n";
  if (trot) y += "    gait: {step_frequency: 1.4, duty_factor: 0.65, step_height: 0.08}\n";
  y += "external_wrenches:\n"
       "  - {frame: arm_end_effector_link, axis: [1, 0, 0], profile: step, amplitude: 40, start_s: 0.8}\n";
  return y;
}

// The tool's path, tick by tick as springbok-sim's loop runs it.
std::vector<Recorded> run_tool(simtool::Scenario& s, Eigen::Vector2d& start_xy) {
  simtool::apply_feet_clearance(s);
  springbok::yaml::Errors errors;
  simtool::WbcAdapter adapter(s, springbok::yaml::Field(s.controller_params, "controller.params", errors));
  EXPECT_TRUE(errors.empty()) << errors.joined();
  sim::BulletRobot hw(s.sim);
  EXPECT_TRUE(hw.configure().ok);
  for (const auto& w : s.wrenches) hw.add_external_wrench(w.wrench);
  EXPECT_TRUE(hw.activate().ok);
  start_xy = hw.ground_truth().q.head<2>();
  std::vector<Recorded> out;
  const auto ticks = static_cast<int>(std::llround(s.duration_s / s.sim.step_s));
  hal::Measurements m;
  hal::JointCommands cmd;
  std::string row;
  for (int k = 0; k < ticks; ++k) {
    hw.read(m);
    adapter.tick(m, hw.ground_truth(), cmd);
    out.push_back({m, adapter.tick_mode(), adapter.tick_status(), cmd.tau_ff_nm});
    (void)hw.write(cmd);
    hw.step();
    row.clear();
    adapter.after_step(hw.ground_truth(), row);
  }
  return out;
}

void expect_firmware_replays_the_tool(bool trot) {
  const std::filesystem::path dir = std::filesystem::temp_directory_path() / ("springbok_one_controller_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  const std::filesystem::path file = dir / (trot ? "trot.yaml" : "stand.yaml");
  std::ofstream(file) << scenario_yaml(trot);
  simtool::Scenario s = simtool::load_scenario(file.string());
  Eigen::Vector2d start_xy;
  const std::vector<Recorded> tool = run_tool(s, start_xy);
  std::filesystem::remove_all(dir);

  // The firmware's control mode, configured with the scenario's parameters.
  app::AppConfig config;
  config.control_mode = app::ControlModeKind::wbc;
  yaml::Errors errors;
  const yaml::Field p(s.controller_params, "controller.params", errors);
  config.estimator = params::read_estimator_params(p["estimator"]);
  if (p["gait"].present()) {  // control.gait: the control mode engages trotting
    config.gait.kind = control::GaitKind::trot;
    config.gait.trot = params::read_trot_params(p["gait"]);
  }
  config.wbc = params::read_wbc_params(p, params::WithControllerParts::yes);
  ASSERT_TRUE(errors.empty()) << errors.joined();
  app::ControlMode firmware(config);
  firmware.controller().set_start_position_xy(start_xy);
  ASSERT_EQ(firmware.controller().params().gait.kind, trot ? control::GaitKind::trot : control::GaitKind::stand);

  hal::JointCommands cmd;
  std::uint64_t control_ticks = 0, compared = 0, stance_changes_seen = 0;
  Stance last_stance = kAllFeet;
  for (const Recorded& r : tool) {
    app::ControlInput in;
    in.dt_s = s.sim.step_s;
    in.meas = &r.meas;
    if (r.mode == safety::Mode::stand_up) {  // the tool's settle: standing still, observed
      in.mode = safety::Mode::stand;
      firmware.observe(in);
      continue;
    }
    ASSERT_EQ(r.mode, safety::Mode::control) << "the tool left the control mode";
    in.mode = safety::Mode::control;
    in.ticks_in_mode = control_ticks++;
    const safety::ControllerReport report = firmware.compute(in, cmd);
    ASSERT_EQ(firmware.last_status(), r.status);
    ASSERT_EQ(report.ok, r.status == control::TickStatus::ok);
    if (!report.ok) continue;
    for (int j = 0; j < kNj; ++j) {
      ASSERT_EQ(cmd.tau_ff_nm[j], r.tau_ff_nm[j]) << "joint " << j << ", control tick " << in.ticks_in_mode;
    }
    ++compared;
    stance_changes_seen += firmware.controller().state().stance != last_stance ? 1 : 0;
    last_stance = firmware.controller().state().stance;
  }
  EXPECT_GT(compared, 1400u);  // 1.5 s of control
  if (trot) {
    EXPECT_GT(stance_changes_seen, 4u);  // the trot ran, in both paths
  } else {
    EXPECT_EQ(stance_changes_seen, 0u);
  }
}

TEST(OneController, FirmwareControlModeReplaysTheToolsTorquesBitForBitStanding) {
  expect_firmware_replays_the_tool(false);
}

TEST(OneController, FirmwareControlModeReplaysTheToolsTorquesBitForBitTrotting) {
  expect_firmware_replays_the_tool(true);
}

}  // namespace
