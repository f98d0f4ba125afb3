// springbok-sim on broken scenario files: a clear error naming the file and
// the field, a non-zero exit, and no output.
#include <gtest/gtest.h>

#include "cli_test_util.hpp"

namespace {
using namespace springbok::test;

// ---- broken scenarios: each names its field, exits non-zero, writes nothing ----

struct Broken {
  const char* name;
  const char* yaml;
  const char* expected;  // in the error message
};

const Broken kBroken[] = {
    {"unknown_key", "duration_s: 1\ncontroller: {type: stand}\nbogus: 3\n", "bogus: unknown key"},
    {"missing_duration", "controller: {type: stand}\n", "duration_s: missing"},
    {"missing_controller", "duration_s: 1\n", "controller: missing"},
    {"wrong_type", "duration_s: fast\ncontroller: {type: stand}\n", "duration_s: must be a number"},
    {"nan", "duration_s: .nan\ncontroller: {type: stand}\n", "duration_s: must be a finite number"},
    {"out_of_range", "duration_s: 1\nsim: {ground_friction: -1}\ncontroller: {type: stand}\n",
     "sim.ground_friction: must be in"},
    {"nested_unknown", "duration_s: 1\nsim: {imu: {sede: 3}}\ncontroller: {type: stand}\n", "sim.imu.sede: unknown key"},
    {"latency_fraction", "duration_s: 1\nsim: {latency: {command_ticks: 1.5}}\ncontroller: {type: stand}\n",
     "sim.latency.command_ticks: must be an integer"},
    {"latency_too_long", "duration_s: 1\nsim: {latency: {joint_measurement_ticks: 9}}\ncontroller: {type: stand}\n",
     "sim.latency.joint_measurement_ticks: must be in"},
    {"bad_vector", "duration_s: 1\ninitial: {base_position_m: [0, 1]}\ncontroller: {type: stand}\n",
     "initial.base_position_m: must be a list of 3, got 2 elements"},
    {"joint_limit", "duration_s: 1\ninitial: {joint_positions_rad: [0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0]}\n"
                    "controller: {type: stand}\n",
     "initial.joint_positions_rad[2]: lf_kfe_joint"},
    {"unknown_controller", "duration_s: 1\ncontroller: {type: magic}\n", "controller.type: unknown controller 'magic'"},
    {"bad_param", "duration_s: 1\ncontroller: {type: stand, params: {kp_leg_nm_per_rad: -5}}\n",
     "controller.params.kp_leg_nm_per_rad: must be in"},
    {"unknown_frame", "duration_s: 1\ncontroller: {type: stand}\nexternal_wrenches:\n"
                      "  - {frame: hand, axis: [1, 0, 0], profile: step, amplitude: 50}\n",
     "external_wrenches[0].frame: unknown frame 'hand'"},
    {"chirp_needs_frequency", "duration_s: 1\ncontroller: {type: stand}\nexternal_wrenches:\n"
                              "  - {frame: arm_end_effector_link, axis: [1, 0, 0], profile: chirp, amplitude: 20,"
                              " duration_s: 1, start_frequency_hz: 0}\n",
     "external_wrenches[0].end_frequency_hz: missing"},
    {"zero_axis", "duration_s: 1\ncontroller: {type: stand}\nexternal_wrenches:\n"
                  "  - {frame: trunk, axis: [0, 0, 0], profile: step, amplitude: 5}\n",
     "external_wrenches[0].axis: must not be zero"},
    {"two_amplitudes", "duration_s: 1\ncontroller: {type: stand}\nexternal_wrenches:\n"
                       "  - {frame: end_effector, axis: [1, 0, 0], profile: step, amplitude: 5, amplitude_weight_fraction: 0.1}\n",
     "external_wrenches[0]: needs exactly one of 'amplitude' and 'amplitude_weight_fraction'"},
    {"no_amplitude", "duration_s: 1\ncontroller: {type: stand}\nexternal_wrenches:\n"
                     "  - {frame: end_effector, axis: [1, 0, 0], profile: step}\n",
     "external_wrenches[0]: needs exactly one of 'amplitude' and 'amplitude_weight_fraction'"},
    {"weight_fraction_range", "duration_s: 1\ncontroller: {type: stand}\nexternal_wrenches:\n"
                              "  - {frame: end_effector, axis: [1, 0, 0], profile: step, amplitude_weight_fraction: 20}\n",
     "external_wrenches[0].amplitude_weight_fraction: must be in"},
    // sim.sensors: the sensor models (sim_hal/sensor_models.hpp)
    {"sensor_preset", "duration_s: 1\nsim: {sensors: {preset: consumer}}\ncontroller: {type: stand}\n",
     "sim.sensors.preset: must be one of ideal, mems, tactical, got 'consumer'"},
    {"sensor_part_preset", "duration_s: 1\nsim: {sensors: {wrist_ft: {preset: mems}}}\ncontroller: {type: stand}\n",
     "sim.sensors.wrist_ft.preset: must be one of ideal, realistic, got 'mems'"},
    {"sensor_out_of_range",
     "duration_s: 1\nsim: {sensors: {imu: {gyro: {noise_rad_s_per_sqrt_hz: 5}}}}\ncontroller: {type: stand}\n",
     "sim.sensors.imu.gyro.noise_rad_s_per_sqrt_hz: must be in"},
    {"sensor_bias_offset_short",
     "duration_s: 1\nsim: {sensors: {imu: {gyro: {bias_offset_rad_s: [0.02, 0]}}}}\ncontroller: {type: stand}\n",
     "sim.sensors.imu.gyro.bias_offset_rad_s: must be a list of 3"},
    {"sensor_negative", "duration_s: 1\nsim: {sensors: {joint_torque: {noise_std_nm: -1}}}\ncontroller: {type: stand}\n",
     "sim.sensors.joint_torque.noise_std_nm: must be in"},
    {"sensor_delay_too_long",
     "duration_s: 1\nsim: {sensors: {imu: {accel: {delay_ticks: 17}}}}\ncontroller: {type: stand}\n",
     "sim.sensors.imu.accel.delay_ticks: must be in"},
    {"sensor_unknown_key", "duration_s: 1\nsim: {sensors: {imu: {gyro: {noise: 1}}}}\ncontroller: {type: stand}\n",
     "sim.sensors.imu.gyro.noise: unknown key"},
    {"sensor_lowpass_cutoff", "duration_s: 1\nsim: {sensors: {encoders: {velocity: lowpass}}}\ncontroller: {type: stand}\n",
     "sim.sensors.encoders.velocity_cutoff_hz: required with velocity: lowpass"},
    {"sensor_gear_list", "duration_s: 1\nsim: {sensors: {encoders: {gear_ratio: [1, 2]}}}\ncontroller: {type: stand}\n",
     "sim.sensors.encoders.gear_ratio: must be a list of 19, got 2 elements"},
    {"legacy_imu_and_sensors_imu",
     "duration_s: 1\nsim: {imu: {gyro_noise_rad_s: 0.01}, sensors: {imu: {preset: mems}}}\ncontroller: {type: stand}\n",
     "sim.imu: conflicts with sim.sensors.imu"},
    {"legacy_imu_and_preset",
     "duration_s: 1\nsim: {imu: {seed: 3}, sensors: {preset: tactical}}\ncontroller: {type: stand}\n",
     "sim.imu: conflicts with sim.sensors.preset"},
    {"not_yaml", "duration_s: [1\n", "YAML syntax"},
};

TEST(SimCli, BrokenScenariosNameTheField) {
  for (const Broken& b : kBroken) {
    const fs::path dir = scratch(std::string("broken_") + b.name);
    const fs::path file = dir / "scenario.yaml";
    std::ofstream(file) << b.yaml;
    const CliResult r = run(file.string(), dir / "out");
    EXPECT_EQ(r.exit_code, 2) << b.name;
    EXPECT_NE(r.err.find(b.expected), std::string::npos) << b.name << ": " << r.err;
    EXPECT_NE(r.err.find(file.string()), std::string::npos) << b.name << ": the message names the file: " << r.err;
    EXPECT_FALSE(fs::exists(dir / "out" / "summary.json")) << b.name;
  }
}

// An optional section left empty is its default: `sim:` the defaults, `external_wrenches:` none
// (the list was refused as "must be a list, got empty" where the map was accepted). A scalar
// there is still refused.
TEST(SimCli, AnEmptyOptionalSectionIsItsDefault) {
  const fs::path dir = scratch("empty_sections");
  const fs::path file = dir / "scenario.yaml";
  std::ofstream(file) << "duration_s: 0.01\nsim:\ncontroller: {type: stand}\nexternal_wrenches:\n";
  const CliResult r = run(file.string(), dir / "out");
  EXPECT_EQ(r.exit_code, 0) << r.err;
  EXPECT_TRUE(fs::exists(dir / "out" / "summary.json"));
  std::ofstream(file) << "duration_s: 0.01\ncontroller: {type: stand}\nexternal_wrenches: 5\n";
  const CliResult bad = run(file.string(), dir / "out2");
  EXPECT_EQ(bad.exit_code, 2);
  EXPECT_NE(bad.err.find("external_wrenches: must be a list, got '5'"), std::string::npos) << bad.err;
}

TEST(SimCli, MissingFileAndMissingArguments) {
  const fs::path dir = scratch("missing");
  const CliResult r = run((dir / "nope.yaml").string(), dir / "out");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("nope.yaml"), std::string::npos) << r.err;
  const int status = std::system(("'" + kBin + "' >/dev/null 2>&1").c_str());
  EXPECT_NE(WEXITSTATUS(status), 0);
}

}  // namespace
