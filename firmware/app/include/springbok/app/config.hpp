// The robot configuration (YAML): loop rate, real-time settings, safety
// thresholds, gains, the operator socket and the log. Every field is required;
// an unknown key, a missing one, a wrong type, a value out of range or a NaN
// is an error that names the field and its line (e.g. "rt.priority: must be in [1, 98], got 99 (line 9)").
// The `can:` section belongs to the SocketCAN backend, which validates it.
// Start-up code: allocates, never runs on the tick path.
#pragma once

#include <string>
#include <vector>

#include "springbok/app/flight_recorder.hpp"
#include "springbok/app/telemetry.hpp"
#include "springbok/control/robot_controller.hpp"
#include "springbok/estimation/base_estimator.hpp"
#include "springbok/model/model.hpp"
#include "springbok/rt/realtime.hpp"
#include "springbok/safety/supervisor.hpp"
#include "springbok/wbc/whole_body_controller.hpp"

namespace springbok::yaml {
class Field;
}

namespace springbok::app {

struct JointGains {
  VecNj kp_nm_per_rad = VecNj::Zero();
  VecNj kd_nms_per_rad = VecNj::Zero();
};

// The controller of the control mode (control.controller).
enum class ControlModeKind : std::uint8_t {
  wbc,       // the whole-body controller on the estimated base state
  joint_pd,  // hold the stand posture with gains.control (bring-up without an IMU)
};

struct AppConfig {
  int rate_hz = 1000;
  int warmup_ticks = 500;                // non-actuating ticks before the statistics reset
  rt::RtConfig rt;
  safety::SupervisorConfig safety;
  JointGains stand_gains;                // stand-up and stand (joint PD to the stand posture)
  double stand_up_duration_s = 3.0;
  double stand_tolerance_rad = 0.05;     // stand-up is done when every leg joint is this close
  VecNj stand_posture_rad = VecNj::Zero();
  // gains.stand_feed_forward: weight (stand-up and stand carry the robot's weight as the
  // drives' feed-forward: ModeController) or none (the PD alone; the default).
  bool stand_weight_feed_forward = false;
  JointGains control_gains;              // control mode with control.controller = joint_pd
  ControlModeKind control_mode = ControlModeKind::wbc;
  // The control mode's controller: control.wbc (controller_params.hpp's YAML), control.estimator
  // (every key optional), control.gait (optional trot map: the gait the control mode engages
  // with), control.push_stepping (optional); its tare_samples are the backend's
  // (can.sensors.wrist_ft.tare_samples).
  control::ControlParams control;
  std::string operator_socket;
  std::string log_path;                  // "-" = standard error
  TelemetryConfig telemetry;             // telemetry: (live UDP stream; telemetry.hpp)
  RecorderConfig recorder;               // recorder: (the flight recorder; flight_recorder.hpp)
  bool has_can_section = false;
};

struct ConfigResult {
  bool ok = false;
  AppConfig config;
  std::vector<std::string> errors;  // one line per problem, naming the field
};

// Never throws.
ConfigResult load_config_text(const std::string& yaml_text);
ConfigResult load_config_file(const std::string& path);
// The app's sections of a document read with springbok::yaml (the `can:` section is the
// CAN backend's: can::read_can_config on the same document; springbok.yaml is read once).
AppConfig read_config(const yaml::Field& root);

}  // namespace springbok::app
