// The controller's parameters (springbok::params): good maps load, every kind of bad field is
// named with its line, and every problem of a map is reported, not only the first.
#include <string>

#include <cmath>

#include <gtest/gtest.h>

#include "springbok/params/controller_params.hpp"

namespace {
using springbok::yaml::Errors;
using springbok::yaml::Field;
namespace params = springbok::params;

const char* kGood = R"(
template:
  base: {mass: 92, damping: 610, stiffness: 1000}
  ee: {mass: [0.4, 4, 10], damping: 29, stiffness: 500}
base_orientation: {kp: 500, kd: 50, inertia: auto}
arm: {posture: current, posture_kp: 50}
weights: {arm: 10}
contact: {friction_mu: 0.8}
)";

springbok::wbc::WbcParams load(const std::string& text) {
  Errors errors;
  const auto p = params::read_wbc_params(Field(YAML::Load(text), "wbc", errors));
  EXPECT_TRUE(errors.empty()) << errors.joined();
  return p;
}

// Every error of `text`, one per line.
template <class Read>
std::string errors_of(const std::string& text, const char* path, Read&& read) {
  Errors errors;
  (void)read(Field(YAML::Load(text), path, errors));
  return errors.empty() ? "(no error)" : errors.joined();
}
std::string error_of(const std::string& text) {
  return errors_of(text, "wbc", [](const Field& f) { return params::read_wbc_params(f); });
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
            "wbc.template.ee.mass: must be in [1e-06, 10000], got -4 (line 3)");
  EXPECT_EQ(error_of(base_ok + "  ee: {mass: 4, damping: 90, stiffness: 0}\n"),
            "wbc.template.ee.stiffness: must be in [1e-06, 1e+07], got 0 (line 3)");
  EXPECT_EQ(error_of(base_ok + "  ee: {mass: 4, damping: 90}\n"), "wbc.template.ee.stiffness: missing (line 3)");
  EXPECT_EQ(error_of(base_ok + "  ee: {mass: 4, damping: .nan, stiffness: 5}\n"),
            "wbc.template.ee.damping: must be a finite number, got '.nan' (line 3)");
  EXPECT_EQ(error_of(base_ok + "  ee: {mass: [4, 4], damping: 1, stiffness: 5}\n"),
            "wbc.template.ee.mass: must be a list of 3, got 2 elements (line 3)");
  // No template: the robot file's (robot::kTemplate).
  const auto robot_default = load("weights: {arm: 1}\n");
  EXPECT_EQ(robot_default.template_params.stiffness_base_n_per_m.x(), springbok::robot::kTemplate.base.stiffness);
  EXPECT_EQ(robot_default.template_params.mass_ee_kg.z(), springbok::robot::kTemplate.ee.mass);
  EXPECT_NE(error_of(std::string(kGood) + "gains: {kp: 1}\n").find("wbc.gains: unknown key"), std::string::npos);
  EXPECT_EQ(error_of(std::string(kGood) + "limits: {torque_scale: 1.5}\n"),
            "wbc.limits.torque_scale: must be in [1e-06, 1], got 1.5 (line 9)");
  EXPECT_EQ(error_of(std::string(kGood) + "limits: {velocity_scale: 1.5}\n"),
            "wbc.limits.velocity_scale: must be in [1e-06, 1], got 1.5 (line 9)");
  EXPECT_EQ(error_of(std::string(kGood) + "limits: {velocity_horizon_s: 0}\n"),
            "wbc.limits.velocity_horizon_s: must be in [0.001, 10], got 0 (line 9)");
  EXPECT_EQ(error_of(std::string(kGood) + "swing: {kp: lots}\n"),
            "wbc.swing.kp: must be a number, got 'lots' (line 9)");
  // What a failed tick commands is the supervisor's: the old fallback section is unknown.
  EXPECT_NE(error_of(std::string(kGood) + "fallback: {damping: 5}\n").find("wbc.fallback: unknown key"), std::string::npos);
  EXPECT_EQ(error_of(base_ok + "  ee: {mass: 4, damping: 9, stiffness: 5}\ncontact: {normal_force_min: 10, normal_force_max: 5}\n"),
            "wbc.contact.normal_force_max: must be above contact.normal_force_min (line 4)");
  EXPECT_EQ(error_of(std::string(kGood) + "contact: {friction_mu: 0.5}\n"), "wbc.contact: duplicate key (line 9)");
}

// The support limit's margin: 4 cm by default, 0 turns it off, a negative or non-number refused.
TEST(WbcConfig, TheSupportMarginIsADistanceOrZeroForOff) {
  const std::string base_ok = "template:\n  base: {mass: 92, damping: 610, stiffness: 1000}\n"
                              "  ee: {mass: 4, damping: 90, stiffness: 500}\n";
  EXPECT_DOUBLE_EQ(load(base_ok).support_margin_m, 0.04);
  EXPECT_DOUBLE_EQ(load(base_ok + "contact: {support_margin: 0.06}\n").support_margin_m, 0.06);
  EXPECT_DOUBLE_EQ(load(base_ok + "contact: {support_margin: 0}\n").support_margin_m, 0.0);
  EXPECT_EQ(error_of(base_ok + "contact: {support_margin: -0.01}\n"),
            "wbc.contact.support_margin: must be in [0, 0.5], got -0.01 (line 4)");
  EXPECT_EQ(error_of(base_ok + "contact: {support_margin: .nan}\n"),
            "wbc.contact.support_margin: must be a finite number, got '.nan' (line 4)");
}

TEST(WbcConfig, TheHandsAccelerationBoundIsANumberOrNone) {
  const std::string base_ok = "template:\n  base: {mass: 92, damping: 610, stiffness: 1000}\n"
                              "  ee: {mass: 0.4, damping: 29, stiffness: 500}\n";
  EXPECT_DOUBLE_EQ(load(base_ok).ee_acceleration_limit_m_s2, springbok::wbc::WbcParams{}.ee_acceleration_limit_m_s2);
  EXPECT_DOUBLE_EQ(load(base_ok + "arm: {max_acceleration: 60}\n").ee_acceleration_limit_m_s2, 60.0);
  EXPECT_TRUE(std::isinf(load(base_ok + "arm: {max_acceleration: none}\n").ee_acceleration_limit_m_s2));
  EXPECT_EQ(error_of(base_ok + "arm: {max_acceleration: 0}\n"),
            "wbc.arm.max_acceleration: must be in [1, 10000], got 0 (line 4)");
  EXPECT_EQ(error_of(base_ok + "arm: {max_acceleration: lots}\n"),
            "wbc.arm.max_acceleration: must be a number, got 'lots' (line 4)");
}

TEST(WbcConfig, TheRotationalTemplateIsOnWhenPresent) {
  EXPECT_FALSE(load(kGood).rotational_template_enabled) << "off by default: the paper's controller";
  const auto p = load(std::string(kGood) +
                      "rotational_template:\n"
                      "  base: {inertia: auto, damping: 150, stiffness: [500, 600, 700]}\n"
                      "  ee: {inertia: 0.4, damping: 9, stiffness: 50}\n"
                      "swing: {kp: 300}\n");
  EXPECT_TRUE(p.rotational_template_enabled);
  EXPECT_LE(p.rotational_template.inertia_base_kgm2.maxCoeff(), 0.0);  // auto: the composite inertia
  EXPECT_DOUBLE_EQ(p.rotational_template.stiffness_base_nm_per_rad.z(), 700.0);
  EXPECT_DOUBLE_EQ(p.rotational_template.inertia_ee_kgm2.y(), 0.4);
  EXPECT_DOUBLE_EQ(p.rotational_template.damping_ee_nms_per_rad.x(), 9.0);
  const std::string base_ok = "template:\n  base: {mass: 92, damping: 610, stiffness: 1000}\n"
                              "  ee: {mass: 0.4, damping: 29, stiffness: 500}\n";
  const auto arm = load(base_ok + "arm: {max_angular_acceleration: 300, manipulability_threshold_6d: 0.01}\n");
  EXPECT_DOUBLE_EQ(arm.ee_angular_acceleration_limit_rad_s2, 300.0);
  EXPECT_DOUBLE_EQ(arm.manipulability_threshold_6d, 0.01);
  EXPECT_DOUBLE_EQ(load(std::string(kGood) + "rotational_template:\n  base: {inertia: [6, 15, 18], damping: 1, stiffness: 1}\n"
                                             "  ee: {inertia: 0.1, damping: 1, stiffness: 1}\n")
                       .rotational_template.inertia_base_kgm2.y(),
                   15.0);
  const std::string rot = std::string(kGood) + "rotational_template:\n  base: {inertia: auto, damping: 150, stiffness: 500}\n";
  EXPECT_EQ(error_of(rot + "  ee: {inertia: 0, damping: 4.5, stiffness: 50}\n"),
            "wbc.rotational_template.ee.inertia: must be in [1e-06, 1000], got 0 (line 11)");
  EXPECT_EQ(error_of(rot + "  ee: {inertia: 0.1, damping: 4.5}\n"), "wbc.rotational_template.ee.stiffness: missing (line 11)");
  EXPECT_EQ(error_of(rot + "  ee: {inertia: 0.1, damping: -1, stiffness: 50}\n"),
            "wbc.rotational_template.ee.damping: must be in [0, 10000], got -1 (line 11)");
  EXPECT_EQ(error_of(std::string(kGood) + "rotational_template:\n  ee: {inertia: 0.1, damping: 1, stiffness: 1}\n"),
            "wbc.rotational_template.base: missing (line 10)");
  EXPECT_EQ(error_of(std::string(kGood) + "rotational_template:\n  base: {inertia: lots, damping: 1, stiffness: 1}\n"
                                          "  ee: {inertia: 0.1, damping: 1, stiffness: 1}\n"),
            "wbc.rotational_template.base.inertia: must be a number, got 'lots' (line 10)");
}

TEST(WbcConfig, JointFrictionIsOneNumberOrOnePerJoint) {
  EXPECT_EQ(load(kGood).joint_viscous_friction_nms_per_rad, springbok::VecNj::Zero()) << "default: none";
  EXPECT_EQ(load(std::string(kGood) + "joint_friction: {viscous: 0.5}\n").joint_viscous_friction_nms_per_rad,
            springbok::VecNj::Constant(0.5));
  const springbok::VecNj per_joint = springbok::VecNj::LinSpaced(0.0, 1.8);
  std::string list = "joint_friction: {viscous: [";
  for (int j = 0; j < springbok::kNj; ++j) list += (j > 0 ? ", " : "") + std::to_string(per_joint[j]);
  EXPECT_LT((load(std::string(kGood) + list + "]}\n").joint_viscous_friction_nms_per_rad - per_joint).norm(), 1e-12);
  EXPECT_EQ(error_of(std::string(kGood) + "joint_friction: {viscous: [0.5, 0.5]}\n"),
            "wbc.joint_friction.viscous: must be a list of 19, got 2 elements (line 9)");
  EXPECT_EQ(error_of(std::string(kGood) + "joint_friction: {viscous: -0.1}\n"),
            "wbc.joint_friction.viscous: must be in [0, 100], got -0.1 (line 9)");
  EXPECT_NE(error_of(std::string(kGood) + "joint_friction: {coulomb: 1}\n").find("wbc.joint_friction.coulomb: unknown key"),
            std::string::npos);
}

TEST(WbcConfig, EveryProblemOfTheMapIsReported) {
  const std::string text = "template:\n  base: {mass: 0, damping: 610, stiffness: 1000}\n  ee: {mass: 4, damping: 90}\n"
                           "weights: {arm: lots}\nswing: {kp: 1}\ncolour: red\n";
  EXPECT_EQ(error_of(text),
            "wbc.colour: unknown key (known: template, rotational_template, base_orientation, arm, weights, contact, limits, swing, "
            "joint_friction) (line 6)\n"
            "wbc.template.ee.stiffness: missing (line 3)\n"
            "wbc.template.base.mass: must be in [1e-06, 100000], got 0 (line 2)\n"
            "wbc.weights.arm: must be a number, got 'lots' (line 4)");
}

TEST(WbcConfig, AScenariosControllerParamsMayHoldTheEstimatorAndTheGait) {
  Errors errors;
  (void)params::read_wbc_params(Field(YAML::Load(std::string(kGood) + "estimator: {}\ngait: {}\n"), "p", errors),
                                params::WithControllerParts::yes);
  EXPECT_TRUE(errors.empty()) << errors.joined();
  EXPECT_NE(error_of(std::string(kGood) + "gait: {}\n").find("wbc.gait: unknown key"), std::string::npos);
}

TEST(TrotConfig, ErrorsNameTheFieldAndGoodValuesLoad) {
  const auto error_of = [](const std::string& yaml) {
    return errors_of(yaml, "gait", [](const Field& f) { return params::read_trot_params(f); });
  };
  EXPECT_EQ(error_of("{duty_factor: 0.4}"), "gait.duty_factor: must be in [0.5, 0.95], got 0.4 (line 1)");
  EXPECT_NE(error_of("{step_frequency: .inf}").find("gait.step_frequency: must be a finite number"), std::string::npos);
  EXPECT_NE(error_of("{step_hieght: 0.1}").find("gait.step_hieght: unknown key"), std::string::npos);
  Errors errors;
  const springbok::gait::TrotParams p =
      params::read_trot_params(Field(YAML::Load("{step_frequency: 1.8, duty_factor: 0.55}"), "gait", errors));
  EXPECT_TRUE(errors.empty());
  EXPECT_EQ(p.step_frequency_hz, 1.8);
  EXPECT_EQ(p.duty_factor, 0.55);
  EXPECT_EQ(p.step_height_m, springbok::gait::TrotParams{}.step_height_m);
}

TEST(PushSteppingConfig, ErrorsNameTheFieldAndGoodValuesLoad) {
  const auto error_of = [](const std::string& yaml) {
    return errors_of(yaml, "push_stepping", [](const Field& f) { return params::read_push_stepping(f); });
  };
  EXPECT_EQ(error_of("{delay: 2}"), "push_stepping.delay: must be in [0, 1], got 2 (line 1)");
  EXPECT_EQ(error_of("{leg_torque_ratio: -0.1}"), "push_stepping.leg_torque_ratio: must be in [0, 2], got -0.1 (line 1)");
  EXPECT_NE(error_of("{enabled: no}").find("push_stepping.enabled: must be true or false"), std::string::npos);
  EXPECT_NE(error_of("{trigger_inside: .nan}").find("push_stepping.trigger_inside: must be a finite number"),
            std::string::npos);
  EXPECT_NE(error_of("{settle_speed: 0.1}").find("push_stepping.settle_speed: unknown key"), std::string::npos);
  Errors errors;
  const springbok::control::PushStepping p = params::read_push_stepping(
      Field(YAML::Load("{enabled: false, trigger_inside: 0.01, unloaded_within: 20, leg_torque_ratio: 0.9, velocity_gain: 0.3, "
                       "settle_drift: 0.1}"),
            "push_stepping", errors));
  EXPECT_TRUE(errors.empty()) << errors.joined();
  EXPECT_FALSE(p.enabled);
  EXPECT_EQ(p.trigger_inside_m, 0.01);
  EXPECT_EQ(p.unloaded_within_n, 20.0);
  EXPECT_EQ(p.leg_torque_ratio, 0.9);
  EXPECT_EQ(p.velocity_gain_s, 0.3);
  EXPECT_EQ(p.settle_drift_m, 0.1);
  EXPECT_EQ(p.delay_s, springbok::control::PushStepping{}.delay_s);
}

// Walking: velocity: [v_x, v_y, yaw_rate] or the three keys, within what the trot is built for.
TEST(TrotConfig, TheCommandedVelocityIsOneListOrThreeKeys) {
  const auto error_of = [](const std::string& yaml) {
    return errors_of(yaml, "gait", [](const Field& f) { return params::read_trot_params(f); });
  };
  Errors errors;
  const springbok::gait::TrotParams p =
      params::read_trot_params(Field(YAML::Load("{velocity: [0.4, -0.1, 0.25]}"), "gait", errors));
  EXPECT_TRUE(errors.empty()) << errors.joined();
  EXPECT_EQ(p.velocity_x_m_s, 0.4);
  EXPECT_EQ(p.velocity_y_m_s, -0.1);
  EXPECT_EQ(p.yaw_rate_rad_s, 0.25);
  EXPECT_EQ(error_of("{velocity: [0.8, 0, 0]}"), "gait.velocity[0]: must be in [-0.5, 0.5], got 0.8 (line 1)");
  EXPECT_EQ(error_of("{velocity: [0, 0.3, 0]}"), "gait.velocity[1]: must be in [-0.2, 0.2], got 0.3 (line 1)");
  EXPECT_NE(error_of("{velocity: [0.1, 0]}").find("gait.velocity: must be a list of 3"), std::string::npos);
  EXPECT_NE(error_of("{velocity: [0.1, 0, 0], yaw_rate: 0.1}").find("gait.velocity: give either"), std::string::npos);
  EXPECT_EQ(error_of("{yaw_rate: -0.6}"), "gait.yaw_rate: must be in [-0.5, 0.5], got -0.6 (line 1)");
  // A schedule is the simulation tool's (a scenario's): elsewhere it is an unknown key.
  EXPECT_NE(error_of("{velocity_schedule: []}").find("gait.velocity_schedule: unknown key"), std::string::npos);
  Errors with_schedule;
  (void)params::read_trot_params(Field(YAML::Load("{velocity_schedule: []}"), "gait", with_schedule),
                                 params::WithVelocitySchedule::yes);
  EXPECT_TRUE(with_schedule.empty()) << with_schedule.joined();
}

TEST(EstimatorConfig, ErrorsNameTheFieldAndGoodValuesLoad) {
  const auto error_of = [](const std::string& yaml) {
    return errors_of(yaml, "estimator", [](const Field& f) { return params::read_estimator_params(f); });
  };
  EXPECT_NE(error_of("{filter: complementary, velocity_gain: -1}").find("estimator.velocity_gain: must be in"), std::string::npos);
  EXPECT_NE(error_of("{foot_radius: .nan}").find("estimator.foot_radius: must be a finite number"), std::string::npos);
  EXPECT_NE(error_of("{velocity_gian: 3}").find("estimator.velocity_gian: unknown key"), std::string::npos);
  EXPECT_EQ(error_of("{filter: complementary, use_accelerometer: yes}"), "estimator.use_accelerometer: must be true or false, got 'yes' (line 1)");
  EXPECT_EQ(error_of("{filter: complementary, velocity_gain: 20, use_accelerometer: false}"), "(no error)");
  Errors errors;
  const springbok::est::EstimatorParams p =
      params::read_estimator_params(Field(YAML::Load("{filter: complementary, velocity_gain: 20, position_gain: 0}"), "estimator", errors));
  EXPECT_EQ(p.velocity_gain_per_s, 20.0);
  EXPECT_EQ(p.position_gain_per_s, 0.0);
  // The position-aided tilt is retired: its keys are refused for either filter, saying so.
  EXPECT_EQ(error_of("{filter: complementary, tilt_gain: 0.5}"),
            "estimator.tilt_gain: retired with the complementary filter's tilt aid: use filter ekf (line 1)");
  EXPECT_NE(error_of("{filter: ekf, tilt_window: 0.3}").find("estimator.tilt_window: retired"), std::string::npos);
  // filter: ekf, the default, with its own keys; a key of the other filter is refused, naming it.
  EXPECT_EQ(params::read_estimator_params(Field(YAML::Load("{}"), "estimator", errors)).filter,
            springbok::est::BaseFilter::ekf);
  EXPECT_EQ(error_of("{velocity_gain: 30}"),
            "estimator.velocity_gain: only for filter complementary (the filter is ekf, the default) (line 1)");
  EXPECT_NE(error_of("{filter: ekf, position_gain: 1}").find("estimator.position_gain: only for filter complementary"),
            std::string::npos);
  EXPECT_NE(error_of("{filter: complementary, ekf: {slip_gate_chi2: 20}}").find("estimator.ekf: only for filter ekf"),
            std::string::npos);
  EXPECT_NE(error_of("{filter: kalman}").find("estimator.filter"), std::string::npos);
  EXPECT_NE(error_of("{filter: ekf, ekf: {gyro_noise_density: -1}}").find("estimator.ekf.gyro_noise_density: must be in"),
            std::string::npos);
  EXPECT_NE(error_of("{ekf: {slip_gate: 3}}").find("estimator.ekf.slip_gate: unknown key"), std::string::npos);
  EXPECT_NE(error_of("{ekf: {use_ground: 1}}").find("estimator.ekf.use_ground: must be true or false"), std::string::npos);
  EXPECT_NE(error_of("{ekf: {use_leg_velocity: on}}").find("estimator.ekf.use_leg_velocity: must be true or false"),
            std::string::npos);
  EXPECT_NE(error_of("{ekf: {leg_velocity_std: 0}}").find("estimator.ekf.leg_velocity_std: must be in"), std::string::npos);
  EXPECT_NE(error_of("{ekf: {encoder_rate_std: .nan}}").find("estimator.ekf.encoder_rate_std"), std::string::npos);
  const springbok::est::EstimatorParams ekf = params::read_estimator_params(
      Field(YAML::Load("{filter: ekf, ekf: {gyro_noise_density: 2.4e-4, slip_gate_chi2: 30, encoder_std: 1e-3, "
                       "use_leg_velocity: false, encoder_rate_std: 0.08, leg_velocity_std: 0.02}}"),
            "estimator", errors));
  EXPECT_TRUE(errors.empty()) << errors.joined();
  EXPECT_EQ(ekf.filter, springbok::est::BaseFilter::ekf);
  EXPECT_EQ(ekf.ekf.gyro_noise_rad_s_per_sqrt_hz, 2.4e-4);
  EXPECT_EQ(ekf.ekf.slip_gate_chi2, 30.0);
  EXPECT_EQ(ekf.encoder_std_rad, 1e-3);
  EXPECT_FALSE(ekf.ekf.use_leg_velocity);
  EXPECT_EQ(ekf.encoder_rate_std_rad_s, 0.08);
  EXPECT_EQ(ekf.ekf.leg_velocity_std_m_s, 0.02);
}

}  // namespace
