// The YAML configuration: the shipped file loads; every kind of bad field is
// an error naming it.
#include <gtest/gtest.h>

#include <fstream>
#include <sstream>
#include <string>

#include "springbok/app/config.hpp"
#include "springbok/app/control_mode.hpp"
#include "springbok/app/drive_gains.hpp"

namespace springbok::app {
namespace {

std::string shipped_text() {
  std::ifstream in(SPRINGBOK_APP_CONFIG);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

// The shipped file with one line replaced (the first line containing `from`).
std::string with(const std::string& from, const std::string& to) {
  std::string text = shipped_text();
  const auto at = text.find(from);
  EXPECT_NE(at, std::string::npos) << from;
  text.replace(at, from.size(), to);
  return text;
}

// The one error of `r`, without its " (line N)" (every error names its line: checked here).
std::string without_line(const std::string& e) {
  const auto at = e.rfind(" (line ");
  EXPECT_NE(at, std::string::npos) << e;
  return at == std::string::npos ? e : e.substr(0, at);
}
std::string only_error(const ConfigResult& r) {
  EXPECT_FALSE(r.ok);
  EXPECT_EQ(r.errors.size(), 1u);
  return r.errors.empty() ? std::string() : without_line(r.errors.front());
}

TEST(AppConfig, TheShippedFileLoads) {
  const ConfigResult r = load_config_file(SPRINGBOK_APP_CONFIG);
  ASSERT_TRUE(r.ok) << (r.errors.empty() ? "" : r.errors.front());
  const AppConfig& c = r.config;
  EXPECT_EQ(c.rate_hz, 1000);
  EXPECT_EQ(c.rt.priority, 80);
  EXPECT_EQ(c.rt.cpu, -1);
  EXPECT_EQ(c.rt.prefault_heap_bytes, std::size_t{16} << 20);
  EXPECT_EQ(c.safety.overrun_streak_limit, 3u);
  EXPECT_EQ(c.safety.hal_watchdog_ticks, 5u);
  EXPECT_EQ(c.safety.damping_nms_per_rad[0], 10.0);
  EXPECT_EQ(c.safety.damping_nms_per_rad[kNj - 1], 2.0);
  EXPECT_EQ(c.safety.idle_damping_nms_per_rad[0], 20.0);
  EXPECT_EQ(c.safety.idle_damping_nms_per_rad[kNj - 1], 0.4);
  EXPECT_EQ(c.stand_gains.kp_nm_per_rad[kFirstArmJoint - 1], 1000.0);
  EXPECT_EQ(c.stand_gains.kp_nm_per_rad[kFirstArmJoint], 40.0);
  EXPECT_EQ(c.stand_posture_rad[8], 1.4);  // lh knee
  EXPECT_EQ(c.operator_socket, "/run/springbok/operator.sock");
  EXPECT_EQ(c.control_mode, ControlModeKind::wbc);
  EXPECT_EQ(c.control.wbc.template_params.mass_base_kg.x(), 92.0);
  EXPECT_EQ(c.control.estimator.filter, est::BaseFilter::ekf);  // the IMU's biases estimated
  EXPECT_FALSE(c.stand_weight_feed_forward);
}

TEST(AppConfig, TheStandsFeedForwardIsWeightOrNone) {
  const ConfigResult weight = load_config_text(with("  stand_feed_forward: none", "  stand_feed_forward: weight"));
  ASSERT_TRUE(weight.ok) << weight.errors.front();
  EXPECT_TRUE(weight.config.stand_weight_feed_forward);
  EXPECT_FALSE(load_config_text(with("  stand_feed_forward: none\n", "")).config.stand_weight_feed_forward);
  EXPECT_EQ(only_error(load_config_text(with("  stand_feed_forward: none", "  stand_feed_forward: gravity"))),
            "gains.stand_feed_forward: must be one of none, weight, got 'gravity'");
}

TEST(AppConfig, ControlSectionErrorsNameTheField) {
  EXPECT_EQ(only_error(load_config_text(with("  controller: wbc", "  controller: mpc"))),
            "control.controller: must be one of wbc, joint_pd, got 'mpc'");
  EXPECT_EQ(only_error(load_config_text(with("base: {mass: 92,", "base: {mass: -92,"))).rfind("control.wbc.template.base.mass", 0),
            0u);
  EXPECT_EQ(only_error(load_config_text(with("estimator: {filter: ekf}", "estimator: {filter: ekf, velocity_gian: 30}")))
                .rfind("control.estimator.velocity_gian: unknown key", 0),
            0u);
  EXPECT_EQ(only_error(load_config_text(with("estimator: {filter: ekf}", "estimator: {filter: ukf}")))
                .rfind("control.estimator.filter: must be one of complementary, ekf, got 'ukf'", 0),
            0u);
  // joint_pd needs no wbc map; wbc does.
  const std::string text = shipped_text();
  const auto wbc_at = text.find("  wbc:"), estimator_at = text.find("  estimator:");
  ASSERT_NE(wbc_at, std::string::npos);
  ASSERT_NE(estimator_at, std::string::npos);
  std::string without_wbc = text;
  without_wbc.erase(wbc_at, estimator_at - wbc_at);
  EXPECT_EQ(only_error(load_config_text(without_wbc)), "control.wbc: missing (control.controller is wbc)");
  const auto at = without_wbc.find("  controller: wbc");
  without_wbc.replace(at, 17, "  controller: joint_pd");
  const ConfigResult pd = load_config_text(without_wbc);
  ASSERT_TRUE(pd.ok) << pd.errors.front();
  EXPECT_EQ(pd.config.control_mode, ControlModeKind::joint_pd);
  // control.estimator is optional: without it every estimator default holds.
  const auto est_at = text.find("  estimator:");
  const std::string without_estimator = text.substr(0, est_at) + text.substr(text.find('\n', est_at) + 1);
  const ConfigResult defaults = load_config_text(without_estimator);
  ASSERT_TRUE(defaults.ok) << defaults.errors.front();
  EXPECT_EQ(defaults.config.control.estimator.velocity_gain_per_s, est::EstimatorParams{}.velocity_gain_per_s);
  EXPECT_EQ(defaults.config.control.gait.kind, control::GaitKind::stand);  // no control.gait: the control mode stands
  // control.gait: the trot the control mode engages with, read as the scenario's gait: map.
  const std::string estimator_line = text.substr(est_at, text.find('\n', est_at) - est_at);
  const ConfigResult trot =
      load_config_text(with(estimator_line, estimator_line + "\n  gait: {step_frequency: 1.2, duty_factor: 0.7}"));
  ASSERT_TRUE(trot.ok) << trot.errors.front();
  EXPECT_EQ(trot.config.control.gait.kind, control::GaitKind::trot);
  EXPECT_EQ(trot.config.control.gait.trot.step_frequency_hz, 1.2);
  EXPECT_EQ(trot.config.control.gait.trot.duty_factor, 0.7);
  EXPECT_EQ(only_error(load_config_text(with(estimator_line, estimator_line + "\n  gait: {duty_factor: 0.3}"))),
            "control.gait.duty_factor: must be in [0.5, 0.95], got 0.3");
  // control.push_stepping: optional, on by default; what the control mode's controller gets.
  EXPECT_TRUE(defaults.config.control.push_stepping.enabled);
  const ConfigResult off =
      load_config_text(with(estimator_line, estimator_line + "\n  push_stepping: {enabled: false, delay: 0.1}"));
  ASSERT_TRUE(off.ok) << off.errors.front();
  EXPECT_FALSE(off.config.control.push_stepping.enabled);
  EXPECT_EQ(off.config.control.push_stepping.delay_s, 0.1);
  EXPECT_FALSE(off.config.control.push_stepping.enabled);
  EXPECT_EQ(only_error(load_config_text(with(estimator_line, estimator_line + "\n  push_stepping: {settle: -1}"))),
            "control.push_stepping.settle: must be in [0, 60], got -1");
}

TEST(AppConfig, UnknownKeyIsNamed) {
  EXPECT_EQ(only_error(load_config_text(with("  priority: 80", "  priority: 80\n  priorty: 81"))),
            "rt.priorty: unknown key (known: enabled, require, priority, cpu, lock_memory, prefault_heap_mib, "
            "cpu_dma_latency)");
  EXPECT_EQ(only_error(load_config_text(shipped_text() + "extra: 1\n")).rfind("extra: unknown key (known: loop, rt,", 0), 0u);
}

TEST(AppConfig, MissingKeyIsNamed) {
  EXPECT_EQ(only_error(load_config_text(with("  hal_watchdog_ticks: 5", ""))), "safety.hal_watchdog_ticks: missing");
  EXPECT_EQ(only_error(load_config_text(with("  control: {kp_legs: 1000.0, kd_legs: 20.0,", "  control: {kd_legs: 20.0,"))),
            "gains.control.kp_legs: missing");
}

TEST(AppConfig, WrongTypeIsNamed) {
  EXPECT_EQ(only_error(load_config_text(with("rate_hz: 1000", "rate_hz: fast"))),
            "loop.rate_hz: must be an integer (decimal or 0x hex), got 'fast'");
  EXPECT_EQ(only_error(load_config_text(with("rate_hz: 1000", "rate_hz: 999.5"))),
            "loop.rate_hz: must be an integer (decimal or 0x hex), got '999.5'");
  EXPECT_EQ(only_error(load_config_text(with("lock_memory: true", "lock_memory: maybe"))),
            "rt.lock_memory: must be true or false, got 'maybe'");
  EXPECT_EQ(only_error(load_config_text(with("limit_margin_rad: 0.05", "limit_margin_rad: [0.05]"))),
            "safety.limit_margin_rad: must be a number, got a list");
  std::string scalar_loop = shipped_text();
  const auto from = scalar_loop.find("loop:\n");
  const auto to = scalar_loop.find("rt:\n");
  ASSERT_LT(from, to);
  scalar_loop.replace(from, to - from, "loop: 3\n");
  EXPECT_EQ(only_error(load_config_text(scalar_loop)), "loop: must be a map, got '3'");
}

TEST(AppConfig, OutOfRangeIsNamed) {
  EXPECT_EQ(only_error(load_config_text(with("priority: 80", "priority: 99"))), "rt.priority: must be in [1, 98], got 99");
  EXPECT_EQ(only_error(load_config_text(with("overrun_streak: 3", "overrun_streak: 0"))),
            "safety.overrun_streak: must be in [1, 1000], got 0");
  EXPECT_EQ(only_error(load_config_text(with("damping_nms_per_rad: {legs: 10.0", "damping_nms_per_rad: {legs: -1"))),
            "safety.damping_nms_per_rad.legs: must be in [0, 200], got -1");
  // D_start = 0 would let the powered robot drop while idle.
  const std::string no_idle_damping =
      with("idle_damping_nms_per_rad: {legs: 20.0", "idle_damping_nms_per_rad: {legs: 0");
  EXPECT_EQ(only_error(load_config_text(no_idle_damping)),
            "safety.idle_damping_nms_per_rad.legs: must be in [0.1, 200], got 0");
  const ConfigResult renamed = load_config_text(with("  idle_damping_nms_per_rad:", "  idle_damping:"));
  ASSERT_EQ(renamed.errors.size(), 2u);
  EXPECT_EQ(renamed.errors[0].rfind("safety.idle_damping: unknown key (known: overrun_streak,", 0), 0u) << renamed.errors[0];
  EXPECT_EQ(without_line(renamed.errors[1]), "safety.idle_damping_nms_per_rad: missing");
}

TEST(AppConfig, TheOperatorSocketPathFitsAUnixSocket) {
  const std::string long_path = "/run/springbok/" + std::string(100, 'x') + ".sock";  // 120 bytes
  EXPECT_EQ(only_error(load_config_text(with("socket: /run/springbok/operator.sock", "socket: " + long_path))),
            "operator.socket: must be at most 107 bytes (a Unix socket path), got 120");
  const std::string fits = "/run/" + std::string(102, 'y');  // 107 bytes
  EXPECT_TRUE(load_config_text(with("socket: /run/springbok/operator.sock", "socket: " + fits)).ok);
}

TEST(AppConfig, NanAndInfinityAreRejected) {
  EXPECT_EQ(only_error(load_config_text(with("limit_margin_rad: 0.05", "limit_margin_rad: .nan"))),
            "safety.limit_margin_rad: must be a finite number, got '.nan'");
  EXPECT_EQ(only_error(load_config_text(with("stand_up_duration_s: 3.0", "stand_up_duration_s: -.inf"))),
            "gains.stand_up_duration_s: must be a finite number, got '-.inf'");
}

TEST(AppConfig, StandPostureIsCheckedAgainstTheModel) {
  const ConfigResult short_list = load_config_text(with("[0.0, 0.7, -1.4, 0.0, 0.7, -1.4,", "[0.0, 0.7,"));
  ASSERT_FALSE(short_list.ok);
  EXPECT_EQ(without_line(short_list.errors.front()), "gains.stand_posture_rad: must be a list of 19, got 15 elements");
  EXPECT_EQ(only_error(load_config_text(with("[0.0, 0.7, -1.4,", "[0.0, 0.7, 0.2,"))),
            "gains.stand_posture_rad[2]: outside the joint limits of lf_kfe_joint [-2.44346, -0.349066]: 0.2");
}

TEST(AppConfig, SyntaxErrorsGiveTheLine) {
  const ConfigResult r = load_config_text("loop:\n  rate_hz: [1000\n");
  ASSERT_FALSE(r.ok);
  EXPECT_EQ(r.errors.front().rfind("YAML syntax: ", 0), 0u) << r.errors.front();
  EXPECT_NE(r.errors.front().find("(line 3, column"), std::string::npos) << r.errors.front();
}

TEST(AppConfig, AMissingFileIsAnError) {
  const ConfigResult r = load_config_file("/nonexistent/springbok.yaml");
  EXPECT_FALSE(r.ok);
  EXPECT_EQ(r.errors, std::vector<std::string>{"/nonexistent/springbok.yaml: cannot open"});
}

// MIT drives with Mini Cheetah gain ranges (kp [0, 500], kd [0, 5]) on the legs, CiA 402 on the arm.
DriveGainRanges mini_cheetah_legs() {
  DriveGainRanges r;
  for (int j = 0; j < kFirstArmJoint; ++j) {
    r.in_drive[static_cast<std::size_t>(j)] = true;
    r.kp_max[j] = 500.0;
    r.kd_max[j] = 5.0;
    r.drive[static_cast<std::size_t>(j)] = "MIT drive (id " + std::to_string(j + 1) + ")";
  }
  return r;
}

// Every damping the shipped config commands is one a law evaluated once per tick renders:
// kd dt / I < 2 (explicit Euler on the joint's own inertia I, rotor included; beyond it the
// joint chatters, as the Gen3's wrist did with the stand gains before the rotors). The MIT
// drives run their law faster; the simulated drives and CiA 402's host-side law run it per tick.
TEST(ShippedConfig, EveryDampingIsRenderableInOneTick) {
  const ConfigResult loaded = load_config_file(SPRINGBOK_APP_CONFIG);
  ASSERT_TRUE(loaded.ok);
  const AppConfig& c = loaded.config;
  const double dt_s = 1.0 / c.rate_hz;
  for (int j = 0; j < kNj; ++j) {
    const double limit = 2.0 * joint_own_axis_inertia_kgm2(j) / dt_s;
    const std::string joint(robot::kJoints[static_cast<std::size_t>(j)].name);
    EXPECT_LT(c.stand_gains.kd_nms_per_rad[j], limit) << "gains.stand, " << joint;
    EXPECT_LT(c.control_gains.kd_nms_per_rad[j], limit) << "gains.control, " << joint;
    EXPECT_LT(c.safety.damping_nms_per_rad[j], limit) << "safety.damping_nms_per_rad, " << joint;
    EXPECT_LT(c.safety.idle_damping_nms_per_rad[j], limit) << "safety.idle_damping_nms_per_rad, " << joint;
  }
  // The wrist's last joint, the lightest: ~0.016 kg m^2 with its rotor, 32 N m s/rad at 1 kHz.
  EXPECT_GT(2.0 * joint_own_axis_inertia_kgm2(kNj - 1) / dt_s, 10.0 * c.stand_gains.kd_nms_per_rad[kNj - 1]);
}

TEST(DriveGains, GainsTheDrivesCannotRenderAreNamedWithTheRange) {
  ConfigResult loaded = load_config_file(SPRINGBOK_APP_CONFIG);
  ASSERT_TRUE(loaded.ok);
  AppConfig c = loaded.config;
  c.stand_gains.kp_nm_per_rad.head<kFirstArmJoint>().setConstant(500.0);  // at the edge: renderable
  c.stand_gains.kd_nms_per_rad.head<kFirstArmJoint>().setConstant(5.0);
  c.control_gains = c.stand_gains;
  c.safety.idle_damping_nms_per_rad.head<kFirstArmJoint>().setConstant(5.0);
  c.safety.damping_nms_per_rad.head<kFirstArmJoint>().setConstant(5.0);
  EXPECT_TRUE(check_drive_gains(c, mini_cheetah_legs()).empty());
  // The arm's gains are rendered on the host (CiA 402): any value fits.
  c.stand_gains.kp_nm_per_rad.tail<kArmJoints>().setConstant(900.0);
  EXPECT_TRUE(check_drive_gains(c, mini_cheetah_legs()).empty());

  c.stand_gains.kp_nm_per_rad.head<kFirstArmJoint>().setConstant(1000.0);
  c.safety.idle_damping_nms_per_rad.head<kFirstArmJoint>().setConstant(6.0);
  const std::vector<std::string> errors = check_drive_gains(c, mini_cheetah_legs());
  ASSERT_EQ(errors.size(), 2u);
  EXPECT_EQ(errors[0],
            "gains.stand.kp_legs: 1000 is outside the kp range [0, 500] of lf_haa_joint's MIT drive (id 1) (the drive "
            "would clamp it); lower the gain or give the drive a wider range (can.mit_ranges)");
  EXPECT_EQ(errors[1].substr(0, 88),
            "safety.idle_damping_nms_per_rad.legs: 6 is outside the kd range [0, 5] of lf_haa_joint's");
  // Only one joint's drive too narrow: that joint is named.
  DriveGainRanges one_narrow;
  one_narrow.in_drive[7] = true;
  one_narrow.kp_max[7] = 2000.0;
  one_narrow.kd_max[7] = 5.5;
  one_narrow.drive[7] = "MIT drive (id 8 on bus lh)";
  one_narrow.backend_kd.emplace_back("can.timing.damping_kd_nms_per_rad", 2.0);
  const std::vector<std::string> lh = check_drive_gains(c, one_narrow);
  ASSERT_EQ(lh.size(), 1u);  // kp 1000 and 500 fit 2000, kd 5 and 2 fit 5.5; idle's 6 does not
  EXPECT_EQ(lh[0].substr(0, 117),
            "safety.idle_damping_nms_per_rad.legs: 6 is outside the kd range [0, 5.5] of lh_hfe_joint's MIT drive "
            "(id 8 on bus lh)");
  // The backend's own kd (the CAN shut-down damping) is checked on every joint's drive.
  one_narrow.backend_kd.front().second = 7.0;
  const std::vector<std::string> shutdown = check_drive_gains(c, one_narrow);
  ASSERT_EQ(shutdown.size(), 2u);
  EXPECT_EQ(shutdown[1].substr(0, 70), "can.timing.damping_kd_nms_per_rad: 7 is outside the kd range [0, 5.5] ");
  // The fault damping is the drives' kd too (CAN.md 4.4).
  c.safety.idle_damping_nms_per_rad.head<kFirstArmJoint>().setConstant(5.0);
  c.safety.damping_nms_per_rad.head<kFirstArmJoint>().setConstant(10.0);
  const std::vector<std::string> fault_damping = check_drive_gains(c, one_narrow);
  ASSERT_EQ(fault_damping.size(), 2u);
  EXPECT_EQ(fault_damping[0].substr(0, 102),
            "safety.damping_nms_per_rad.legs: 10 is outside the kd range [0, 5.5] of lh_hfe_joint's MIT drive (id 8");
}

}  // namespace
}  // namespace springbok::app
