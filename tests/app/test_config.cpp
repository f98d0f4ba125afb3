// The YAML configuration: the shipped file loads; every kind of bad field is
// an error naming it.
#include <gtest/gtest.h>

#include <fstream>
#include <sstream>
#include <string>

#include "springbok/app/config.hpp"

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

std::string only_error(const ConfigResult& r) {
  EXPECT_FALSE(r.ok);
  EXPECT_EQ(r.errors.size(), 1u);
  return r.errors.empty() ? std::string() : r.errors.front();
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
  EXPECT_EQ(c.stand_gains.kp_nm_per_rad[kFirstArmJoint - 1], 1000.0);
  EXPECT_EQ(c.stand_gains.kp_nm_per_rad[kFirstArmJoint], 40.0);
  EXPECT_EQ(c.stand_posture_rad[8], 1.4);  // lh knee
  EXPECT_EQ(c.operator_socket, "/run/springbok/operator.sock");
  EXPECT_EQ(c.control_mode, ControlModeKind::wbc);
  EXPECT_EQ(c.wbc.template_params.mass_base_kg.x(), 92.0);
  EXPECT_EQ(c.estimator.velocity_gain_per_s, 30.0);
}

TEST(AppConfig, ControlSectionErrorsNameTheField) {
  EXPECT_EQ(only_error(load_config_text(with("  controller: wbc", "  controller: mpc"))),
            "control.controller: expected wbc or joint_pd, got 'mpc'");
  EXPECT_EQ(only_error(load_config_text(with("base: {mass: 92,", "base: {mass: -92,"))).rfind("control.wbc.template.base.mass", 0),
            0u);
  EXPECT_EQ(only_error(load_config_text(with("{velocity_gain: 30,", "{velocity_gian: 30,")))
                .rfind("control.estimator.velocity_gian: unknown key", 0),
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
  EXPECT_EQ(defaults.config.estimator.velocity_gain_per_s, est::EstimatorParams{}.velocity_gain_per_s);
}

TEST(AppConfig, UnknownKeyIsNamed) {
  EXPECT_EQ(only_error(load_config_text(with("  priority: 80", "  priority: 80\n  priorty: 81"))),
            "rt.priorty: unknown key");
  EXPECT_EQ(only_error(load_config_text(shipped_text() + "extra: 1\n")), "extra: unknown key");
}

TEST(AppConfig, MissingKeyIsNamed) {
  EXPECT_EQ(only_error(load_config_text(with("  hal_watchdog_ticks: 5", ""))), "safety.hal_watchdog_ticks: missing");
  EXPECT_EQ(only_error(load_config_text(with("  control: {kp_legs: 1000.0, kd_legs: 20.0,", "  control: {kd_legs: 20.0,"))),
            "gains.control.kp_legs: missing");
}

TEST(AppConfig, WrongTypeIsNamed) {
  EXPECT_EQ(only_error(load_config_text(with("rate_hz: 1000", "rate_hz: fast"))),
            "loop.rate_hz: wrong type: expected an integer, got 'fast'");
  EXPECT_EQ(only_error(load_config_text(with("rate_hz: 1000", "rate_hz: 999.5"))),
            "loop.rate_hz: wrong type: expected an integer, got '999.5'");
  EXPECT_EQ(only_error(load_config_text(with("lock_memory: true", "lock_memory: maybe"))),
            "rt.lock_memory: wrong type: expected true or false, got 'maybe'");
  EXPECT_EQ(only_error(load_config_text(with("limit_margin_rad: 0.05", "limit_margin_rad: [0.05]"))),
            "safety.limit_margin_rad: wrong type: expected a number, got a list");
  std::string scalar_loop = shipped_text();
  const auto from = scalar_loop.find("loop:\n");
  const auto to = scalar_loop.find("rt:\n");
  ASSERT_LT(from, to);
  scalar_loop.replace(from, to - from, "loop: 3\n");
  EXPECT_EQ(only_error(load_config_text(scalar_loop)), "loop: wrong type: expected a map, got a scalar");
}

TEST(AppConfig, OutOfRangeIsNamed) {
  EXPECT_EQ(only_error(load_config_text(with("priority: 80", "priority: 99"))), "rt.priority: out of range [1, 98]: 99");
  EXPECT_EQ(only_error(load_config_text(with("overrun_streak: 3", "overrun_streak: 0"))),
            "safety.overrun_streak: out of range [1, 1000]: 0");
  EXPECT_EQ(only_error(load_config_text(with("damping_nms_per_rad: {legs: 10.0", "damping_nms_per_rad: {legs: -1"))),
            "safety.damping_nms_per_rad.legs: out of range [0, 200]: -1");
}

TEST(AppConfig, NanAndInfinityAreRejected) {
  EXPECT_EQ(only_error(load_config_text(with("limit_margin_rad: 0.05", "limit_margin_rad: .nan"))),
            "safety.limit_margin_rad: not a finite number: .nan");
  EXPECT_EQ(only_error(load_config_text(with("stand_up_duration_s: 3.0", "stand_up_duration_s: -.inf"))),
            "gains.stand_up_duration_s: not a finite number: -.inf");
}

TEST(AppConfig, StandPostureIsCheckedAgainstTheModel) {
  const ConfigResult short_list = load_config_text(with("[0.0, 0.7, -1.4, 0.0, 0.7, -1.4,", "[0.0, 0.7,"));
  ASSERT_FALSE(short_list.ok);
  EXPECT_EQ(short_list.errors.front(), "gains.stand_posture_rad: expected 19 values (one per joint), got 15");
  EXPECT_EQ(only_error(load_config_text(with("[0.0, 0.7, -1.4,", "[0.0, 0.7, 0.2,"))),
            "gains.stand_posture_rad[2]: outside the joint limits of lf_kfe_joint [-2.44346, -0.349066]: 0.2");
}

TEST(AppConfig, SyntaxErrorsGiveTheLine) {
  const ConfigResult r = load_config_text("loop:\n  rate_hz: [1000\n");
  ASSERT_FALSE(r.ok);
  EXPECT_EQ(r.errors.front().substr(0, 12), "yaml: line 3");
}

TEST(AppConfig, AMissingFileIsAnError) {
  EXPECT_EQ(only_error(load_config_file("/nonexistent/springbok.yaml")), "/nonexistent/springbok.yaml: cannot open");
}

}  // namespace
}  // namespace springbok::app
