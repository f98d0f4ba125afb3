#include "scenario.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>
#include <random>
#include <vector>

#include <fmt/format.h>

#include "springbok/wbc/stand_controller.hpp"

namespace springbok::simtool {
namespace {

using yaml::Field;

// sim.sensors.imu.{gyro, accel}: one triad of the sensor model, over its preset's values.
void read_triad(const Field& f, sim::InertialTriadConfig& c, bool gyro) {
  const char* noise = gyro ? "noise_rad_s_per_sqrt_hz" : "noise_m_s2_per_sqrt_hz";
  const char* walk = gyro ? "bias_walk_rad_s2_per_sqrt_hz" : "bias_walk_m_s3_per_sqrt_hz";
  const char* bias = gyro ? "turn_on_bias_rad_s" : "turn_on_bias_m_s2";
  const char* offset = gyro ? "bias_offset_rad_s" : "bias_offset_m_s2";
  const char* lsb = gyro ? "lsb_rad_s" : "lsb_m_s2";
  const char* range = gyro ? "range_rad_s" : "range_m_s2";
  if (!f.allow_only({noise, walk, bias, offset, "scale_factor_std", lsb, range, "sample_rate_hz", "delay_ticks"})) {
    return;
  }
  const double scale = gyro ? 1.0 : 10.0;  // the accelerometer's limits: m/s^2 span ~10x rad/s
  f[noise].number(c.noise_per_sqrt_hz, 0.0, 1.0 * scale);
  f[walk].number(c.bias_walk_per_sqrt_hz, 0.0, 1.0 * scale);
  f[bias].number(c.turn_on_bias, 0.0, 10.0 * scale);
  f[offset].vector(c.bias_offset, -10.0 * scale, 10.0 * scale);
  f["scale_factor_std"].number(c.scale_factor_std, 0.0, 0.5);
  f[lsb].number(c.lsb, 0.0, 1.0 * scale);
  f[range].number(c.range, 0.0, 1e4 * scale);
  f["sample_rate_hz"].number(c.sample_rate_hz, 0.0, 1e6);
  f["delay_ticks"].integer(c.delay_ticks, 0, sim::kMaxSensorDelayTicks);
}

// sim.sensors: {preset, seed, imu, encoders, joint_torque, wrist_ft} (tools/scenarios/README.md,
// "Sensor models"): the preset first (mems / tactical: that IMU and the realistic rest), then
// each section's own preset, then each key over it.
void read_sensors(const Field& f, sim::SensorModelConfig& c) {
  c = sim::SensorModelConfig{};
  if (!f.allow_only({"preset", "seed", "imu", "encoders", "joint_torque", "wrist_ft"})) return;
  constexpr sim::ImuPreset kImuPresets[] = {sim::ImuPreset::ideal, sim::ImuPreset::mems, sim::ImuPreset::tactical};
  constexpr sim::PartPreset kPartPresets[] = {sim::PartPreset::ideal, sim::PartPreset::realistic};
  if (int p = 0; f["preset"].choice(p, {"ideal", "mems", "tactical"})) c = sim::sensor_preset(kImuPresets[p]);
  f["seed"].integer(c.seed, 0, std::numeric_limits<long long>::max());

  const Field imu = f["imu"];
  if (imu.allow_only({"preset", "gyro", "accel", "orientation"})) {
    if (int p = 0; imu["preset"].choice(p, {"ideal", "mems", "tactical"})) c.imu = sim::imu_preset(kImuPresets[p]);
    read_triad(imu["gyro"], c.imu.gyro, true);
    read_triad(imu["accel"], c.imu.accel, false);
    const Field o = imu["orientation"];
    if (o.allow_only({"drift_rad_per_sqrt_s", "noise_rad"})) {
      o["drift_rad_per_sqrt_s"].number(c.imu.orientation.drift_rad_per_sqrt_s, 0.0, 1.0);
      o["noise_rad"].number(c.imu.orientation.noise_rad, 0.0, 1.0);
    }
  }
  const Field enc = f["encoders"];
  if (enc.allow_only({"preset", "counts_per_rev", "gear_ratio", "velocity", "velocity_cutoff_hz"})) {
    if (int p = 0; enc["preset"].choice(p, {"ideal", "realistic"})) c.encoders = sim::encoder_preset(kPartPresets[p]);
    enc["counts_per_rev"].number(c.encoders.counts_per_rev, 0.0, 1e9);
    enc["gear_ratio"].vector<kNj>(c.encoders.gear_ratio, 1e-3, 1e4, /*scalar_fills=*/true);
    constexpr sim::EncoderVelocity kVelocity[] = {sim::EncoderVelocity::exact, sim::EncoderVelocity::difference,
                                                  sim::EncoderVelocity::lowpass};
    if (int v = 0; enc["velocity"].choice(v, {"exact", "difference", "lowpass"})) c.encoders.velocity = kVelocity[v];
    enc["velocity_cutoff_hz"].number(c.encoders.velocity_cutoff_hz, 1e-3, 1e6);
    if (c.encoders.velocity == sim::EncoderVelocity::lowpass && !(c.encoders.velocity_cutoff_hz > 0.0)) {
      enc["velocity_cutoff_hz"].fail("required with velocity: lowpass");
    }
  }
  const Field tau = f["joint_torque"];
  if (tau.allow_only({"preset", "noise_std_nm", "offset_std_nm"})) {
    if (int p = 0; tau["preset"].choice(p, {"ideal", "realistic"})) {
      c.joint_torque = sim::joint_torque_preset(kPartPresets[p]);
    }
    tau["noise_std_nm"].vector<kNj>(c.joint_torque.noise_std_nm, 0.0, 1e4, true);
    tau["offset_std_nm"].vector<kNj>(c.joint_torque.offset_std_nm, 0.0, 1e4, true);
  }
  const Field ft = f["wrist_ft"];
  if (ft.allow_only({"preset", "force_noise_std_n", "torque_noise_std_nm", "force_offset_std_n", "torque_offset_std_nm",
                     "force_offset_walk_n_per_sqrt_s", "torque_offset_walk_nm_per_sqrt_s", "force_range_n",
                     "torque_range_nm", "force_lsb_n", "torque_lsb_nm"})) {
    sim::WristFtConfig& w = c.wrist_ft;
    if (int p = 0; ft["preset"].choice(p, {"ideal", "realistic"})) w = sim::wrist_ft_preset(kPartPresets[p]);
    ft["force_noise_std_n"].number(w.force_noise_std_n, 0.0, 1e3);
    ft["torque_noise_std_nm"].number(w.torque_noise_std_nm, 0.0, 1e2);
    ft["force_offset_std_n"].number(w.force_offset_std_n, 0.0, 1e4);
    ft["torque_offset_std_nm"].number(w.torque_offset_std_nm, 0.0, 1e3);
    ft["force_offset_walk_n_per_sqrt_s"].number(w.force_offset_walk_n_per_sqrt_s, 0.0, 1e2);
    ft["torque_offset_walk_nm_per_sqrt_s"].number(w.torque_offset_walk_nm_per_sqrt_s, 0.0, 10.0);
    ft["force_range_n"].vector<3>(w.force_range_n, 0.0, 1e6, true);
    ft["torque_range_nm"].vector<3>(w.torque_range_nm, 0.0, 1e5, true);
    ft["force_lsb_n"].number(w.force_lsb_n, 0.0, 100.0);
    ft["torque_lsb_nm"].number(w.torque_lsb_nm, 0.0, 10.0);
  }
}

void read_sim(const Field& f, sim::SimConfig& c) {
  f.allow_only({"step_s", "substeps", "solver_iterations", "limit_solver_iterations", "gravity_m_s2", "ground_friction", "ground_restitution",
                "fixed_base", "imu", "sensors", "latency"});
  f["step_s"].number(c.step_s, 1e-5, 0.01);
  f["substeps"].integer(c.substeps, 1, 100);
  f["solver_iterations"].integer(c.solver_iterations, 1, 1000);
  f["limit_solver_iterations"].integer(c.limit_solver_iterations, 1, 1000);
  f["gravity_m_s2"].number(c.gravity_m_s2, 0.0, 100.0);
  f["ground_friction"].number(c.ground_friction, 0.0, 10.0);
  f["ground_restitution"].number(c.ground_restitution, 0.0, 1.0);
  f["fixed_base"].boolean(c.fixed_base);
  const Field imu = f["imu"];
  imu.allow_only({"gyro_noise_rad_s", "accel_noise_m_s2", "gyro_bias_rad_s", "accel_bias_m_s2", "seed"});
  c.imu.gyro_noise_rad_s = c.imu.accel_noise_m_s2 = c.imu.gyro_bias_rad_s = c.imu.accel_bias_m_s2 = 0.0;
  c.imu.seed = 1;
  imu["gyro_noise_rad_s"].number(c.imu.gyro_noise_rad_s, 0.0, 10.0);
  imu["accel_noise_m_s2"].number(c.imu.accel_noise_m_s2, 0.0, 100.0);
  imu["gyro_bias_rad_s"].number(c.imu.gyro_bias_rad_s, 0.0, 10.0);
  imu["accel_bias_m_s2"].number(c.imu.accel_bias_m_s2, 0.0, 100.0);
  imu["seed"].integer(c.imu.seed, 0, 4294967295LL);
  // sim.imu is the IMU model's legacy form: with sim.sensors' IMU (its imu, its preset, its
  // seed) the file says two things of one sensor.
  const Field sensors = f["sensors"];
  read_sensors(sensors, c.sensors);
  if (imu.is_map() && !imu.keys().empty()) {
    for (const char* key : {"imu", "preset", "seed"}) {
      if (!sensors[key].present()) continue;
      imu.fail(fmt::format("conflicts with sim.sensors.{}: give the IMU's model in one place (sim.sensors.imu; "
                           "sim.imu's keys are its legacy form, per-sample std and turn-on std)",
                           key));
      break;
    }
  }
  const Field latency = f["latency"];
  latency.allow_only({"joint_measurement_ticks", "sensor_measurement_ticks", "command_ticks"});
  c.latency = sim::Latency{};
  latency["joint_measurement_ticks"].integer(c.latency.joint_measurement_ticks, 0, sim::Latency::kMaxTicks);
  latency["sensor_measurement_ticks"].integer(c.latency.sensor_measurement_ticks, 0, sim::Latency::kMaxTicks);
  latency["command_ticks"].integer(c.latency.command_ticks, 0, sim::Latency::kMaxTicks);
}

// 'stance' (nominal_stance: the robot file's, legs and arm) or kNj angles within the joints' limits.
void joint_positions(const Field& f, VecNj& q) {
  if (f.is_scalar() && f.node().Scalar() == "stance") {
    q = wbc::nominal_stance();
    return;
  }
  if (!f.is_list()) {
    f.fail(fmt::format("must be 'stance' or a list of {} angles, got {}", kNj, f.describe()));
    return;
  }
  VecNj v = q;
  if (!f.vector<kNj>(v, -10.0, 10.0)) return;
  for (int j = 0; j < kNj; ++j) {
    const auto& lim = robot::kJoints[static_cast<std::size_t>(j)].limits;
    if (lim.bounded && (v[j] < lim.lower_rad || v[j] > lim.upper_rad)) {
      f[static_cast<std::size_t>(j)].fail(fmt::format("{} = {} is outside its limits [{}, {}]",
                                                       robot::kJoints[static_cast<std::size_t>(j)].name, v[j],
                                                       lim.lower_rad, lim.upper_rad));
      return;
    }
  }
  q = v;
}

void read_initial(const Field& f, Scenario& s) {
  f.allow_only({"base_position_m", "base_orientation_xyzw", "joint_positions_rad", "feet_clearance_m"});
  VecNq q = sim::SimConfig::default_q();
  q.head<3>() = Vec3(0.0, 0.0, 0.65);
  Vec3 position = q.head<3>();
  if (f["base_position_m"].vector<3>(position, -1e3, 1e3)) q.head<3>() = position;
  Vec<4> quat;
  if (f["base_orientation_xyzw"].vector<4>(quat, -1.0, 1.0)) {
    if (std::abs(quat.norm() - 1.0) > 1e-3) {
      f["base_orientation_xyzw"].fail("must be a unit quaternion (x y z w)");
    } else {
      q.segment<4>(3) = quat.normalized();
    }
  }
  VecNj joints = wbc::nominal_stance();
  if (f["joint_positions_rad"].present()) joint_positions(f["joint_positions_rad"], joints);
  q.tail<kNj>() = joints;
  if (f["feet_clearance_m"].number(s.feet_clearance_m, 0.0, 10.0)) s.has_feet_clearance = true;
  s.sim.initial_q = q;
}

// random_pushes: {seed, start_s, end_s, every_s: [lo, hi], duration_s, max_force_n, frames: [...]}:
// horizontal pushes of a uniform direction and a magnitude uniform in [max/4, max], each on one of
// the frames (uniformly), starting every lo..hi s from start_s until end_s. Expanded here into
// step wrenches, deterministically from the seed (std::mt19937_64 and the tool's own uniform
// draws, not std::uniform_*_distribution, whose algorithm the standard leaves open).
void read_random_pushes(const Field& f, Scenario& s) {
  if (!f.present() || !f.allow_only({"seed", "start_s", "end_s", "every_s", "duration_s", "max_force_n", "frames"})) {
    return;
  }
  const std::size_t errors_before = f.errors().size();
  std::uint64_t seed = 1;
  double start_s = 0.0, end_s = s.duration_s, duration_s = 0.2, max_force_n = 80.0;
  Eigen::Vector2d every_s(2.0, 4.0);
  f["seed"].integer(seed, 0, std::numeric_limits<long long>::max());
  f["start_s"].number(start_s, 0.0, 1e6);
  f["end_s"].number(end_s, 0.0, 1e6);
  f["duration_s"].number(duration_s, 1e-3, 10.0);
  f["max_force_n"].number(max_force_n, 0.0, 1e4);
  if (f["every_s"].vector<2>(every_s, 0.01, 1e3) && every_s[1] < every_s[0]) f["every_s"].fail("must be [lo, hi], lo <= hi");
  std::vector<sim::FrameRef> frames;
  std::vector<std::string> names;
  const Field list = f["frames"];
  if (list.require() && list.expect_list()) {
    for (std::size_t i = 0; i < list.size(); ++i) {
      std::string name;
      if (!list[i].text(name)) continue;
      if (const auto frame = sim::find_frame(name)) {
        frames.push_back(*frame);
        names.push_back(name);
      } else {
        list[i].fail("unknown frame '" + name + "' (a link name or a fixed frame of the model)");
      }
    }
    if (list.size() == 0) list.fail("must name at least one frame");
  }
  if (f.errors().size() != errors_before || frames.empty()) return;
  std::mt19937_64 rng(seed);
  const auto uniform = [&rng] { return static_cast<double>(rng() >> 11) * 0x1.0p-53; };  // [0, 1)
  for (double t = start_s + every_s[0] + (every_s[1] - every_s[0]) * uniform(); t + duration_s <= end_s;
       t += every_s[0] + (every_s[1] - every_s[0]) * uniform()) {
    if (s.wrenches.size() >= static_cast<std::size_t>(sim::BulletRobot::kMaxExternalWrenches)) {
      f.fail(fmt::format("more than {} pushes and wrenches in all (shorten end_s or lengthen every_s)",
                         sim::BulletRobot::kMaxExternalWrenches));
      return;
    }
    const std::size_t which = std::min(frames.size() - 1, static_cast<std::size_t>(uniform() * frames.size()));
    const double angle = 2.0 * M_PI * uniform();
    NamedWrench w;
    w.frame = names[which];
    w.wrench.frame = frames[which];
    w.wrench.kind = sim::WrenchKind::force;
    w.wrench.axis_world = Vec3(std::cos(angle), std::sin(angle), 0.0);
    w.wrench.profile.shape = sim::ProfileShape::step;
    w.wrench.profile.amplitude = max_force_n * (0.25 + 0.75 * uniform());
    w.wrench.profile.start_s = t;
    w.wrench.profile.duration_s = duration_s;
    s.wrenches.push_back(std::move(w));
  }
}

std::optional<NamedWrench> read_wrench(const Field& f) {
  if (!f.is_map()) {
    f.fail("must be a map, got " + f.describe());
    return std::nullopt;
  }
  const std::size_t errors_before = f.errors().size();
  f.allow_only({"frame", "kind", "axis", "profile", "amplitude", "amplitude_weight_fraction", "start_s", "duration_s",
                "start_frequency_hz", "end_frequency_hz"});
  NamedWrench out;
  if (f["frame"].require() && f["frame"].text(out.frame)) {
    if (out.frame == "end_effector") out.frame = robot::kFrames[robot::kEeFrame].name;  // the robot file's hand, any robot
    if (const auto frame = sim::find_frame(out.frame)) {
      out.wrench.frame = *frame;
    } else {
      f["frame"].fail("unknown frame '" + out.frame + "' (a link name or a fixed frame of the model)");
    }
  }
  int kind = 0;
  f["kind"].choice(kind, {"force", "torque"});
  out.wrench.kind = kind == 0 ? sim::WrenchKind::force : sim::WrenchKind::torque;
  Vec3 axis = Vec3::Zero();
  if (f["axis"].require() && f["axis"].vector<3>(axis, -1e6, 1e6)) {
    if (axis.norm() < 1e-9) f["axis"].fail("must not be zero");
    else out.wrench.axis_world = axis.normalized();
  }
  auto& p = out.wrench.profile;
  int profile = 0;
  if (f["profile"].require() && f["profile"].choice(profile, {"step", "constant", "chirp", "impulse"})) {
    constexpr sim::ProfileShape kShapes[] = {sim::ProfileShape::step, sim::ProfileShape::constant,
                                             sim::ProfileShape::chirp, sim::ProfileShape::impulse};
    p.shape = kShapes[profile];
  }
  // In newtons (or N m), or as a fraction of the robot's weight, m g: a push that scales with the robot.
  if (f["amplitude"].present() == f["amplitude_weight_fraction"].present()) {
    f.fail("needs exactly one of 'amplitude' and 'amplitude_weight_fraction'");
  } else if (f["amplitude"].present()) {
    f["amplitude"].number(p.amplitude, -1e5, 1e5);
  } else if (double fraction = 0.0; f["amplitude_weight_fraction"].number(fraction, -10.0, 10.0)) {
    p.amplitude = fraction * total_mass_kg() * kGravity_m_s2;
  }
  p.start_s = 0.0;
  f["start_s"].number(p.start_s, 0.0, 1e6);
  const bool needs_duration = p.shape == sim::ProfileShape::chirp || p.shape == sim::ProfileShape::impulse;
  p.duration_s = std::numeric_limits<double>::infinity();
  if (needs_duration) f["duration_s"].require();
  f["duration_s"].number(p.duration_s, 1e-6, 1e6);
  for (const char* key : {"start_frequency_hz", "end_frequency_hz"}) {
    if (p.shape == sim::ProfileShape::chirp) {
      if (f[key].require()) f[key].number(key[0] == 's' ? p.start_frequency_hz : p.end_frequency_hz, 0.0, 1e3);
    } else if (f[key].present()) {
      f[key].fail("only for profile: chirp");
    }
  }
  if (f.errors().size() != errors_before) return std::nullopt;
  return out;
}

}  // namespace

void refuse_if_any(const yaml::Errors& errors, const std::string& path) {
  if (errors.empty()) return;
  std::string text;
  for (const std::string& e : errors.lines()) text += (text.empty() ? "" : "\n") + path + ": " + e;
  throw ScenarioError(text);
}

Scenario load_scenario(const std::string& path) {
  const yaml::Document doc = yaml::parse_file(path);
  if (!doc.ok) throw ScenarioError(doc.error);
  yaml::Errors errors;
  const Field top(doc.root, "", errors);
  Scenario s;
  if (!top.is_map()) {
    top.fail("must be a map, got " + top.describe());
    refuse_if_any(errors, path);
  }
  top.allow_only({"name", "description", "duration_s", "sim", "initial", "controller", "external_wrenches",
                  "random_pushes", "summary"});
  if (top["duration_s"].require()) top["duration_s"].number(s.duration_s, 1e-3, 3600.0);
  read_sim(top["sim"], s.sim);
  // The sensors' name in the summary: the preset, "custom" when keys change it.
  if (const Field sensors = top["sim"]["sensors"]; sensors.present()) {
    std::string preset = "ideal";
    if (sensors["preset"].present()) (void)sensors["preset"].text(preset);
    const bool changed = sensors.is_map() && std::ranges::any_of(sensors.keys(), [](const std::string& k) {
      return k != "preset" && k != "seed";
    });
    s.sensors = changed ? preset + " (custom)" : preset;
  } else if (const Field imu = top["sim"]["imu"]; imu.is_map() && !imu.keys().empty()) {
    s.sensors = "ideal (custom: sim.imu)";
  }
  read_initial(top["initial"], s);
  const Field controller = top["controller"];
  if (controller.require() && controller.allow_only({"type", "params", "settle_s", "still_start_s"})) {
    controller["settle_s"].number(s.controller_settle_s, 0.0, 3600.0);
    controller["still_start_s"].number(s.controller_still_start_s, 0.0, 3600.0);
    if (controller["type"].require()) controller["type"].text(s.controller_type);
    s.controller_params = controller["params"].node();
    s.controller_params_line = controller["params"].line();
  }
  // An empty `external_wrenches:` is none, as an empty `sim:` is its defaults.
  if (const Field list = top["external_wrenches"]; !list.node().IsNull() && list.expect_list()) {
    if (list.size() > static_cast<std::size_t>(sim::BulletRobot::kMaxExternalWrenches)) {
      list.fail(fmt::format("at most {} entries", sim::BulletRobot::kMaxExternalWrenches));
    }
    for (std::size_t i = 0; i < list.size(); ++i) {
      if (auto w = read_wrench(list[i])) s.wrenches.push_back(std::move(*w));
    }
  }
  const std::size_t explicit_wrenches = s.wrenches.size();
  read_random_pushes(top["random_pushes"], s);
  // The WBC takes the wrist F/T's tare and its reference pose while it settles: a wrench
  // acting then would be built into both (a 50 N push from t = 0 with settle_s 0.5 is tared
  // out, and the robot falls), so wrenches start once the controller runs.
  if (s.controller_type == "wbc" && errors.empty()) {  // (every explicit entry read: indices match)
    for (std::size_t i = 0; i < s.wrenches.size(); ++i) {
      const double start_s = s.wrenches[i].wrench.profile.start_s;
      if (start_s >= s.controller_settle_s) continue;
      const std::string why = fmt::format(
          "{} s is before controller.settle_s ({} s): the controller takes the wrist F/T tare and its reference pose "
          "while it settles, so a wrench then would be built into both; start it at or after settle_s",
          start_s, s.controller_settle_s);
      if (i < explicit_wrenches) {
        top["external_wrenches"][i]["start_s"].fail(why);
      } else {
        top["random_pushes"]["start_s"].fail("the first push at " + why);
      }
      break;
    }
  }
  const Field summary = top["summary"];
  summary.allow_only({"fall_height_m"});
  summary["fall_height_m"].number(s.fall_height_m, 0.0, 10.0);
  std::string text;
  top["name"].text(text);
  top["description"].text(text);
  refuse_if_any(errors, path);
  return s;
}

void apply_feet_clearance(Scenario& s) {
  if (!s.has_feet_clearance) return;
  sim::BulletRobot probe(s.sim);
  if (auto r = probe.configure(); !r.ok) throw std::runtime_error(r.message);
  s.sim.initial_q[2] += s.feet_clearance_m - probe.lowest_foot_clearance_m();
}

}  // namespace springbok::simtool
