#include "springbok/app/config.hpp"

#include <sys/un.h>

#include <initializer_list>
#include <string_view>

#include "springbok/yaml/reader.hpp"
#include "springbok/params/controller_params.hpp"

namespace springbok::app {
namespace {

using yaml::Field;

// Every key of the app's sections is required (the shipped file states them all).
Field need(const Field& map, std::string_view key) {
  const Field f = map[key];
  f.require();
  return f;
}

// {legs: x, arm: y} -> per joint
void legs_arm(const Field& f, double lo, double hi, VecNj& out) {
  if (!f.present() || !f.allow_only({"legs", "arm"})) return;
  double legs = 0.0, arm = 0.0;
  if (need(f, "legs").number(legs, lo, hi)) out.head<kFirstArmJoint>().setConstant(legs);
  if (need(f, "arm").number(arm, lo, hi)) out.tail<kArmJoints>().setConstant(arm);
}

void gains(const Field& f, JointGains& out) {
  if (!f.present() || !f.allow_only({"kp_legs", "kd_legs", "kp_arm", "kd_arm"})) return;
  double v = 0.0;
  if (need(f, "kp_legs").number(v, 0.0, 5000.0)) out.kp_nm_per_rad.head<kFirstArmJoint>().setConstant(v);
  if (need(f, "kd_legs").number(v, 0.0, 500.0)) out.kd_nms_per_rad.head<kFirstArmJoint>().setConstant(v);
  if (need(f, "kp_arm").number(v, 0.0, 1000.0)) out.kp_nm_per_rad.tail<kArmJoints>().setConstant(v);
  if (need(f, "kd_arm").number(v, 0.0, 100.0)) out.kd_nms_per_rad.tail<kArmJoints>().setConstant(v);
}

// A required section that must be a map: false when absent or not a map (the error is there).
bool section(const Field& f, std::initializer_list<std::string_view> keys) {
  return f.require() && f.allow_only(keys) && f.is_map();
}

}  // namespace

AppConfig read_config(const Field& root) {
  AppConfig c;
  if (!root.present() || root.node().IsNull()) {
    root.fail("empty document");
    return c;
  }
  if (!root.allow_only({"loop", "rt", "safety", "gains", "control", "operator", "log", "telemetry", "recorder", "can"})) return c;
  c.has_can_section = root["can"].present();

  if (const Field n = root["loop"]; section(n, {"rate_hz", "warmup_ticks"})) {
    need(n, "rate_hz").integer(c.rate_hz, 100, 4000);
    need(n, "warmup_ticks").integer(c.warmup_ticks, 0, 100000);
  }
  if (const Field n = root["rt"];
      section(n, {"enabled", "require", "priority", "cpu", "lock_memory", "prefault_heap_mib", "cpu_dma_latency"})) {
    need(n, "enabled").boolean(c.rt.enabled);
    need(n, "require").boolean(c.rt.require);
    need(n, "priority").integer(c.rt.priority, 1, 98);
    need(n, "cpu").integer(c.rt.cpu, -1, 1023);
    need(n, "lock_memory").boolean(c.rt.lock_memory);
    std::size_t heap_mib = 0;
    if (need(n, "prefault_heap_mib").integer(heap_mib, 0, 4096)) c.rt.prefault_heap_bytes = heap_mib << 20;
    need(n, "cpu_dma_latency").boolean(c.rt.hold_cpu_dma_latency);
  }
  if (const Field n = root["safety"];
      section(n, {"overrun_streak", "overrun_rate_per_s", "hal_watchdog_ticks", "qp_failure_streak", "limit_margin_rad",
                  "reset_max_speed_rad_s", "damping_nms_per_rad", "idle_damping_nms_per_rad"})) {
    need(n, "overrun_streak").integer(c.safety.overrun_streak_limit, 1, 1000);
    need(n, "overrun_rate_per_s").integer(c.safety.overrun_rate_limit, 1, 4000);
    need(n, "hal_watchdog_ticks").integer(c.safety.hal_watchdog_ticks, 1, 1000);
    need(n, "qp_failure_streak").integer(c.safety.qp_failure_streak_limit, 1, 1000);
    need(n, "limit_margin_rad").number(c.safety.limit_margin_rad, 0.0, 0.5);
    need(n, "reset_max_speed_rad_s").number(c.safety.reset_max_speed_rad_s, 0.0, 1.0);
    legs_arm(need(n, "damping_nms_per_rad"), 0.0, 200.0, c.safety.damping_nms_per_rad);
    // D_start (CAN.md 4.2 step 5), > 0: without it the powered robot drops while idle.
    legs_arm(need(n, "idle_damping_nms_per_rad"), 0.1, 200.0, c.safety.idle_damping_nms_per_rad);
  }
  if (const Field n = root["gains"];
      section(n, {"stand", "control", "stand_up_duration_s", "stand_tolerance_rad", "stand_posture_rad",
                  "stand_feed_forward"})) {
    gains(need(n, "stand"), c.stand_gains);
    if (int feed_forward = 0; n["stand_feed_forward"].choice(feed_forward, {"none", "weight"})) {
      c.stand_weight_feed_forward = feed_forward == 1;
    }
    gains(need(n, "control"), c.control_gains);
    need(n, "stand_up_duration_s").number(c.stand_up_duration_s, 0.1, 60.0);
    need(n, "stand_tolerance_rad").number(c.stand_tolerance_rad, 0.001, 0.5);
    const Field posture = need(n, "stand_posture_rad");
    if (posture.vector<kNj>(c.stand_posture_rad, -6.3, 6.3)) {
      const safety::JointLimits limits = safety::joint_limits_from_model();
      for (int j = 0; j < kNj; ++j) {
        const double q = c.stand_posture_rad[j];
        if (limits.bounded[static_cast<std::size_t>(j)] && (q < limits.lower_rad[j] || q > limits.upper_rad[j])) {
          posture[static_cast<std::size_t>(j)].fail(
              "outside the joint limits of " + std::string(robot::kJoints[static_cast<std::size_t>(j)].name) + " [" +
              yaml::show(limits.lower_rad[j]) + ", " + yaml::show(limits.upper_rad[j]) + "]: " + yaml::show(q));
        }
      }
    }
  }
  if (const Field n = root["control"]; section(n, {"controller", "wbc", "estimator", "gait", "push_stepping"})) {
    int kind = 0;
    if (need(n, "controller").choice(kind, {"wbc", "joint_pd"})) {
      c.control_mode = kind == 0 ? ControlModeKind::wbc : ControlModeKind::joint_pd;
    }
    if (c.control_mode == ControlModeKind::wbc) {
      c.safety.control_needs_imu = true;       // the estimator's orientation and rate
      c.safety.control_needs_wrist_ft = true;  // F_e, what the template renders
      if (!n["wbc"].present()) n["wbc"].fail("missing (control.controller is wbc)");
    }
    if (n["wbc"].present()) c.control.wbc = params::read_wbc_params(n["wbc"]);
    // optional: every key keeps its default
    if (n["estimator"].present()) c.control.estimator = params::read_estimator_params(n["estimator"]);
    // optional: the trot the control mode engages with (the scenario's gait: map); absent: stand
    if (n["gait"].present()) {
      c.control.gait.kind = control::GaitKind::trot;
      c.control.gait.trot = params::read_trot_params(n["gait"]);
    }
    // optional: stepping to catch a push standing cannot hold (on by default)
    if (n["push_stepping"].present()) c.control.push_stepping = params::read_push_stepping(n["push_stepping"]);
  }
  if (const Field n = root["operator"]; section(n, {"socket"}) && need(n, "socket").text(c.operator_socket)) {
    constexpr std::size_t kMaxSocketPath = sizeof(sockaddr_un::sun_path) - 1;  // what bind(2) takes
    if (c.operator_socket.size() > kMaxSocketPath) {
      n["socket"].fail("must be at most " + std::to_string(kMaxSocketPath) + " bytes (a Unix socket path), got " +
                       std::to_string(c.operator_socket.size()));
    }
  }
  if (const Field n = root["log"]; section(n, {"path"})) need(n, "path").text(c.log_path);
  c.telemetry = read_telemetry_config(root["telemetry"]);
  c.recorder = read_recorder_config(root["recorder"]);
  return c;
}

namespace {
ConfigResult from_document(const yaml::Document& doc) {
  ConfigResult result;
  if (!doc.ok) {
    result.errors.push_back(doc.error);
    return result;
  }
  yaml::Errors errors;
  result.config = read_config(Field(doc.root, "", errors));
  result.errors = errors.lines();
  result.ok = errors.empty();
  return result;
}
}  // namespace

ConfigResult load_config_text(const std::string& yaml_text) { return from_document(yaml::parse_text(yaml_text)); }

ConfigResult load_config_file(const std::string& path) {
  ConfigResult result = from_document(yaml::parse_file(path));
  for (auto& e : result.errors) {
    if (e.rfind(path, 0) != 0) e = path + ": " + e;
  }
  return result;
}

}  // namespace springbok::app
