// The WBC config: good files load, every kind of bad field is named.
#include <string>

#include <gtest/gtest.h>

#include "springbok/wbc/wbc_config.hpp"

namespace {
using springbok::config::ConfigError;
using springbok::config::Fields;
using springbok::wbc::read_wbc_params;

const char* kGood = R"(
template:
  base: {mass: 92, damping: 610, stiffness: 1000}
  ee: {mass: [0.4, 4, 10], damping: 29, stiffness: 500}
base_orientation: {kp: 500, kd: 50, inertia: auto}
arm: {posture: current, posture_kp: 50}
weights: {arm: 10}
contact: {friction_mu: 0.8}
)";

springbok::wbc::WbcParams load(const std::string& text) { return read_wbc_params(Fields(YAML::Load(text), "wbc")); }

std::string error_of(const std::string& text) {
  try {
    load(text);
  } catch (const ConfigError& e) {
    return e.what();
  }
  return "(no error)";
}

TEST(WbcConfig, GoodFileLoads) {
  const auto p = load(kGood);
  EXPECT_DOUBLE_EQ(p.template_params.mass_base_kg.y(), 92.0);
  EXPECT_DOUBLE_EQ(p.template_params.mass_ee_kg.z(), 10.0);
  EXPECT_DOUBLE_EQ(p.template_params.damping_ee_ns_per_m.x(), 29.0);
  EXPECT_DOUBLE_EQ(p.kr_nm_per_rad.x(), 500.0);
  EXPECT_LE(p.base_rot_inertia_kgm2.maxCoeff(), 0.0);  // auto
  EXPECT_FALSE(p.pin_arm_posture);
  EXPECT_DOUBLE_EQ(p.posture_kp_per_s2, 50.0);
  EXPECT_DOUBLE_EQ(p.weight_arm, 10.0);
  EXPECT_DOUBLE_EQ(p.friction_mu, 0.8);
  EXPECT_DOUBLE_EQ(p.joint_limit_horizon_s, springbok::wbc::WbcParams{}.joint_limit_horizon_s);
}

TEST(WbcConfig, BadFieldsAreNamed) {
  const std::string base_ok = "template:\n  base: {mass: 92, damping: 610, stiffness: 1000}\n";
  EXPECT_EQ(error_of(base_ok + "  ee: {mass: -4, damping: 90, stiffness: 500}\n"),
            "wbc.template.ee.mass: must be in [1e-06, 10000], got -4");
  EXPECT_EQ(error_of(base_ok + "  ee: {mass: 4, damping: 90, stiffness: 0}\n"),
            "wbc.template.ee.stiffness: must be in [1e-06, 1e+07], got 0");
  EXPECT_EQ(error_of(base_ok + "  ee: {mass: 4, damping: 90}\n"), "wbc.template.ee.stiffness: missing");
  EXPECT_EQ(error_of(base_ok + "  ee: {mass: 4, damping: .nan, stiffness: 5}\n"),
            "wbc.template.ee.damping: must be a finite number, got '.nan'");
  EXPECT_EQ(error_of(base_ok + "  ee: {mass: [4, 4], damping: 1, stiffness: 5}\n"),
            "wbc.template.ee.mass: must be a number or a list of 3 numbers, got a list");
  EXPECT_EQ(error_of("weights: {arm: 1}\n"), "wbc.template: missing");
  EXPECT_NE(error_of(std::string(kGood) + "gains: {kp: 1}\n").find("wbc.gains: unknown key"), std::string::npos);
  EXPECT_EQ(error_of(std::string(kGood) + "limits: {torque_scale: 1.5}\n"),
            "wbc.limits.torque_scale: must be in [1e-06, 1], got 1.5");
  EXPECT_EQ(error_of(std::string(kGood) + "swing: {kp: lots}\n"),
            "wbc.swing.kp: must be a number, got 'lots'");
  // What a failed tick commands is the supervisor's: the old fallback section is unknown.
  EXPECT_NE(error_of(std::string(kGood) + "fallback: {damping: 5}\n").find("wbc.fallback: unknown key"), std::string::npos);
  EXPECT_EQ(error_of(base_ok + "  ee: {mass: 4, damping: 9, stiffness: 5}\ncontact: {normal_force_min: 10, normal_force_max: 5}\n"),
            "wbc.contact.normal_force_max: must be above contact.normal_force_min");
  EXPECT_EQ(error_of(std::string(kGood) + "contact: {friction_mu: 0.5}\n"), "wbc.contact: duplicate key");
}
}  // namespace
