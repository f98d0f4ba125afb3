#include "springbok/params/controller_params.hpp"

#include <array>
#include <cmath>
#include <limits>
#include <span>
#include <string_view>

namespace springbok::params {
namespace {

using yaml::Field;

constexpr double kTiny = 1e-6;

// A number or [x, y, z].
bool triple(const Field& f, Vec3& out, double lo, double hi) { return f.vector<3>(out, lo, hi, true); }

// A template part, a number or [x, y, z], within the range live tuning also checks.
bool template_part(const Field& f, Vec3& out, control::TuningRequest::Part part) {
  const control::TuningRange& range = control::kTemplateRanges[part];
  return triple(f, out, range.lo, range.hi);
}

// A template's two bodies, `base: {..}` and `ee: {..}`, each with exactly `keys`, all required.
struct TwoBodies {
  Field base, ee;
};
TwoBodies two_bodies(const Field& f, const std::array<std::string_view, 3>& keys) {
  f.allow_only({"base", "ee"});
  TwoBodies parts{f["base"], f["ee"]};
  for (const Field* part : {&parts.base, &parts.ee}) {
    if (!part->require()) continue;
    part->allow_only(keys);
    for (const std::string_view key : keys) (*part)[key].require();
  }
  return parts;
}

void read_template(const Field& f, wbc::TemplateParams& t) {
  using P = control::TuningRequest;
  const auto [base, ee] = two_bodies(f, {"mass", "damping", "stiffness"});
  template_part(base["mass"], t.mass_base_kg, P::base_mass);
  template_part(base["damping"], t.damping_base_ns_per_m, P::base_damping);
  template_part(base["stiffness"], t.stiffness_base_n_per_m, P::base_stiffness);
  template_part(ee["mass"], t.mass_ee_kg, P::ee_mass);
  template_part(ee["damping"], t.damping_ee_ns_per_m, P::ee_damping);
  template_part(ee["stiffness"], t.stiffness_ee_n_per_m, P::ee_stiffness);
}

// `word` (e.g. auto, current) or what `read` takes; true when `read` took a value.
template <class Read>
bool word_or(const Field& f, const char* word, Read&& read) {
  if (f.is_scalar() && f.node().Scalar() == word) return false;
  return read();
}

// rotational_template: {base: {inertia: auto | I, damping, stiffness}, ee: {inertia, damping, stiffness}};
// each a number or [x, y, z] (kg m^2, N m s/rad, N m/rad). Present: the template is on.
void read_rotational_template(const Field& f, wbc::RotationalTemplateParams& t) {
  using P = control::TuningRequest;
  const auto [base, ee] = two_bodies(f, {"inertia", "damping", "stiffness"});
  // The base's inertia is not tuned live (the WBC resolves `auto` at engagement).
  if (!word_or(base["inertia"], "auto", [&] { return triple(base["inertia"], t.inertia_base_kgm2, kTiny, 1e4); })) {
    t.inertia_base_kgm2.setZero();  // the composite inertia at the reference pose
  }
  template_part(base["damping"], t.damping_base_nms_per_rad, P::rot_base_damping);
  template_part(base["stiffness"], t.stiffness_base_nm_per_rad, P::rot_base_stiffness);
  template_part(ee["inertia"], t.inertia_ee_kgm2, P::rot_ee_inertia);
  template_part(ee["damping"], t.damping_ee_nms_per_rad, P::rot_ee_damping);
  template_part(ee["stiffness"], t.stiffness_ee_nm_per_rad, P::rot_ee_stiffness);
}

}  // namespace

wbc::WbcParams read_wbc_params(const Field& f, WithControllerParts parts) {
  if (parts == WithControllerParts::yes) {
    f.allow_only({"template", "rotational_template", "base_orientation", "arm", "weights", "contact", "limits", "swing",
                  "joint_friction", "estimator", "gait", "push_stepping", "hand_trajectory", "state_source"});
  } else {
    f.allow_only({"template", "rotational_template", "base_orientation", "arm", "weights", "contact", "limits", "swing",
                  "joint_friction"});
  }
  wbc::WbcParams p;
  if (f["template"].present()) read_template(f["template"], p.template_params);
  if (f["rotational_template"].present()) {
    p.rotational_template_enabled = true;
    read_rotational_template(f["rotational_template"], p.rotational_template);
  }

  const Field rot = f["base_orientation"];
  rot.allow_only({"kp", "kd", "inertia"});
  triple(rot["kp"], p.kr_nm_per_rad, 0.0, 1e5);
  triple(rot["kd"], p.dr_nms_per_rad, 0.0, 1e4);
  word_or(rot["inertia"], "auto", [&] { return triple(rot["inertia"], p.base_rot_inertia_kgm2, kTiny, 1e4); });

  const Field arm = f["arm"];
  arm.allow_only({"posture_kp", "posture_kd", "posture", "pinv_lambda0", "manipulability_threshold",
                  "manipulability_threshold_6d", "max_acceleration", "max_angular_acceleration"});
  arm["posture_kp"].number(p.posture_kp_per_s2, 0.0, 1e5);
  arm["posture_kd"].number(p.posture_kd_per_s, 0.0, 1e4);
  if (word_or(arm["posture"], "current",
              [&] { return arm["posture"].vector<wbc::kArmDofs>(p.arm_posture_rad, -2 * M_PI, 2 * M_PI); })) {
    p.pin_arm_posture = true;
  }
  arm["pinv_lambda0"].number(p.pinv_lambda0, 0.0, 10.0);
  arm["manipulability_threshold"].number(p.manipulability_threshold, 0.0, 10.0);
  arm["manipulability_threshold_6d"].number(p.manipulability_threshold_6d, 0.0, 10.0);
  arm["max_angular_acceleration"].number(p.ee_angular_acceleration_limit_rad_s2, 1.0, 1e5);
  // A number [m/s^2], or `none`: the paper's unbounded task.
  const Field max_acc = arm["max_acceleration"];
  if (max_acc.is_scalar() && max_acc.node().Scalar() == "none") {
    p.ee_acceleration_limit_m_s2 = std::numeric_limits<double>::infinity();
  } else {
    max_acc.number(p.ee_acceleration_limit_m_s2, 1.0, 1e4);
  }

  const Field w = f["weights"];
  w.allow_only({"base_force", "base_torque", "arm", "reg_acceleration", "reg_force", "reg_slack"});
  w["base_force"].number(p.weight_base_force, kTiny, 1e6);
  w["base_torque"].number(p.weight_base_torque, kTiny, 1e6);
  w["arm"].number(p.weight_arm, kTiny, 1e8);
  w["reg_acceleration"].number(p.reg_acceleration, 1e-12, 1e3);
  w["reg_force"].number(p.reg_force, 1e-12, 1e3);
  w["reg_slack"].number(p.reg_slack, 1e-6, 1e9);

  const Field c = f["contact"];
  c.allow_only({"friction_mu", "normal_force_min", "normal_force_max", "foot_radius", "support_margin"});
  c["foot_radius"].number(p.foot_contact_radius_m, 0.0, 0.5);
  c["support_margin"].number(p.support_margin_m, 0.0, 0.5);
  c["friction_mu"].number(p.friction_mu, kTiny, 5.0);
  c["normal_force_min"].number(p.normal_force_min_n, 0.0, 1e4);
  c["normal_force_max"].number(p.normal_force_max_n, 0.0, 1e5);
  if (p.normal_force_max_n <= p.normal_force_min_n) c["normal_force_max"].fail("must be above contact.normal_force_min");

  const Field lim = f["limits"];
  lim.allow_only({"joint_horizon_s", "velocity_horizon_s", "velocity_scale", "torque_scale"});
  lim["joint_horizon_s"].number(p.joint_limit_horizon_s, 1e-3, 10.0);
  lim["velocity_horizon_s"].number(p.joint_velocity_horizon_s, 1e-3, 10.0);
  lim["velocity_scale"].number(p.joint_velocity_limit_scale, kTiny, 1.0);
  lim["torque_scale"].number(p.torque_limit_scale, kTiny, 1.0);

  const Field sw = f["swing"];
  sw.allow_only({"kp", "kd"});
  triple(sw["kp"], p.swing_kp_per_s2, 0.0, 1e5);
  triple(sw["kd"], p.swing_kd_per_s, 0.0, 1e4);

  // One number for every joint or one per joint (springbok::robot::kJoints' order).
  const Field fr = f["joint_friction"];
  fr.allow_only({"viscous"});
  fr["viscous"].vector<kNj>(p.joint_viscous_friction_nms_per_rad, 0.0, 100.0, true);
  return p;
}

est::EstimatorParams read_estimator_params(const Field& f) {
  f.allow_only({"filter", "velocity_gain", "position_gain", "foot_radius", "ground_height", "use_accelerometer",
                "tilt_gain", "tilt_window", "ekf"});
  est::EstimatorParams p;
  int filter = static_cast<int>(p.filter);
  if (f["filter"].choice(filter, {"complementary", "ekf"})) p.filter = static_cast<est::BaseFilter>(filter);
  // Each filter's own keys: one given for the other filter would be ignored.
  const bool ekf = p.filter == est::BaseFilter::ekf;
  // The complementary filter's position-aided tilt is retired: the EKF estimates the tilt from
  // the raw IMU (the CAN IMU without q_w included).
  for (const char* key : {"tilt_gain", "tilt_window"}) {
    if (f[key].present()) f[key].fail("retired with the complementary filter's tilt aid: use filter ekf");
  }
  for (const char* key : {"velocity_gain", "position_gain", "use_accelerometer"}) {
    if (ekf && f[key].present()) f[key].fail("only for filter complementary (the filter is ekf, the default)");
  }
  if (!ekf && f["ekf"].present()) f["ekf"].fail("only for filter ekf (the filter is complementary)");
  f["velocity_gain"].number(p.velocity_gain_per_s, 1e-3, 1e3);
  f["position_gain"].number(p.position_gain_per_s, 0.0, 1e3);
  f["foot_radius"].number(p.foot_radius_m, 0.0, 0.5);
  f["ground_height"].number(p.ground_height_m, -1e3, 1e3);
  f["use_accelerometer"].boolean(p.use_accelerometer);
  // filter ekf: the IMU's datasheet quantities, the feet's, the slip gate, the ground, the priors.
  const Field e = f["ekf"];
  if (e.present()) {
    e.allow_only({"gyro_noise_density", "accel_noise_density", "gyro_bias_walk", "accel_bias_walk", "foot_anchored_walk",
                  "slip_gate_chi2", "use_ground", "ground_std", "encoder_std", "kinematics_std", "use_leg_velocity",
                  "encoder_rate_std", "leg_velocity_std", "initial_gyro_bias_std", "initial_accel_bias_std"});
    est::EkfParams& k = p.ekf;
    e["gyro_noise_density"].number(k.gyro_noise_rad_s_per_sqrt_hz, 1e-7, 1.0);
    e["accel_noise_density"].number(k.accel_noise_m_s2_per_sqrt_hz, 1e-7, 10.0);
    e["gyro_bias_walk"].number(k.gyro_bias_walk_rad_s2_per_sqrt_hz, 0.0, 1.0);
    e["accel_bias_walk"].number(k.accel_bias_walk_m_s3_per_sqrt_hz, 0.0, 10.0);
    e["foot_anchored_walk"].number(k.foot_anchored_walk_m_s_per_sqrt_hz, 1e-6, 1.0);
    e["slip_gate_chi2"].number(k.slip_gate_chi2, 0.0, 1e6);
    e["use_ground"].boolean(k.use_ground);
    e["ground_std"].number(k.ground_std_m, 1e-5, 1.0);
    e["encoder_std"].number(p.encoder_std_rad, 0.0, 0.1);
    e["kinematics_std"].number(p.kinematics_std_m, 1e-5, 0.1);
    e["use_leg_velocity"].boolean(k.use_leg_velocity);
    e["encoder_rate_std"].number(p.encoder_rate_std_rad_s, 0.0, 10.0);
    e["leg_velocity_std"].number(k.leg_velocity_std_m_s, 1e-5, 1.0);
    e["initial_gyro_bias_std"].number(k.initial_gyro_bias_std_rad_s, 1e-6, 1.0);
    e["initial_accel_bias_std"].number(k.initial_accel_bias_std_m_s2, 1e-6, 10.0);
  }
  return p;
}

gait::TrotParams read_trot_params(const Field& f, WithVelocitySchedule schedule) {
  // The scenario's velocity_schedule (first: cut off where it is not allowed), [v_x, v_y, yaw rate] at once.
  std::array<std::string_view, gait::kTrotFields.size() + 2> keys{"velocity_schedule", "velocity"};
  for (std::size_t i = 0; i < gait::kTrotFields.size(); ++i) keys[i + 2] = gait::kTrotFields[i].key;
  f.allow_only(std::span<const std::string_view>(keys).subspan(schedule == WithVelocitySchedule::yes ? 0 : 1));
  gait::TrotParams p;
  for (const gait::TrotField& field : gait::kTrotFields) f[field.key].number(p.*field.member, field.lo, field.hi);
  const Field v = f["velocity"];
  if (v.present()) {
    if (f["velocity_x"].present() || f["velocity_y"].present() || f["yaw_rate"].present()) {
      v.fail("give either velocity or velocity_x / velocity_y / yaw_rate");
    } else {
      (void)read_walking_velocity(v, p);
    }
  }
  return p;
}

control::PushStepping read_push_stepping(const Field& f) {
  f.allow_only({"enabled", "trigger_inside", "unloaded_within", "leg_torque_ratio", "delay", "velocity_gain", "settle", "settle_drift",
                "settle_push_change"});
  control::PushStepping p;
  f["enabled"].boolean(p.enabled);
  f["trigger_inside"].number(p.trigger_inside_m, -0.5, 0.5);
  f["unloaded_within"].number(p.unloaded_within_n, 0.0, 1e4);
  f["leg_torque_ratio"].number(p.leg_torque_ratio, 0.0, 2.0);
  f["delay"].number(p.delay_s, 0.0, 1.0);
  f["settle"].number(p.settle_s, 0.0, 60.0);
  f["velocity_gain"].number(p.velocity_gain_s, 0.0, 1.0);
  f["settle_drift"].number(p.settle_drift_m, 0.0, 1.0);
  f["settle_push_change"].number(p.settle_push_change_n, 0.0, 1e4);
  return p;
}

bool read_walking_velocity(const Field& f, gait::TrotParams& p) {
  if (!f.expect_list(3)) return false;
  bool ok = true;
  for (std::size_t i = 0; i < 3; ++i) {  // velocity_x, velocity_y, yaw_rate: kTrotFields' last three
    const gait::TrotField& field = gait::kTrotFields[gait::kTrotFields.size() - 3 + i];
    ok = f[i].number(p.*field.member, field.lo, field.hi) && ok;
  }
  return ok;
}

}  // namespace springbok::params
