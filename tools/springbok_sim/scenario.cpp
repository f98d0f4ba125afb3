#include "scenario.hpp"

#include <cmath>
#include <fmt/format.h>

#include "springbok/wbc/stand_controller.hpp"

namespace springbok::simtool {
namespace {

[[noreturn]] void fail(const std::string& field, const std::string& what) {
  throw ScenarioError(fmt::format("{}: {}", field, what));
}

std::string kind_of(const YAML::Node& n) {
  switch (n.Type()) {
    case YAML::NodeType::Map: return "a map";
    case YAML::NodeType::Sequence: return "a list";
    case YAML::NodeType::Null: return "empty";
    default: return "'" + n.Scalar() + "'";
  }
}

bool as_bool(const YAML::Node& n, const std::string& field) {
  if (!n.IsScalar()) fail(field, "must be true or false, got " + kind_of(n));
  bool value = false;
  if (!YAML::convert<bool>::decode(n, value)) fail(field, "must be true or false, got " + kind_of(n));
  return value;
}

std::string as_string(const YAML::Node& n, const std::string& field) {
  if (!n.IsScalar()) fail(field, "must be a string, got " + kind_of(n));
  return n.Scalar();
}

template <int N>
Vec<N> as_vector(const YAML::Node& n, const std::string& field, double lo, double hi) {
  if (!n.IsSequence() || static_cast<int>(n.size()) != N) {
    fail(field, fmt::format("must be a list of {} numbers, got {}", N, kind_of(n)));
  }
  Vec<N> v;
  for (int i = 0; i < N; ++i) v[i] = as_number(n[i], fmt::format("{}[{}]", field, i), lo, hi);
  return v;
}

VecNj joint_positions(const YAML::Node& n, const std::string& field) {
  if (n.IsScalar() && n.Scalar() == "stance") return wbc::nominal_stance();
  if (!n.IsSequence()) fail(field, "must be 'stance' or a list of 19 angles, got " + kind_of(n));
  const VecNj q = as_vector<kNj>(n, field, -10.0, 10.0);
  for (int j = 0; j < kNj; ++j) {
    const auto& lim = robot::kJoints[j].limits;
    if (lim.bounded && (q[j] < lim.lower_rad || q[j] > lim.upper_rad)) {
      fail(fmt::format("{}[{}]", field, j), fmt::format("{} = {} is outside its limits [{}, {}]",
                                                        robot::kJoints[j].name, q[j], lim.lower_rad, lim.upper_rad));
    }
  }
  return q;
}

void read_sim(const Fields& f, sim::SimConfig& c) {
  f.allow_only({"step_s", "substeps", "solver_iterations", "gravity_m_s2", "ground_friction", "ground_restitution",
                "fixed_base", "imu", "latency"});
  c.step_s = f.number("step_s", c.step_s, 1e-5, 0.01);
  c.substeps = static_cast<int>(f.number("substeps", c.substeps, 1, 100));
  if (f.has("substeps") && f.child("substeps").as<double>() != c.substeps) fail(f.field("substeps"), "must be an integer");
  c.solver_iterations = static_cast<int>(f.number("solver_iterations", c.solver_iterations, 1, 1000));
  c.gravity_m_s2 = f.number("gravity_m_s2", c.gravity_m_s2, 0.0, 100.0);
  c.ground_friction = f.number("ground_friction", c.ground_friction, 0.0, 10.0);
  c.ground_restitution = f.number("ground_restitution", c.ground_restitution, 0.0, 1.0);
  if (f.has("fixed_base")) c.fixed_base = as_bool(f.child("fixed_base"), f.field("fixed_base"));
  const Fields imu(f.child("imu"), f.field("imu"));
  imu.allow_only({"gyro_noise_rad_s", "accel_noise_m_s2", "gyro_bias_rad_s", "accel_bias_m_s2", "seed"});
  c.imu.gyro_noise_rad_s = imu.number("gyro_noise_rad_s", 0.0, 0.0, 10.0);
  c.imu.accel_noise_m_s2 = imu.number("accel_noise_m_s2", 0.0, 0.0, 100.0);
  c.imu.gyro_bias_rad_s = imu.number("gyro_bias_rad_s", 0.0, 0.0, 10.0);
  c.imu.accel_bias_m_s2 = imu.number("accel_bias_m_s2", 0.0, 0.0, 100.0);
  c.imu.seed = static_cast<std::uint64_t>(imu.number("seed", 1.0, 0.0, 4294967295.0));
  const Fields latency(f.child("latency"), f.field("latency"));
  latency.allow_only({"joint_measurement_ticks", "sensor_measurement_ticks", "command_ticks"});
  const auto ticks = [&](const char* key) {
    const double t = latency.number(key, 0.0, 0.0, sim::Latency::kMaxTicks);
    if (t != std::floor(t)) fail(latency.field(key), "must be an integer");
    return static_cast<int>(t);
  };
  c.latency.joint_measurement_ticks = ticks("joint_measurement_ticks");
  c.latency.sensor_measurement_ticks = ticks("sensor_measurement_ticks");
  c.latency.command_ticks = ticks("command_ticks");
}

void read_initial(const Fields& f, Scenario& s) {
  f.allow_only({"base_position_m", "base_orientation_xyzw", "joint_positions_rad", "feet_clearance_m"});
  VecNq q = sim::SimConfig::default_q();
  q.head<3>() = Vec3(0.0, 0.0, 0.65);
  if (f.has("base_position_m")) q.head<3>() = as_vector<3>(f.child("base_position_m"), f.field("base_position_m"), -1e3, 1e3);
  if (f.has("base_orientation_xyzw")) {
    const Vec<4> quat = as_vector<4>(f.child("base_orientation_xyzw"), f.field("base_orientation_xyzw"), -1.0, 1.0);
    if (std::abs(quat.norm() - 1.0) > 1e-3) fail(f.field("base_orientation_xyzw"), "must be a unit quaternion (x y z w)");
    q.segment<4>(3) = quat.normalized();
  }
  q.tail<kNj>() = f.has("joint_positions_rad")
                      ? joint_positions(f.child("joint_positions_rad"), f.field("joint_positions_rad"))
                      : wbc::nominal_stance();
  if (f.has("feet_clearance_m")) {
    s.has_feet_clearance = true;
    s.feet_clearance_m = f.number("feet_clearance_m", 0.0, 0.0, 10.0);
  }
  s.sim.initial_q = q;
}

NamedWrench read_wrench(const YAML::Node& n, const std::string& path) {
  if (!n.IsMap()) fail(path, "must be a map, got " + kind_of(n));
  const Fields f(n, path);
  f.allow_only({"frame", "kind", "axis", "profile", "amplitude", "start_s", "duration_s", "start_frequency_hz",
                "end_frequency_hz"});
  NamedWrench out;
  if (!f.has("frame")) fail(f.field("frame"), "missing");
  out.frame = as_string(n["frame"], f.field("frame"));
  const auto frame = sim::find_frame(out.frame);
  if (!frame) fail(f.field("frame"), "unknown frame '" + out.frame + "' (a link name or a fixed frame of the model)");
  out.wrench.frame = *frame;
  const std::string kind = f.has("kind") ? as_string(n["kind"], f.field("kind")) : "force";
  if (kind == "force") {
    out.wrench.kind = sim::WrenchKind::force;
  } else if (kind == "torque") {
    out.wrench.kind = sim::WrenchKind::torque;
  } else {
    fail(f.field("kind"), "must be force or torque, got '" + kind + "'");
  }
  if (!f.has("axis")) fail(f.field("axis"), "missing");
  const Vec3 axis = as_vector<3>(n["axis"], f.field("axis"), -1e6, 1e6);
  if (axis.norm() < 1e-9) fail(f.field("axis"), "must not be zero");
  out.wrench.axis_world = axis.normalized();
  if (!f.has("profile")) fail(f.field("profile"), "missing");
  const std::string profile = as_string(n["profile"], f.field("profile"));
  auto& p = out.wrench.profile;
  if (profile == "step") {
    p.shape = sim::ProfileShape::step;
  } else if (profile == "constant") {
    p.shape = sim::ProfileShape::constant;
  } else if (profile == "chirp") {
    p.shape = sim::ProfileShape::chirp;
  } else if (profile == "impulse") {
    p.shape = sim::ProfileShape::impulse;
  } else {
    fail(f.field("profile"), "must be step, constant, chirp or impulse, got '" + profile + "'");
  }
  p.amplitude = f.required_number("amplitude", -1e5, 1e5);
  p.start_s = f.number("start_s", 0.0, 0.0, 1e6);
  const bool needs_duration = p.shape == sim::ProfileShape::chirp || p.shape == sim::ProfileShape::impulse;
  p.duration_s = needs_duration ? f.required_number("duration_s", 1e-6, 1e6)
                                : f.number("duration_s", std::numeric_limits<double>::infinity(), 1e-6, 1e6);
  if (p.shape == sim::ProfileShape::chirp) {
    p.start_frequency_hz = f.required_number("start_frequency_hz", 0.0, 1e3);
    p.end_frequency_hz = f.required_number("end_frequency_hz", 0.0, 1e3);
  } else {
    for (const char* key : {"start_frequency_hz", "end_frequency_hz"}) {
      if (f.has(key)) fail(f.field(key), "only for profile: chirp");
    }
  }
  return out;
}

}  // namespace

double as_number(const YAML::Node& n, const std::string& field, double lo, double hi) {
  if (!n.IsScalar()) fail(field, "must be a number, got " + kind_of(n));
  double value = 0.0;
  if (!YAML::convert<double>::decode(n, value)) fail(field, "must be a number, got " + kind_of(n));
  if (!std::isfinite(value)) fail(field, "must be finite, got " + kind_of(n));
  if (value < lo || value > hi) fail(field, fmt::format("must be in [{}, {}], got {}", lo, hi, value));
  return value;
}

Fields::Fields(const YAML::Node& map, std::string path) : map_(map), path_(std::move(path)) {
  if (map_.IsDefined() && !map_.IsNull() && !map_.IsMap()) fail(path_, "must be a map, got " + kind_of(map_));
}

bool Fields::has(const char* key) const { return map_.IsMap() && map_[key].IsDefined(); }

YAML::Node Fields::child(const char* key) const { return has(key) ? map_[key] : YAML::Node(); }

void Fields::allow_only(std::initializer_list<const char*> keys) const {
  if (!map_.IsMap()) return;
  for (const auto& item : map_) {
    const std::string key = item.first.as<std::string>();
    bool known = false;
    std::string allowed;
    for (const char* k : keys) {
      known = known || key == k;
      allowed += allowed.empty() ? k : std::string(", ") + k;
    }
    if (!known) fail(field(key.c_str()), "unknown key (allowed: " + allowed + ")");
  }
}

double Fields::number(const char* key, double fallback, double lo, double hi) const {
  return has(key) ? as_number(map_[key], field(key), lo, hi) : fallback;
}

double Fields::required_number(const char* key, double lo, double hi) const {
  if (!has(key)) fail(field(key), "missing");
  return as_number(map_[key], field(key), lo, hi);
}

Scenario load_scenario(const std::string& path) {
  YAML::Node root;
  try {
    root = YAML::LoadFile(path);
  } catch (const YAML::Exception& e) {
    throw ScenarioError(fmt::format("{}: {}", path, e.what()));
  }
  try {
    if (!root.IsMap()) fail("(top level)", "must be a map, got " + kind_of(root));
    const Fields top(root, "");
    top.allow_only({"name", "description", "duration_s", "sim", "initial", "controller", "external_wrenches", "summary"});
    Scenario s;
    s.duration_s = top.required_number("duration_s", 1e-3, 3600.0);
    read_sim(Fields(root["sim"], "sim"), s.sim);
    read_initial(Fields(root["initial"], "initial"), s);
    if (!top.has("controller")) fail("controller", "missing");
    const Fields controller(root["controller"], "controller");
    controller.allow_only({"type", "params", "settle_s"});
    s.controller_settle_s = controller.number("settle_s", 0.0, 0.0, 3600.0);
    if (!controller.has("type")) fail("controller.type", "missing");
    s.controller_type = as_string(controller.child("type"), "controller.type");
    s.controller_params = controller.child("params");
    if (top.has("external_wrenches")) {
      const YAML::Node list = root["external_wrenches"];
      if (!list.IsSequence()) fail("external_wrenches", "must be a list, got " + kind_of(list));
      if (list.size() > static_cast<std::size_t>(sim::BulletRobot::kMaxExternalWrenches)) {
        fail("external_wrenches", fmt::format("at most {} entries", sim::BulletRobot::kMaxExternalWrenches));
      }
      for (std::size_t i = 0; i < list.size(); ++i) {
        s.wrenches.push_back(read_wrench(list[i], fmt::format("external_wrenches[{}]", i)));
      }
    }
    const Fields summary(root["summary"], "summary");
    summary.allow_only({"fall_height_m"});
    s.fall_height_m = summary.number("fall_height_m", s.fall_height_m, 0.0, 10.0);
    if (top.has("name")) as_string(root["name"], "name");
    if (top.has("description")) as_string(root["description"], "description");
    return s;
  } catch (const ScenarioError& e) {
    throw ScenarioError(fmt::format("{}: {}", path, e.what()));
  }
}

void apply_feet_clearance(Scenario& s) {
  if (!s.has_feet_clearance) return;
  sim::BulletRobot probe(s.sim);
  if (auto r = probe.configure(); !r.ok) throw std::runtime_error(r.message);
  s.sim.initial_q[2] += s.feet_clearance_m - probe.lowest_foot_clearance_m();
}

}  // namespace springbok::simtool
