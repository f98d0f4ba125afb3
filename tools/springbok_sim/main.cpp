// springbok-sim SCENARIO --out DIR
// Runs a scenario in lockstep with the Bullet robot (the firmware's tick: read -> controller ->
// write; then the physics steps; one tick per 1 ms of simulated time, as fast as the machine
// allows) and writes DIR/log.csv (one row per tick) and DIR/summary.json.
#include <charconv>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <limits>
#include <memory>
#include <optional>
#include <string>

#include <CLI/CLI.hpp>
#include <fmt/format.h>

#include "controller.hpp"
#include "scenario.hpp"
#include "wbc_adapter.hpp"
#include "springbok/isa/isa.hpp"
#include "springbok/rt/realtime.hpp"
#include "springbok/sim_hal/bullet_robot.hpp"
#include "springbok/wbc/stand_controller.hpp"

namespace {
using namespace springbok;

using simtool::Controller;

class StandAdapter final : public Controller {
 public:
  explicit StandAdapter(const yaml::Field& p) : stand_(gains(p), wbc::nominal_stance()) {}
  bool tick(sim::BulletRobot& robot, std::int64_t) noexcept override {
    stand_.tick(robot.ground_truth().q, cmd_);  // base orientation: ground truth (the estimator is a wbc option)
    return robot.write(cmd_) == hal::IoStatus::ok;
  }

 private:
  static wbc::StandGains gains(const yaml::Field& p) {
    p.allow_only({"kp_leg_nm_per_rad", "kd_leg_nms_per_rad", "kp_arm_nm_per_rad", "kd_arm_nms_per_rad"});
    wbc::StandGains g;
    p["kp_leg_nm_per_rad"].number(g.kp_leg_nm_per_rad, 0.0, 1e5);
    p["kd_leg_nms_per_rad"].number(g.kd_leg_nms_per_rad, 0.0, 1e4);
    p["kp_arm_nm_per_rad"].number(g.kp_arm_nm_per_rad, 0.0, 1e5);
    p["kd_arm_nms_per_rad"].number(g.kd_arm_nms_per_rad, 0.0, 1e4);
    return g;
  }
  wbc::StandController stand_;
  hal::JointCommands cmd_;
};

// The safe mode: tau = -D qd.
class DampingAdapter final : public Controller {
 public:
  explicit DampingAdapter(const yaml::Field& p) {
    p.allow_only({"kd_leg_nms_per_rad", "kd_arm_nms_per_rad"});
    double leg = 20.0, arm = 2.0;
    p["kd_leg_nms_per_rad"].number(leg, 0.0, 1e4);
    p["kd_arm_nms_per_rad"].number(arm, 0.0, 1e4);
    kd_.head<kFirstArmJoint>().setConstant(leg);
    kd_.tail<kArmJoints>().setConstant(arm);
  }
  bool tick(sim::BulletRobot& robot, std::int64_t) noexcept override {
    cmd_.mode = hal::CommandMode::enabled;
    cmd_.tau_ff_nm.setZero();
    cmd_.kp_nm_per_rad.setZero();
    cmd_.qd_des_rad_s.setZero();
    cmd_.kd_nms_per_rad = kd_;
    return robot.write(cmd_) == hal::IoStatus::ok;
  }

 private:
  VecNj kd_ = VecNj::Zero();
  hal::JointCommands cmd_;
};

// Throws ScenarioError naming every bad controller.params field.
std::unique_ptr<Controller> make_controller(const simtool::Scenario& s, const std::string& path, sim::BulletRobot& robot) {
  yaml::Errors errors;
  const yaml::Field params(s.controller_params, "controller.params", errors, s.controller_params_line);
  std::unique_ptr<Controller> c;
  if (s.controller_type == "stand") c = std::make_unique<StandAdapter>(params);
  else if (s.controller_type == "damping") c = std::make_unique<DampingAdapter>(params);
  else if (s.controller_type == "wbc") c = std::make_unique<simtool::WbcAdapter>(s, params, robot);
  else errors.add("controller.type", 0, "unknown controller '" + s.controller_type + "' (known: stand, damping, wbc)");
  simtool::refuse_if_any(errors, path);
  return c;
}

constexpr const char* kFootNames[kFeet] = {"lf", "rf", "lh", "rh"};

std::string csv_header() {
  std::string h = "time_s,base_x_m,base_y_m,base_z_m,base_qx,base_qy,base_qz,base_qw";
  for (const char* f : kFootNames) h += fmt::format(",{}_fz_n", f);
  for (const char* f : kFootNames) h += fmt::format(",{}_contact", f);
  h += ",ground_fz_n";
  for (const auto& j : robot::kJoints) h += fmt::format(",tau_{}", j.name);
  for (const auto& j : robot::kJoints) h += fmt::format(",q_{}", j.name);
  for (const auto& j : robot::kJoints) h += fmt::format(",tau_limit_{}", j.name);
  return h;
}

// A number with 6 decimals (resolution 1 um, 1 urad, 1 uN m): integer
// formatting, several times cheaper per tick than a floating-point conversion.
// Not finite or beyond 9e9: std::to_chars' shortest form.
void append_fixed6(std::string& out, double value) {
  char buf[32];
  char* end = buf;
  const double micro = std::nearbyint(value * 1e6);
  if (std::abs(micro) < 9.0e15) {
    auto units = static_cast<std::int64_t>(micro);
    if (units < 0) {
      *end++ = '-';
      units = -units;
    }
    end = std::to_chars(end, buf + sizeof buf, units / 1000000).ptr;
    *end++ = '.';
    std::int64_t fraction = units % 1000000;
    for (int digit = 5; digit >= 0; --digit, fraction /= 10) end[digit] = static_cast<char>('0' + fraction % 10);
    end += 6;
  } else {
    end = std::to_chars(buf, buf + sizeof buf, value).ptr;
  }
  out.append(buf, end);
}

void put(std::string& out, double value) {
  out.push_back(',');
  append_fixed6(out, value);
}

void append_row(std::string& out, const sim::GroundTruth& t) {
  append_fixed6(out, t.time_s);
  for (int i = 0; i < 7; ++i) put(out, t.q[i]);
  for (const auto& f : t.foot_force_n) put(out, f.z());
  for (bool c : t.foot_contact) out.append(c ? ",1" : ",0");
  put(out, t.ground_force_n.z());
  for (int j = 0; j < kNj; ++j) put(out, t.tau_applied_nm[j]);
  for (int j = 0; j < kNj; ++j) put(out, t.q[7 + j]);
  for (int j = 0; j < kNj; ++j) put(out, t.tau_limit_nm[j]);
}

// The command line's changes to the scenario (empty: the scenario's own).
struct Overrides {
  std::string state_source;    // controller.params.state_source (a wbc scenario's)
  std::string sensors;         // sim.sensors.preset, the whole sensor model (sim.imu's legacy keys dropped)
  std::int64_t sensors_seed = -1;  // sim.sensors.seed
};

void apply(const Overrides& o, simtool::Scenario& s) {
  if (!o.state_source.empty() && s.controller_type == "wbc") {
    if (!s.controller_params.IsMap()) s.controller_params = YAML::Node(YAML::NodeType::Map);
    s.controller_params["state_source"] = o.state_source;
  }
  if (!o.sensors.empty()) {
    const std::uint64_t seed = s.sim.sensors.seed;
    s.sim.sensors = sim::sensor_preset(o.sensors == "mems"       ? sim::ImuPreset::mems
                                       : o.sensors == "tactical" ? sim::ImuPreset::tactical
                                                                 : sim::ImuPreset::ideal);
    s.sim.sensors.seed = seed;
    s.sim.imu = sim::ImuNoise{};
    s.sensors = o.sensors;
  }
  if (o.sensors_seed >= 0) s.sim.sensors.seed = static_cast<std::uint64_t>(o.sensors_seed);
}

int run(const std::string& scenario_path, const Overrides& overrides, const std::filesystem::path& out_dir,
        const char* memory_locked) {
  simtool::Scenario s = simtool::load_scenario(scenario_path);
  apply(overrides, s);
  simtool::apply_feet_clearance(s);
  sim::BulletRobot hw(s.sim);
  if (auto r = hw.configure(); !r.ok) throw std::runtime_error(r.message);
  for (const auto& w : s.wrenches) hw.add_external_wrench(w.wrench);
  if (auto r = hw.activate(); !r.ok) throw std::runtime_error(r.message);
  std::unique_ptr<Controller> controller = make_controller(s, scenario_path, hw);

  std::filesystem::create_directories(out_dir);
  std::FILE* log = std::fopen((out_dir / "log.csv").c_str(), "wb");
  if (log == nullptr) throw std::runtime_error("cannot write " + (out_dir / "log.csv").string());
  const std::string header = csv_header() + controller->csv_columns() + "\n";
  std::fwrite(header.data(), 1, header.size(), log);

  const auto ticks = static_cast<std::int64_t>(std::llround(s.duration_s / s.sim.step_s));
  const auto last_second_ticks = static_cast<std::int64_t>(std::llround(1.0 / s.sim.step_s));
  const double weight_n = total_mass_kg() * s.sim.gravity_m_s2;
  std::string row;
  row.reserve(4096);
  bool fell = false;
  std::string fell_reason;
  double fell_time_s = 0.0;
  double fz_sum_n = 0.0, feet_fz_sum_n = 0.0;
  std::int64_t fz_samples = 0;
  int write_errors = 0;

  const auto wall_start = std::chrono::steady_clock::now();
  for (std::int64_t k = 0; k < ticks; ++k) {
    if (!controller->tick(hw, k)) ++write_errors;
    hw.step();
    const sim::GroundTruth& truth = hw.ground_truth();
    row.clear();
    append_row(row, truth);
    controller->after_step(truth, row);
    row.push_back('\n');
    std::fwrite(row.data(), 1, row.size(), log);
    if (!fell && (truth.q[2] < s.fall_height_m || truth.non_foot_ground_contact)) {
      fell = true;
      fell_time_s = truth.time_s;
      fell_reason = truth.non_foot_ground_contact ? "a non-foot link touched the ground" : "trunk below fall_height_m";
    }
    if (k >= ticks - last_second_ticks) {
      fz_sum_n += truth.ground_force_n.z();
      for (const auto& f : truth.foot_force_n) feet_fz_sum_n += f.z();
      ++fz_samples;
    }
  }
  const double wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - wall_start).count();
  std::fclose(log);

  const double sim_s = static_cast<double>(ticks) * s.sim.step_s;
  const auto ratio = [&](double sum) {
    return weight_n > 0.0 && fz_samples > 0 ? fmt::format("{:.9g}", sum / fz_samples / weight_n) : std::string("null");
  };
  const auto& q = hw.ground_truth().q;
  std::string json = "{\n";
  json += fmt::format("  \"scenario\": \"{}\",\n", std::filesystem::path(scenario_path).filename().string());
  json += fmt::format("  \"controller\": \"{}\",\n", s.controller_type);
  json += fmt::format("  \"ticks\": {},\n", ticks);
  json += fmt::format("  \"sim_seconds\": {:.9g},\n", sim_s);
  json += fmt::format("  \"wall_seconds\": {:.9g},\n", wall_s);
  json += fmt::format("  \"realtime_factor\": {:.9g},\n", wall_s > 0.0 ? sim_s / wall_s : 0.0);
  json += fmt::format("  \"fell\": {},\n", fell ? "true" : "false");
  json += fmt::format("  \"fell_reason\": {},\n", fell ? "\"" + fell_reason + "\"" : "null");
  json += fmt::format("  \"fell_time_s\": {},\n", fell ? fmt::format("{:.6f}", fell_time_s) : "null");
  json += fmt::format("  \"contact_fz_over_weight\": {},\n", ratio(fz_sum_n));
  json += fmt::format("  \"feet_fz_over_weight\": {},\n", ratio(feet_fz_sum_n));
  json += fmt::format("  \"final_base_position_m\": [{:.9g}, {:.9g}, {:.9g}],\n", q[0], q[1], q[2]);
  json += fmt::format("  \"sensors\": \"{}\",\n", s.sensors);
  json += controller->summary_fields();
  json += fmt::format("  \"memory_locked\": {},\n", memory_locked);
  json += fmt::format("  \"kernels\": \"{}\",\n", isa::name(isa::active()));
  json += fmt::format("  \"write_errors\": {}\n", write_errors);
  json += "}\n";
  std::FILE* summary = std::fopen((out_dir / "summary.json").c_str(), "wb");
  if (summary == nullptr) throw std::runtime_error("cannot write " + (out_dir / "summary.json").string());
  std::fwrite(json.data(), 1, json.size(), summary);
  std::fclose(summary);
  std::printf("%s", json.c_str());
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"springbok-sim: run a scenario against the Bullet robot"};
  std::string scenario;
  std::string out;
  app.add_option("SCENARIO", scenario, "scenario YAML (schema: tools/scenarios/README.md)")->required();
  app.add_option("--out", out, "output directory (log.csv, summary.json)")->required();
  bool lock_memory = false;
  app.add_flag("--lock-memory", lock_memory,
               "lock and prefault memory as the deployed binary does (RT.md: mlockall, heap and stack), so that "
               "tick_us carries no page faults of first use; without the privilege a warning, and the run goes on");
  Overrides overrides;
  app.add_option("--state-source", overrides.state_source,
                 "the base state the WBC is given, over the scenario's controller.params.state_source: estimated "
                 "(the firmware's estimator on the simulated sensors) or truth (the simulator's)")
      ->check(CLI::IsMember({"truth", "estimated"}));
  app.add_option("--sensors", overrides.sensors,
                 "the sensor model's preset, over the scenario's sim.sensors and sim.imu (its seed kept)")
      ->check(CLI::IsMember({"ideal", "mems", "tactical"}));
  app.add_option("--sensors-seed", overrides.sensors_seed, "the sensor model's seed, over sim.sensors.seed")
      ->check(CLI::Range(std::int64_t{0}, std::numeric_limits<std::int64_t>::max()));
  CLI11_PARSE(app, argc, argv);
  if (!isa::environment_error().empty()) {
    std::fprintf(stderr, "springbok-sim: %s\n", isa::environment_error().c_str());
    return 2;
  }
  // The RT recipe's process steps without /dev/cpu_dma_latency, and of its report only the
  // memory lock's outcome: no SCHED_FIFO thread, no PREEMPT_RT banner (a desktop tool).
  rt::RtReport rt_report;
  std::unique_ptr<rt::RtProcess> rt_process;
  if (lock_memory) {
    rt::RtConfig rt_config;
    rt_config.hold_cpu_dma_latency = false;
    rt_process = std::make_unique<rt::RtProcess>(rt_config, rt_report);
    rt::prefault_stack();
    if (rt_report.memory_locked) {
      std::fprintf(stderr, "springbok-sim: memory locked and prefaulted\n");
    } else {
      for (const std::string& w : rt_report.warnings)
        if (w.find("mlockall") != std::string::npos) std::fprintf(stderr, "springbok-sim: --lock-memory: %s\n", w.c_str());
    }
  }
  try {
    return run(scenario, overrides, out, lock_memory ? (rt_report.memory_locked ? "true" : "false") : "null");
  } catch (const std::exception& e) {
    std::fprintf(stderr, "springbok-sim: %s\n", e.what());
    return 2;
  }
}
