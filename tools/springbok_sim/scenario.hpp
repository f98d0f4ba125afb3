// A springbok-sim scenario: what to simulate, with which controller, which
// pushes, for how long. Loaded from YAML (schema: tools/scenarios/README.md)
// and validated at start-up: every error names the offending field.
#pragma once

#include <stdexcept>
#include <string>
#include <vector>

#include <yaml-cpp/yaml.h>

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
  bool has_feet_clearance = false;
  double feet_clearance_m = 0.0;
  std::string controller_type;        // stand | damping | none
  YAML::Node controller_params;       // opaque here; the controller validates it
  double controller_settle_s = 0.0;   // wbc: stand controller for this long first
  std::vector<NamedWrench> wrenches;
  double fall_height_m = 0.25;
};

// Throws ScenarioError("<file>: <field path>: <what>").
Scenario load_scenario(const std::string& path);

// With `initial.feet_clearance_m`: moves the initial base height so that the lowest
// foot sphere is that far above the ground. Throws std::runtime_error if Bullet fails.
void apply_feet_clearance(Scenario& s);

// Field readers with path-naming errors, for the controllers' parameter maps.
class Fields {
 public:
  Fields(const YAML::Node& map, std::string path);  // map may be undefined/null: all optional
  void allow_only(std::initializer_list<const char*> keys) const;
  double number(const char* key, double fallback, double lo, double hi) const;
  double required_number(const char* key, double lo, double hi) const;
  bool has(const char* key) const;
  // The value at key, or an empty (null) node when absent.
  YAML::Node child(const char* key) const;
  const YAML::Node& node() const { return map_; }
  std::string field(const char* key) const { return path_.empty() ? key : path_ + "." + key; }

 private:
  YAML::Node map_;
  std::string path_;
};

double as_number(const YAML::Node& node, const std::string& field, double lo, double hi);

}  // namespace springbok::simtool
