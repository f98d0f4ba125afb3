// A springbok-sim scenario: what to simulate, with which controller, which
// pushes, for how long. Loaded from YAML (schema: tools/scenarios/README.md)
// and validated at start-up: every error names the offending field.
#pragma once

#include <stdexcept>
#include <string>
#include <vector>

#include <yaml-cpp/yaml.h>

#include "springbok/yaml/reader.hpp"
#include "springbok/sim_hal/bullet_robot.hpp"

namespace springbok::simtool {

struct ScenarioError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

struct NamedWrench {
  std::string frame;
  sim::ExternalWrench wrench;
};

struct Scenario {
  double duration_s = 0.0;
  sim::SimConfig sim;
  std::string sensors = "ideal";      // the sensor model's name for the summary (sim.sensors.preset)
  bool has_feet_clearance = false;
  double feet_clearance_m = 0.0;
  std::string controller_type;        // stand | damping | none
  YAML::Node controller_params;       // read by the controller's adapter (make_controller)
  int controller_params_line = 0;
  double controller_settle_s = 0.0;   // wbc: stand controller for this long first
  // wbc: before the operator's start, the firmware idles this long with the robot held still
  // (sim::BulletRobot::hold_still: the sensors sample it, the world and its clock do not run):
  // the estimator's start-up gyro calibration, as a robot lying still before it is started.
  double controller_still_start_s = 10.0;
  std::vector<NamedWrench> wrenches;
  double fall_height_m = 0.25;
};

// Throws ScenarioError: every problem, one line each, "<file>: <field path>: <what> (line N)".
Scenario load_scenario(const std::string& path);

// With `initial.feet_clearance_m`: moves the initial base height so that the lowest
// foot sphere is that far above the ground. Throws std::runtime_error if Bullet fails.
void apply_feet_clearance(Scenario& s);

// Throws ScenarioError with every line of `errors`, each prefixed with `path` (none: returns).
void refuse_if_any(const yaml::Errors& errors, const std::string& path);

}  // namespace springbok::simtool
