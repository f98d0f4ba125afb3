#include "springbok/wbc/wbc_config.hpp"

namespace springbok::wbc {
namespace {

constexpr double kTiny = 1e-6;

void read_template(const config::Fields& f, TemplateParams& t) {
  f.allow_only({"base", "ee"});
  const config::Fields base = f.required_map("base");
  const config::Fields ee = f.required_map("ee");
  for (const auto* part : {&base, &ee}) part->allow_only({"mass", "damping", "stiffness"});
  t.mass_base_kg = base.required_vector<3>("mass", kTiny, 1e5);
  t.damping_base_ns_per_m = base.required_vector<3>("damping", 0.0, 1e6);
  t.stiffness_base_n_per_m = base.required_vector<3>("stiffness", kTiny, 1e7);
  t.mass_ee_kg = ee.required_vector<3>("mass", kTiny, 1e4);
  t.damping_ee_ns_per_m = ee.required_vector<3>("damping", 0.0, 1e6);
  t.stiffness_ee_n_per_m = ee.required_vector<3>("stiffness", kTiny, 1e7);
}

}  // namespace

WbcParams read_wbc_params(const config::Fields& f) {
  f.allow_only({"template", "base_orientation", "arm", "weights", "contact", "limits", "swing"});
  WbcParams p;
  read_template(f.required_map("template"), p.template_params);

  const config::Fields rot = f.map("base_orientation");
  rot.allow_only({"kp", "kd", "inertia"});
  p.kr_nm_per_rad = rot.vector<3>("kp", p.kr_nm_per_rad, 0.0, 1e5);
  p.dr_nms_per_rad = rot.vector<3>("kd", p.dr_nms_per_rad, 0.0, 1e4);
  if (rot.has("inertia") && !(rot.child("inertia").IsScalar() && rot.child("inertia").Scalar() == "auto")) {
    p.base_rot_inertia_kgm2 = rot.vector<3>("inertia", p.base_rot_inertia_kgm2, kTiny, 1e4);
  }

  const config::Fields arm = f.map("arm");
  arm.allow_only({"posture_kp", "posture_kd", "posture", "pinv_lambda0", "manipulability_threshold"});
  p.posture_kp_per_s2 = arm.number("posture_kp", p.posture_kp_per_s2, 0.0, 1e5);
  p.posture_kd_per_s = arm.number("posture_kd", p.posture_kd_per_s, 0.0, 1e4);
  if (arm.has("posture") && !(arm.child("posture").IsScalar() && arm.child("posture").Scalar() == "current")) {
    p.arm_posture_rad = arm.vector<kArmDofs>("posture", p.arm_posture_rad, -2 * M_PI, 2 * M_PI);
    p.pin_arm_posture = true;
  }
  p.pinv_lambda0 = arm.number("pinv_lambda0", p.pinv_lambda0, 0.0, 10.0);
  p.manipulability_threshold = arm.number("manipulability_threshold", p.manipulability_threshold, 0.0, 10.0);

  const config::Fields w = f.map("weights");
  w.allow_only({"base_force", "base_torque", "arm", "reg_acceleration", "reg_force", "reg_slack"});
  p.weight_base_force = w.number("base_force", p.weight_base_force, kTiny, 1e6);
  p.weight_base_torque = w.number("base_torque", p.weight_base_torque, kTiny, 1e6);
  p.weight_arm = w.number("arm", p.weight_arm, kTiny, 1e8);
  p.reg_acceleration = w.number("reg_acceleration", p.reg_acceleration, 1e-12, 1e3);
  p.reg_force = w.number("reg_force", p.reg_force, 1e-12, 1e3);
  p.reg_slack = w.number("reg_slack", p.reg_slack, 1e-6, 1e9);

  const config::Fields c = f.map("contact");
  c.allow_only({"friction_mu", "normal_force_min", "normal_force_max", "foot_radius"});
  p.foot_contact_radius_m = c.number("foot_radius", p.foot_contact_radius_m, 0.0, 0.5);
  p.friction_mu = c.number("friction_mu", p.friction_mu, kTiny, 5.0);
  p.normal_force_min_n = c.number("normal_force_min", p.normal_force_min_n, 0.0, 1e4);
  p.normal_force_max_n = c.number("normal_force_max", p.normal_force_max_n, 0.0, 1e5);
  if (p.normal_force_max_n <= p.normal_force_min_n) {
    config::fail(c.field("normal_force_max"), "must be above contact.normal_force_min");
  }

  const config::Fields lim = f.map("limits");
  lim.allow_only({"joint_horizon_s", "torque_scale"});
  p.joint_limit_horizon_s = lim.number("joint_horizon_s", p.joint_limit_horizon_s, 1e-3, 10.0);
  p.torque_limit_scale = lim.number("torque_scale", p.torque_limit_scale, kTiny, 1.0);

  const config::Fields sw = f.map("swing");
  sw.allow_only({"kp", "kd"});
  p.swing_kp_per_s2 = sw.vector<3>("kp", p.swing_kp_per_s2, 0.0, 1e5);
  p.swing_kd_per_s = sw.vector<3>("kd", p.swing_kd_per_s, 0.0, 1e4);
  return p;
}

}  // namespace springbok::wbc
