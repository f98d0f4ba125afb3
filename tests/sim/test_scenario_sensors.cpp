// A scenario's sim.sensors, as load_scenario reads it: the default is ideal, a preset then each
// section's own preset then each key over them, the legacy sim.imu keys kept as they were.
#include <gtest/gtest.h>

#include <fstream>
#include <string>

#include "cli_test_util.hpp"
#include "scenario.hpp"

namespace springbok::test {
namespace {

simtool::Scenario load(const std::string& name, const std::string& sim) {
  const fs::path dir = scratch(name);
  std::ofstream(dir / "s.yaml") << "duration_s: 1.0\ncontroller: {type: stand}\n" << sim;
  return simtool::load_scenario((dir / "s.yaml").string());
}

TEST(ScenarioSensors, TheDefaultIsIdeal) {
  EXPECT_TRUE(sim::is_ideal(load("sensors_default", "").sim.sensors));
  EXPECT_TRUE(sim::is_ideal(load("sensors_empty", "sim: {sensors: {}}\n").sim.sensors));
}

TEST(ScenarioSensors, APresetThenSectionPresetsThenKeys) {
  const simtool::Scenario s = load("sensors_layers",
                                   "sim:\n  sensors:\n    preset: mems\n    seed: 11\n"
                                   "    imu: {gyro: {noise_rad_s_per_sqrt_hz: 0.001, delay_ticks: 2, bias_offset_rad_s: [0.02, 0, -0.01]},\n"
                                   "          accel: {bias_offset_m_s2: [0, 0.3, 0]}}\n"
                                   "    encoders: {preset: ideal}\n"
                                   "    joint_torque: {noise_std_nm: [0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15, 16, 17, 18]}\n"
                                   "    wrist_ft: {force_range_n: [10, 20, 30]}\n");
  const sim::SensorModelConfig& c = s.sim.sensors;
  const sim::SensorModelConfig mems = sim::sensor_preset(sim::ImuPreset::mems);
  EXPECT_EQ(c.seed, 11u);
  EXPECT_EQ(c.imu.gyro.noise_per_sqrt_hz, 0.001);
  EXPECT_EQ(c.imu.gyro.delay_ticks, 2);
  EXPECT_EQ(c.imu.gyro.bias_offset, Vec3(0.02, 0.0, -0.01));
  EXPECT_EQ(c.imu.accel.bias_offset, Vec3(0.0, 0.3, 0.0));
  EXPECT_EQ(c.imu.gyro.lsb, mems.imu.gyro.lsb) << "the preset's other values stay";
  EXPECT_EQ(c.imu.accel.noise_per_sqrt_hz, mems.imu.accel.noise_per_sqrt_hz);
  EXPECT_TRUE(sim::is_ideal(c.encoders));
  EXPECT_EQ(c.joint_torque.noise_std_nm[18], 18.0);
  EXPECT_EQ(c.joint_torque.offset_std_nm, mems.joint_torque.offset_std_nm);
  EXPECT_EQ(c.wrist_ft.force_range_n, Vec3(10, 20, 30));
  EXPECT_EQ(c.wrist_ft.force_lsb_n, 1.0 / 16.0);
  EXPECT_FALSE(s.sim.imu.active());

  const simtool::Scenario t = load("sensors_tactical_imu", "sim: {sensors: {imu: {preset: tactical}, "
                                   "encoders: {counts_per_rev: 4096, gear_ratio: 6, velocity: lowpass, velocity_cutoff_hz: 200}}}\n");
  EXPECT_EQ(t.sim.sensors.imu.gyro.noise_per_sqrt_hz, sim::imu_preset(sim::ImuPreset::tactical).gyro.noise_per_sqrt_hz);
  EXPECT_TRUE(sim::is_ideal(t.sim.sensors.wrist_ft)) << "a section's preset touches only its section";
  EXPECT_EQ(t.sim.sensors.encoders.velocity, sim::EncoderVelocity::lowpass);
  EXPECT_EQ(t.sim.sensors.encoders.gear_ratio, VecNj::Constant(6.0));
}

TEST(ScenarioSensors, TheLegacyImuKeysKeepTheirMeaning) {
  const simtool::Scenario s =
      load("sensors_legacy", "sim: {imu: {gyro_noise_rad_s: 0.005, accel_bias_m_s2: 0.1, seed: 4}, "
                             "sensors: {encoders: {preset: realistic}}}\n");
  EXPECT_EQ(s.sim.imu.gyro_noise_rad_s, 0.005);
  EXPECT_EQ(s.sim.imu.accel_bias_m_s2, 0.1);
  EXPECT_EQ(s.sim.imu.seed, 4u);
  EXPECT_TRUE(sim::is_ideal(s.sim.sensors.imu)) << "the IMU's model stays the legacy one (BulletRobot maps it)";
  EXPECT_FALSE(sim::is_ideal(s.sim.sensors.encoders));
  EXPECT_THROW(load("sensors_conflict", "sim: {imu: {accel_noise_m_s2: 0.04}, sensors: {seed: 2}}\n"),
               simtool::ScenarioError);
}

}  // namespace
}  // namespace springbok::test
