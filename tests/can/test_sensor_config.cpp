// The sensors' part of the CAN config (CAN.md 6): YAML fields and defaults, ids that
// collide with a drive on the same bus, and the bus load with the sensors (6.3).
#include <gtest/gtest.h>

#include <string>

#include "springbok/can/bus_load.hpp"
#include "springbok/can/config_yaml.hpp"

namespace springbok::can {
namespace {

// CAN.md 4.2 step 3's expected pose, which a config with MIT drives must give: the stance.
constexpr const char* kStartPose =
    "start_pose: {q_rad: [0, 0.7, -1.4, 0, 0.7, -1.4, 0, -0.7, 1.4, 0, -0.7, 1.4, 0, 0, 0, 0, 0, 0, 0]}";

std::string with_sensors(const std::string& sensors, const std::string& layout = "classic7",
                         const std::string& protocol = "mit") {
  // The sensors' own bus where a sensor is on it (a bus with neither drives nor sensors is refused).
  const std::string own_bus =
      sensors.find("bus: sensors") != std::string::npos ? "\n  extra_buses:\n    - {name: sensors, interface: can7}" : "";
  return "can:\n  layout: " + layout + "\n  protocol: " + protocol + own_bus + "\n  " + kStartPose + "\n  sensors:\n" +
         sensors;
}

TEST(SensorConfig, OwnBusWithDefaults) {
  const ConfigResult r = load_can_config_text(with_sensors("    imu: {bus: sensors}\n    wrist_ft: {bus: sensors}\n"));
  ASSERT_TRUE(r.ok) << r.error;
  ASSERT_EQ(r.config.buses.size(), 8u);
  EXPECT_EQ(r.config.buses[7].name, "sensors");
  EXPECT_TRUE(r.config.buses[7].drives.empty());
  const ImuConfig& imu = r.config.sensors.imu;
  EXPECT_TRUE(imu.enabled);
  EXPECT_EQ(imu.ids, (std::array<std::uint32_t, 3>{0x6A0, 0x6A1, 0x6A2}));
  EXPECT_EQ(imu.scales.orientation_per_count, 1.0 / 32768.0);
  EXPECT_EQ(imu.scales.rate_rad_s_per_count, 1.0 / 1024.0);
  EXPECT_EQ(imu.scales.accel_m_s2_per_count, 1.0 / 512.0);
  EXPECT_EQ(imu.stale_ticks, 3u);
  const FtConfig& ft = r.config.sensors.wrist_ft;
  EXPECT_EQ(ft.ids, (std::array<std::uint32_t, 2>{0x6B0, 0x6B1}));
  EXPECT_EQ(ft.counts_per_n, 64.0);
  EXPECT_EQ(ft.counts_per_nm, 1000.0);
  EXPECT_EQ(ft.stale_ticks, 3u);
  EXPECT_EQ(ft.tare_samples, 500u);
  EXPECT_FALSE(ft.has_offset);
  // CAN.md 6.3: IMU 3 x 135 + F/T 2 x 135 = 675 us per 1 ms: 67.5 %.
  const BusLoad l = worst_case_load(r.config.buses[7], 1000.0, r.config.sensors);
  EXPECT_EQ(l.frames_per_tick, 5);
  EXPECT_NEAR(l.bus_time_us, 675.0, 1e-9);
  EXPECT_NEAR(l.load, 0.675, 1e-12);
  // The drive buses are unchanged by sensors elsewhere.
  EXPECT_NEAR(worst_case_load(r.config.buses[0], 1000.0, r.config.sensors).load, 0.75, 1e-12);
  // No sensors: the section is optional.
  const ConfigResult none = load_can_config_text(std::string("can: {layout: classic7, ") + kStartPose + "}");
  ASSERT_TRUE(none.ok);
  EXPECT_FALSE(none.config.sensors.imu.enabled);
  EXPECT_FALSE(none.config.sensors.wrist_ft.enabled);
}

TEST(SensorConfig, EveryFieldIsRead) {
  const ConfigResult r = load_can_config_text(with_sensors(
      "    imu: {bus: sensors, ids: [0x10, 0x11, 0x12], orientation_per_count: 0.0001, rate_rad_s_per_count: 0.002,\n"
      "          accel_m_s2_per_count: 0.004, stale_ticks: 5, clip_streak: 7, rate_hz: 500}\n"
      "    wrist_ft: {bus: sensors, ids: [0x20, 0x21], counts_per_n: 32, counts_per_nm: 2000, stale_ticks: 2,\n"
      "               tare_samples: 1000, clip_streak: 4, offset: {xyz_m: [0, 0, 0.05], rpy_rad: [0, 0, 1.5]}}\n"));
  ASSERT_TRUE(r.ok) << r.error;
  const ImuConfig& imu = r.config.sensors.imu;
  EXPECT_EQ(imu.ids, (std::array<std::uint32_t, 3>{0x10, 0x11, 0x12}));
  EXPECT_EQ(imu.scales.orientation_per_count, 0.0001);
  EXPECT_EQ(imu.scales.rate_rad_s_per_count, 0.002);
  EXPECT_EQ(imu.scales.accel_m_s2_per_count, 0.004);
  EXPECT_EQ(imu.stale_ticks, 5u);
  EXPECT_EQ(imu.clip_streak, 7u);
  EXPECT_EQ(imu.rate_hz, 500.0);
  const FtConfig& ft = r.config.sensors.wrist_ft;
  EXPECT_EQ(ft.ids, (std::array<std::uint32_t, 2>{0x20, 0x21}));
  EXPECT_EQ(ft.counts_per_n, 32.0);
  EXPECT_EQ(ft.counts_per_nm, 2000.0);
  EXPECT_EQ(ft.stale_ticks, 2u);
  EXPECT_EQ(ft.tare_samples, 1000u);
  EXPECT_EQ(ft.clip_streak, 4u);
  EXPECT_TRUE(ft.has_offset);
  EXPECT_EQ(ft.offset.xyz_m[2], 0.05);
  EXPECT_EQ(ft.offset.rpy_rad[2], 1.5);
  // IMU at 500 Hz: 1.5 frames per tick (rounded up to 2) = 202.5 us; F/T 270 us.
  const BusLoad l = worst_case_load(r.config.buses[7], 1000.0, r.config.sensors);
  EXPECT_EQ(l.frames_per_tick, 4);
  EXPECT_NEAR(l.bus_time_us, 472.5, 1e-9);
}

struct BadCase {
  const char* sensors;
  const char* error;
};

TEST(SensorConfig, ErrorsNameTheField) {
  const BadCase cases[] = {
      {"    imu: {ids: [1, 2, 3]}\n", "can.sensors.imu.bus: missing"},
      {"    imu: {bus: nowhere}\n", "can.sensors.imu.bus: no bus named 'nowhere'"},
      {"    imu: {bus: sensors, ids: [0x6A0, 0x6A1]}\n", "can.sensors.imu.ids: must be a list of 3, got 2 elements"},
      {"    imu: {bus: sensors, ids: [0x6A0, 0x6A1, 0x800]}\n", "can.sensors.imu.ids[2]: must be in [0, 2047], got 0x800"},
      {"    imu: {bus: sensors, ids: [0x6A0, 0x6A1, 0x6A0]}\n", "can.sensors.imu.ids[2]: 0x6A0 used twice on bus 'sensors'"},
      {"    imu: {bus: sensors}\n    wrist_ft: {bus: sensors, ids: [0x6B0, 0x6A2]}\n",
       "can.sensors.wrist_ft.ids[1]: 0x6A2 used twice on bus 'sensors'"},
      {"    imu: {bus: sensors, rate_rad_s_per_count: 0}\n", "can.sensors.imu.rate_rad_s_per_count: must be > 0"},
      {"    imu: {bus: sensors, orientation_per_count: .nan}\n", "can.sensors.imu.orientation_per_count: must be a finite number"},
      {"    imu: {bus: sensors, stale_ticks: 0}\n", "can.sensors.imu.stale_ticks: must be in [1, 127], got 0"},
      {"    imu: {bus: sensors, colour: red}\n", "can.sensors.imu.colour: unknown key"},
      {"    wrist_ft: {bus: sensors, counts_per_n: -64}\n", "can.sensors.wrist_ft.counts_per_n: must be > 0"},
      {"    wrist_ft: {bus: sensors, tare_samples: 0}\n", "can.sensors.wrist_ft.tare_samples: must be in [1, 1000000], got 0"},
      {"    wrist_ft: {bus: sensors, offset: {xyz_m: [0, 0]}}\n", "can.sensors.wrist_ft.offset.xyz_m: must be a list of 3, got 2 elements"},
      {"    wrist_ft: {bus: sensors, offset: {rpy: [0, 0, 0]}}\n", "can.sensors.wrist_ft.offset.rpy: unknown key"},
      {"    barometer: {bus: sensors}\n", "can.sensors.barometer: unknown key"},
  };
  for (const BadCase& c : cases) {
    const ConfigResult r = load_can_config_text(with_sensors(c.sensors));
    EXPECT_FALSE(r.ok) << c.sensors;
    EXPECT_NE(r.error.find(c.error), std::string::npos) << "expected '" << c.error << "' in: " << r.error;
  }
  // A bus with neither drives nor a sensor.
  const ConfigResult empty = load_can_config_text("can:\n  layout: classic7\n  extra_buses: [{name: spare, interface: can9}]\n");
  EXPECT_NE(empty.error.find("can.buses[7].drives: no drive or sensor on bus 'spare'"), std::string::npos) << empty.error;
}

TEST(SensorConfig, IdsCollidingWithADriveOnTheSameBusAreRefused) {
  // MIT bus 'lf' (drives 1..3, replies 0x101..0x103): command id 3, reply id 0x102.
  const BadCase mit[] = {
      {"    imu: {bus: lf, ids: [0x6A0, 0x003, 0x6A2]}\n",
       "can.sensors.imu.ids[1]: 0x003 collides with the MIT command id of drive 3 on bus 'lf'"},
      {"    wrist_ft: {bus: lf, ids: [0x102, 0x6B1]}\n",
       "can.sensors.wrist_ft.ids[0]: 0x102 collides with the MIT reply id of drive 2 on bus 'lf'"},
  };
  for (const BadCase& c : mit) {
    const ConfigResult r = load_can_config_text(with_sensors(c.sensors));
    EXPECT_NE(r.error.find(c.error), std::string::npos) << "expected '" << c.error << "' in: " << r.error;
  }
  // The same id on another bus is no collision (bus 'sensors' has no drives); F/T alone on
  // 'arm2' (2 MIT joints: 500 us + 270 us = 77 %) is within the limit.
  EXPECT_TRUE(load_can_config_text(with_sensors("    imu: {bus: sensors, ids: [0x001, 0x101, 0x6A2]}\n")).ok);
  EXPECT_TRUE(load_can_config_text(with_sensors("    wrist_ft: {bus: arm2}\n")).ok);
  // CiA 402 bus 'lf' (nodes 1..3): every COB-ID of the pre-defined connection set, NMT and SYNC.
  const BadCase cia[] = {
      {"    wrist_ft: {bus: lf, ids: [0x6B0, 0x181]}\n", "0x181 collides with the CANopen TPDO1 COB-ID of node 1 on bus 'lf'"},
      {"    wrist_ft: {bus: lf, ids: [0x6B0, 0x283]}\n", "0x283 collides with the CANopen TPDO2 COB-ID of node 3 on bus 'lf'"},
      {"    wrist_ft: {bus: lf, ids: [0x202, 0x6B1]}\n", "0x202 collides with the CANopen RPDO1 COB-ID of node 2 on bus 'lf'"},
      {"    wrist_ft: {bus: lf, ids: [0x6B0, 0x082]}\n", "0x082 collides with the CANopen EMCY COB-ID of node 2 on bus 'lf'"},
      {"    wrist_ft: {bus: lf, ids: [0x6B0, 0x583]}\n", "0x583 collides with the CANopen SDO response COB-ID of node 3"},
      {"    wrist_ft: {bus: lf, ids: [0x601, 0x6B1]}\n", "0x601 collides with the CANopen SDO request COB-ID of node 1"},
      {"    wrist_ft: {bus: lf, ids: [0x6B0, 0x703]}\n", "0x703 collides with the CANopen heartbeat COB-ID of node 3"},
      {"    wrist_ft: {bus: lf, ids: [0x6B0, 0x503]}\n", "0x503 collides with the CANopen RPDO4 COB-ID of node 3"},
      {"    wrist_ft: {bus: lf, ids: [0x000, 0x6B1]}\n", "0x000 collides with the CANopen NMT id on bus 'lf'"},
      {"    wrist_ft: {bus: lf, ids: [0x6B0, 0x080]}\n", "0x080 collides with the CANopen SYNC id on bus 'lf'"},
  };
  for (const BadCase& c : cia) {
    const ConfigResult r = load_can_config_text(with_sensors(c.sensors, "classic7", "cia402"));
    EXPECT_NE(r.error.find(c.error), std::string::npos) << "expected '" << c.error << "' in: " << r.error;
  }
  // 0x184 is node 4's TPDO1: on bus 'rf', not on 'lf'. (The load check then refuses 'lf':
  // 745 us + 270 us; that is the next test's subject.)
  std::string why;
  EXPECT_FALSE(sensor_id_collides(classic7_layout(Protocol::cia402).buses[0], 0x184, why));
  EXPECT_TRUE(sensor_id_collides(classic7_layout(Protocol::cia402).buses[1], 0x184, why));
  EXPECT_EQ(why, "the CANopen TPDO1 COB-ID of node 4");
}

TEST(SensorConfig, BusLoadWithTheSensorsIsRefusedNamingTheBus) {
  // IMU on 'arm2' (2 MIT joints, 500 us): + 3 x 135 = 905 us, 90.5 %.
  ConfigResult r = load_can_config_text(with_sensors("    imu: {bus: arm2}\n"));
  EXPECT_FALSE(r.ok);
  EXPECT_NE(r.error.find("can.buses: bus 'arm2' (can6): worst-case load 90.5 % (7 frames, 905.0 us per 1000 us tick)"),
            std::string::npos)
      << r.error;
  // Both sensors on a 1 Mbit/s bus of their own fit (67.5 %); at 500 kbit/s they do not (135 %).
  r = load_can_config_text(
      "can:\n  layout: classic7\n  extra_buses: [{name: sensors, interface: can7, bitrate: 500000}]\n"
      "  sensors: {imu: {bus: sensors}, wrist_ft: {bus: sensors}}\n  " + std::string(kStartPose) + "\n");
  EXPECT_FALSE(r.ok);
  EXPECT_NE(r.error.find("bus 'sensors' (can7): worst-case load 135.0 %"), std::string::npos) << r.error;
  // check_bus_loads on a built config, the sensors counted.
  CanConfig c = classic7_layout(Protocol::mit);
  c.sensors.wrist_ft.enabled = true;
  c.sensors.wrist_ft.bus = "lf";  // 750 us + 270 us
  EXPECT_NE(check_bus_loads(c).find("bus 'lf' (can0): worst-case load 102.0 %"), std::string::npos) << check_bus_loads(c);
  EXPECT_NEAR(worst_case_load(c.buses[0], 1000.0).load, 0.75, 1e-12);  // the drives' part alone
  // On an FD bus the sensor frames are classic frames at the nominal rate.
  CanConfig fd = fd5_layout();
  fd.sensors.imu.enabled = true;
  fd.sensors.imu.bus = "arm";
  EXPECT_NEAR(worst_case_load(fd.buses[4], 1000.0, fd.sensors).bus_time_us, 756.0 + 405.0, 1e-6);
}

TEST(SensorConfig, ExampleFilesPutTheSensorsOnTheirOwnBus) {
  const ConfigResult r = load_can_config_file(std::string(SPRINGBOK_SOURCE_DIR) + "/tests/hil/config/mit_fd5.yaml");
  ASSERT_TRUE(r.ok) << r.error;
  ASSERT_TRUE(r.config.sensors.imu.enabled);
  ASSERT_TRUE(r.config.sensors.wrist_ft.enabled);
  EXPECT_EQ(r.config.sensors.imu.bus, "sensors");
  EXPECT_EQ(r.config.sensors.wrist_ft.bus, "sensors");
  EXPECT_EQ(r.config.buses.back().name, "sensors");
  EXPECT_TRUE(r.config.buses.back().drives.empty());
}

}  // namespace
}  // namespace springbok::can
