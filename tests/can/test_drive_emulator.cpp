// The emulator's drive side against the host codecs and CAN.md's worked examples
// (in process, no sockets), and the drive_emulator command line.
#include <gtest/gtest.h>

#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <string>
#include <vector>

#include "springbok/can/cia402.hpp"
#include "springbok/can/mit.hpp"
#include "springbok/can/sensors.hpp"
#include "springbok/can/socketcan.hpp"
#include "springbok/drive_emulator/drives.hpp"
#include "springbok/drive_emulator/sensors.hpp"

#include "frame_util.hpp"
#include "run_command.hpp"

namespace springbok::emu {
namespace {

using can::frame_util::bytes;
using can::frame_util::frame_of;

using can::Frame;
namespace c4 = can::cia402;

TEST(DriveEmulator, MitDriveRepliesToEveryFrameWithTheWorkedExampleBytes) {
  can::DriveConfig cfg = can::default_drive(2, can::Protocol::mit);  // drive 3
  cfg.mit_ranges = can::mit::Ranges{};                               // Mini Cheetah ranges of CAN.md 1.6
  JointModel model = make_joint_model(2, 0.5);
  model.qd_rad_s = 1.25;
  model.tau_nm = -2.0;
  MitDrive drive(cfg, false, model, {}, 0);
  std::vector<Frame> out;
  // A command while not in motor mode is stored and answered with the state at reception.
  drive.on_frame(frame_of(0x003, {0x8A, 0x3C, 0x7C, 0x01, 0x99, 0x33, 0x39, 0x54}), 0, out);
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(out[0].id, 0x103u);
  EXPECT_EQ(bytes(out[0]), (std::vector<int>{0x03, 0x85, 0x1E, 0x82, 0x67, 0x1C}));
  EXPECT_FALSE(drive.enabled());
  // A frame for another drive is not answered.
  drive.on_frame(frame_of(0x004, {0, 0, 0, 0, 0, 0, 0, 0}), 0, out);
  EXPECT_EQ(out.size(), 1u);
  Frame enter;
  can::mit::encode_special(3, can::mit::Special::enter_motor_mode, enter);
  drive.on_frame(enter, 0, out);
  EXPECT_TRUE(drive.enabled());
  EXPECT_EQ(out.size(), 2u);
}

TEST(DriveEmulator, Cia402DriveAnswersTheWorkedSdoExamplesAndEnables) {
  const can::DriveConfig cfg = can::default_drive(2, can::Protocol::cia402);  // node 3
  Cia402Drive drive(cfg, make_joint_model(2, -1.4), {}, 0);
  std::vector<Frame> out;
  drive.boot(0, out);
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(out[0].id, 0x703u);
  EXPECT_EQ(bytes(out[0]), (std::vector<int>{0x00}));
  out.clear();
  drive.on_frame(frame_of(0x603, {0x2F, 0x60, 0x60, 0x00, 0x0A, 0x00, 0x00, 0x00}), 0, out);
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(out[0].id, 0x583u);
  EXPECT_EQ(bytes(out[0]), (std::vector<int>{0x60, 0x60, 0x60, 0x00, 0x00, 0x00, 0x00, 0x00}));

  // The host's PDO mapping sequence is accepted entry by entry.
  std::array<c4::SdoWrite, c4::kMaxMappingWrites> seq{};
  const int n = c4::pdo_mapping_sequence(3, c4::Mapping::compact, seq);
  for (int i = 0; i < n; ++i) {
    out.clear();
    Frame req;
    c4::encode_sdo_request(3, c4::SdoRequest{c4::SdoRequest::Kind::write, seq[i].index, seq[i].sub, seq[i].value, seq[i].size}, req);
    drive.on_frame(req, 0, out);
    ASSERT_EQ(out.size(), 1u);
    c4::SdoResponse res;
    ASSERT_EQ(c4::decode_sdo_response(out[0], 3, res), can::FrameStatus::ok);
    EXPECT_EQ(res.kind, c4::SdoResponse::Kind::write_ok) << "write " << i << " aborted: " << c4::abort_code_name(res.value);
  }
  // Reading a missing object aborts with 0x06020000.
  out.clear();
  drive.on_frame(frame_of(0x603, {0x40, 0x34, 0x12, 0x00, 0, 0, 0, 0}), 0, out);
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(bytes(out[0]), (std::vector<int>{0x80, 0x34, 0x12, 0x00, 0x00, 0x00, 0x02, 0x06}));

  // NMT start, then walk the state machine through RPDO1 + SYNC.
  Frame f;
  c4::encode_nmt(c4::NmtCommand::start, 3, f);
  drive.on_frame(f, 0, out);
  std::uint16_t cw = 0;
  c4::State s = c4::State::unknown;
  for (int cycle = 0; cycle < 10 && s != c4::State::operation_enabled; ++cycle) {
    cw = c4::controlword_towards_enabled(s, cw);
    c4::encode_rpdo1(3, c4::Rpdo1{cw, 0}, f);
    drive.on_frame(f, 0, out);
    out.clear();
    c4::encode_sync(f);
    drive.on_frame(f, 0, out);
    ASSERT_EQ(out.size(), 1u);  // compact TPDO1 only
    c4::Feedback fb;
    ASSERT_EQ(c4::decode_tpdo1(out[0], 3, c4::Mapping::compact, fb), can::FrameStatus::ok);
    s = c4::decode_statusword(fb.statusword);
    EXPECT_NEAR(fb.position / cfg.counts_per_rad, -1.4, 1.0 / cfg.counts_per_rad);
  }
  EXPECT_EQ(s, c4::State::operation_enabled);
  // The statusword reads back as in CAN.md's example.
  out.clear();
  drive.on_frame(frame_of(0x603, {0x40, 0x41, 0x60, 0x00, 0x00, 0x00, 0x00, 0x00}), 0, out);
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(bytes(out[0]), (std::vector<int>{0x4B, 0x41, 0x60, 0x00, 0x37, 0x02, 0x00, 0x00}));
}

TEST(DriveEmulator, FaultScriptErrorsNameTheEntry) {
  EXPECT_TRUE(load_faults_text("faults: [{kind: silent, drive: 5, at: 50}]").ok);
  EXPECT_NE(load_faults_text("faults: [{kind: melt, drive: 5, at: 1}]").error.find("faults[0].kind"), std::string::npos);
  EXPECT_NE(load_faults_text("faults: [{kind: drop, drive: 500, at: 1}]").error.find("faults[0].drive"), std::string::npos);
  EXPECT_NE(load_faults_text("faults: [{kind: drop, drive: 5, at: 0}]").error.find("faults[0].at"), std::string::npos);
  EXPECT_NE(load_faults_text("faults: [{kind: drop, drive: 5, at: 1, colour: red}]").error.find("faults[0].colour"),
            std::string::npos);
}

// ---- sensors (CAN.md 6.5) ---------------------------------------------------------------------
can::SensorsConfig both_sensors() {
  can::SensorsConfig c;
  c.imu.enabled = true;
  c.imu.bus = "sensors";
  c.wrist_ft.enabled = true;
  c.wrist_ft.bus = "sensors";
  return c;
}

// The host side: the emulator's frames into hal/can's assemblers, one tick per sample.
struct SensorRig {
  can::SensorsConfig cfg = both_sensors();
  SensorEmulator emu;
  can::ImuAssembler imu;
  can::FtAssembler ft;
  hal::Imu imu_in;
  hal::Wrench wrist_in;
  std::vector<Frame> imu_out, ft_out;
  std::uint64_t tick = 0;
  explicit SensorRig(const std::vector<Fault>& faults = {}, const can::SensorsConfig& c = both_sensors())
      : cfg(c), emu(c, faults) {
    imu.configure(cfg.imu, 0);
    ft.configure(cfg.wrist_ft, 0);
    imu_in.valid = true;
    imu_in.orientation = Eigen::Quaterniond(Eigen::AngleAxisd(0.3, Eigen::Vector3d(1, 2, 3).normalized()));
    imu_in.angular_rate_rad_s = Eigen::Vector3d(0.25, -1.5, 3.0);
    imu_in.linear_accel_m_s2 = Eigen::Vector3d(0.5, -0.2, 9.81);
    wrist_in.valid = true;
    wrist_in.force_n = Eigen::Vector3d(12.0, -3.0, 40.0);
    wrist_in.torque_nm = Eigen::Vector3d(0.5, 1.25, -2.0);
  }
  // One world step; returns the host's events of this tick.
  std::vector<can::SensorEvent> step() {
    ++tick;
    imu_out.clear();
    ft_out.clear();
    emu.publish(imu_in, wrist_in, imu_out, ft_out);
    std::vector<can::SensorEvent> ev;
    for (const Frame& f : imu_out) ev.push_back(imu.push(f, tick));
    for (const Frame& f : ft_out) ev.push_back(ft.push(f, tick));
    imu.update(tick);
    ft.update(tick);
    return ev;
  }
};

TEST(SensorEmulator, PublishedFramesDecodeBackToTheSampleWithinQuantization) {
  SensorRig rig;
  for (int k = 0; k < 300; ++k) {  // the counter wraps at 256
    rig.imu_in.angular_rate_rad_s.x() = 0.01 * k;
    rig.step();
    ASSERT_EQ(rig.imu_out.size(), 3u);
    ASSERT_EQ(rig.ft_out.size(), 2u);
    ASSERT_TRUE(rig.imu.usable()) << k;
    ASSERT_TRUE(rig.ft.usable()) << k;
    const can::ImuReading r = rig.imu.reading();
    EXPECT_LT(r.orientation.angularDistance(rig.imu_in.orientation), 4.0 / 32768.0) << k;
    EXPECT_LE((r.angular_rate_rad_s - rig.imu_in.angular_rate_rad_s).cwiseAbs().maxCoeff(), 0.5 / 1024.0 + 1e-12);
    EXPECT_LE((r.linear_accel_m_s2 - rig.imu_in.linear_accel_m_s2).cwiseAbs().maxCoeff(), 0.5 / 512.0 + 1e-12);
    EXPECT_LE((rig.ft.reading().force_n - rig.wrist_in.force_n).cwiseAbs().maxCoeff(), 0.5 / 64.0 + 1e-12);
    EXPECT_LE((rig.ft.reading().torque_nm - rig.wrist_in.torque_nm).cwiseAbs().maxCoeff(), 0.5 / 1000.0 + 1e-12);
  }
  EXPECT_EQ(rig.imu.diagnostics().samples_accepted, 300u);
  EXPECT_EQ(rig.imu.diagnostics().last_counter, 299 % 256);
  EXPECT_EQ(rig.ft.diagnostics().samples_accepted, 300u);
  EXPECT_EQ(rig.emu.frames_out(), 1500u);
}

// A sample the world's sensor model saturated (hal::Imu / hal::Wrench clipping) goes on the bus
// with the clipping status bit: the host counts it and, held clip_streak (10) samples, latches
// the streak the supervisor faults on.
TEST(SensorEmulator, TheSamplesClippingReachesTheHost) {
  SensorRig rig;
  rig.step();
  EXPECT_EQ(rig.imu.diagnostics().clipped, 0u);
  rig.imu_in.clipping = true;
  rig.wrist_in.clipping = true;
  for (int k = 0; k < 10; ++k) rig.step();
  EXPECT_EQ(rig.imu.diagnostics().clipped, 10u);
  EXPECT_EQ(rig.ft.diagnostics().clipped, 10u);
  EXPECT_TRUE(rig.imu.diagnostics().clip_streak_fault);
  EXPECT_TRUE(rig.ft.diagnostics().clip_streak_fault);
  EXPECT_EQ(rig.imu.diagnostics().samples_accepted, 11u) << "a clipped sample is still used";
}

TEST(SensorEmulator, OffsetWrenchGoesToTheSensorFrameAndBack) {
  can::SensorsConfig c = both_sensors();
  c.wrist_ft.has_offset = true;
  c.wrist_ft.offset.xyz_m = {0.01, -0.02, 0.05};
  c.wrist_ft.offset.rpy_rad = {0.1, -0.2, 1.0};
  SensorRig rig({}, c);
  rig.step();
  ASSERT_TRUE(rig.ft.usable());
  EXPECT_LE((rig.ft.reading().force_n - rig.wrist_in.force_n).norm(), 0.03);
  EXPECT_LE((rig.ft.reading().torque_nm - rig.wrist_in.torque_nm).norm(), 0.003);
  // The frames carry the sensor-frame wrench, not the EE one: F_s = R^T F_ee.
  can::FtConfig plain = c.wrist_ft;
  plain.has_offset = false;
  can::FtAssembler raw;
  raw.configure(plain, 0);
  for (const Frame& f : rig.ft_out) raw.push(f, 1);
  raw.update(1);
  const Eigen::Matrix3d rot = can::wrench_transform(c.wrist_ft.offset).rotation;
  EXPECT_LE((raw.reading().force_n - rot.transpose() * rig.wrist_in.force_n).norm(), 0.03);
}

TEST(SensorEmulator, EachScriptedFaultIsSeenByTheHostAsSpecified) {
  const auto run = [](const std::string& script) {
    const FaultResult fr = load_faults_text(script);
    EXPECT_TRUE(fr.ok) << fr.error;
    SensorRig rig(fr.faults);
    std::vector<std::vector<can::SensorEvent>> ticks;
    for (int k = 0; k < 12; ++k) ticks.push_back(rig.step());
    return std::make_pair(std::move(rig), std::move(ticks));
  };
  using can::SensorEvent;
  {  // Silence from sample 5: lost once the newest sample (4) is older than 3 ticks.
    auto [rig, ticks] = run("faults: [{kind: silent, sensor: imu, at: 5}]");
    EXPECT_TRUE(ticks[4].size() == 2u);  // only the F/T's two frames
    EXPECT_EQ(rig.imu.diagnostics().samples_accepted, 4u);
    EXPECT_TRUE(rig.imu.diagnostics().lost);
    EXPECT_EQ(rig.imu.diagnostics().age_ticks, 8u);
    EXPECT_FALSE(rig.ft.diagnostics().lost);
  }
  {  // Stale counter for 2 samples: both rejected as stale.
    auto [rig, ticks] = run("faults: [{kind: stale_counter, sensor: wrist_ft, at: 3, count: 2}]");
    EXPECT_EQ(ticks[2].back(), SensorEvent::stale_counter);
    EXPECT_EQ(ticks[3].back(), SensorEvent::stale_counter);
    EXPECT_EQ(ticks[4].back(), SensorEvent::accepted);  // counter 2 -> 3: one step
    EXPECT_EQ(rig.ft.diagnostics().stale_counters, 2u);
  }
  {  // Status invalid.
    auto [rig, ticks] = run("faults: [{kind: status_invalid, sensor: imu, at: 2, count: 3}]");
    EXPECT_EQ(ticks[1][2], SensorEvent::status_invalid);
    EXPECT_EQ(rig.imu.diagnostics().status_invalid, 3u);
    EXPECT_EQ(rig.imu.diagnostics().samples_accepted, 9u);
  }
  {  // Corrupt quaternion.
    auto [rig, ticks] = run("faults: [{kind: corrupt_quaternion, sensor: imu, at: 6}]");
    EXPECT_EQ(ticks[5][2], SensorEvent::bad_quaternion);
    EXPECT_EQ(rig.imu.diagnostics().bad_quaternion, 1u);
  }
  {  // Saturation: used, counted, a streak once it lasts clip_streak (10) samples.
    auto [rig, ticks] = run("faults: [{kind: saturate, sensor: wrist_ft, at: 1, count: 10}]");
    EXPECT_EQ(rig.ft.diagnostics().clipped, 10u);
    EXPECT_EQ(rig.ft.diagnostics().clip_streak_max, 10u);
    EXPECT_EQ(rig.ft.diagnostics().samples_accepted, 12u);
    EXPECT_FALSE(rig.ft.diagnostics().clip_streak_fault);  // ended at sample 11
  }
  {  // Split: each sample's last frame comes one tick late; every sample still completes.
    auto [rig, ticks] = run("faults: [{kind: split, sensor: imu, at: 3, count: 4}]");
    EXPECT_EQ(ticks[2].size(), 2u + 2u);  // IMU orientation + rate of sample 3, F/T
    EXPECT_EQ(ticks[2][1], SensorEvent::stored);
    EXPECT_EQ(ticks[3][0], SensorEvent::accepted);  // sample 3's acceleration, held over
    EXPECT_EQ(rig.imu.diagnostics().samples_accepted, 12u);
    EXPECT_FALSE(rig.imu.diagnostics().lost);
  }
  {  // Not converged / bias not taken: reported, samples used.
    auto [rig, ticks] = run("faults: [{kind: not_ready, sensor: wrist_ft, at: 10, count: 100}]");
    EXPECT_TRUE(rig.ft.diagnostics().not_ready);
    EXPECT_FALSE(rig.imu.diagnostics().not_ready);
    EXPECT_EQ(rig.ft.diagnostics().samples_accepted, 12u);
  }
  {  // Wrong DLC (sample 2's three frames); drop of 4 F/T samples: the counter moves on, 0 -> 5 is a jump of 5 > 3.
    auto [rig, ticks] = run("faults: [{kind: wrong_dlc, sensor: imu, at: 2}, {kind: drop, sensor: wrist_ft, at: 2, count: 4}]");
    EXPECT_EQ(rig.imu.diagnostics().wrong_dlc, 3u);
    EXPECT_EQ(rig.ft.diagnostics().counter_jumps, 1u);  // counter 0 -> 5
    EXPECT_EQ(rig.ft.diagnostics().samples_accepted, 1u + 6u);
  }
}

TEST(SensorEmulator, FaultScriptSensorEntries) {
  const FaultResult ok = load_faults_text("faults: [{kind: split, sensor: wrist_ft, at: 3, count: 2}, {kind: silent, sensor: imu, at: 9}]");
  ASSERT_TRUE(ok.ok) << ok.error;
  EXPECT_EQ(ok.faults[0].sensor, SensorId::wrist_ft);
  EXPECT_EQ(ok.faults[0].kind, FaultKind::split);
  EXPECT_EQ(ok.faults[1].sensor, SensorId::imu);
  EXPECT_EQ(ok.faults[1].drive_id, 0);
  EXPECT_NE(load_faults_text("faults: [{kind: split, drive: 3, at: 1}]").error.find("faults[0].sensor"), std::string::npos);
  EXPECT_NE(load_faults_text("faults: [{kind: split, sensor: gps, at: 1}]").error.find("faults[0].sensor"), std::string::npos);
  EXPECT_NE(load_faults_text("faults: [{kind: emcy, sensor: imu, at: 1}]").error.find("not a sensor fault"), std::string::npos);
  EXPECT_NE(load_faults_text("faults: [{kind: corrupt_quaternion, sensor: wrist_ft, at: 1}]").error.find("IMU fault"),
            std::string::npos);
  EXPECT_NE(load_faults_text("faults: [{kind: silent, sensor: imu, drive: 2, at: 1}]").error.find("either"),
            std::string::npos);
}

int run(const std::string& args, std::string& output) {
  const springbok::test::CommandRun r = springbok::test::run_program("", "drive_emulator", args);
  output += r.out;
  return r.exit_code;
}
// ---- CiA 402 start-up properties the host must not assume (CAN.md 2.4, 4.3) ------------------
// One SDO request to node `n` at `now_ns`; the frames the drive sent back.
std::vector<Frame> sdo(Cia402Drive& drive, std::uint8_t n, const c4::SdoRequest& req, std::int64_t now_ns = 0) {
  Frame f;
  c4::encode_sdo_request(n, req, f);
  std::vector<Frame> out;
  drive.on_frame(f, now_ns, out);
  return out;
}
std::uint32_t sdo_read(Cia402Drive& drive, std::uint8_t n, std::uint16_t index, std::int64_t now_ns = 0) {
  const std::vector<Frame> out = sdo(drive, n, {c4::SdoRequest::Kind::read, index, 0, 0, 0}, now_ns);
  c4::SdoResponse res;
  EXPECT_EQ(out.size(), 1u);
  if (out.empty() || c4::decode_sdo_response(out[0], n, res) != can::FrameStatus::ok) return 0xDEADBEEF;
  EXPECT_EQ(res.kind, c4::SdoResponse::Kind::read_ok);
  return res.value;
}
std::vector<Fault> script(const std::string& yaml) {
  const FaultResult r = load_faults_text(yaml);
  EXPECT_TRUE(r.ok) << r.error;
  return r.faults;
}

TEST(DriveEmulator, Cia402RatedTorqueFromTheScriptScalesTheDrive) {
  const can::DriveConfig cfg = can::default_drive(12, can::Protocol::cia402);  // node 13, arm_joint_1, 39 Nm
  {  // Default: the joint's peak torque limit (flat on the arm).
    Cia402Drive drive(cfg, make_joint_model(12, 0.0), {}, 0);
    std::vector<Frame> out;
    drive.boot(0, out);
    EXPECT_EQ(sdo_read(drive, 13, c4::object::rated_torque), 39000u);
  }
  Cia402Drive drive(cfg, make_joint_model(12, 0.0), script("faults: [{kind: rated_torque, drive: 13, param: 150000}]"), 0);
  std::vector<Frame> out;
  drive.boot(0, out);
  EXPECT_EQ(sdo_read(drive, 13, c4::object::rated_torque), 150000u);
  std::array<c4::SdoWrite, c4::kMaxMappingWrites> seq{};
  const int n = c4::pdo_mapping_sequence(13, c4::Mapping::compact, seq);
  for (int i = 0; i < n; ++i) {
    ASSERT_EQ(sdo(drive, 13, {c4::SdoRequest::Kind::write, seq[i].index, seq[i].sub, seq[i].value, seq[i].size}).size(), 1u);
  }
  // Enable, then 20 per mille of 150 Nm = 3 Nm applied, and 0x6077 reads 20 back.
  Frame f;
  c4::encode_nmt(c4::NmtCommand::start, 13, f);
  drive.on_frame(f, 0, out);
  c4::State s = c4::State::unknown;
  std::uint16_t cw = 0;
  c4::Feedback fb;
  for (int cycle = 0; cycle < 12; ++cycle) {
    cw = c4::controlword_towards_enabled(s, cw);
    c4::encode_rpdo1(13, c4::Rpdo1{cw, static_cast<std::int16_t>(s == c4::State::operation_enabled ? 20 : 0)}, f);
    drive.on_frame(f, 0, out);
    out.clear();
    c4::encode_sync(f);
    drive.on_frame(f, 0, out);
    ASSERT_EQ(out.size(), 1u);
    ASSERT_EQ(c4::decode_tpdo1(out[0], 13, c4::Mapping::compact, fb), can::FrameStatus::ok);
    s = c4::decode_statusword(fb.statusword);
  }
  ASSERT_EQ(s, c4::State::operation_enabled);
  EXPECT_DOUBLE_EQ(drive.model().tau_nm, 3.0);
  EXPECT_EQ(fb.torque, 20);
}

TEST(DriveEmulator, Cia402ModeDisplayFollowsTheWriteAfterTheScriptedDelay) {
  const can::DriveConfig cfg = can::default_drive(2, can::Protocol::cia402);  // node 3
  const c4::SdoRequest cst{c4::SdoRequest::Kind::write, c4::object::modes_of_operation, 0, 10, 1};
  {  // Default: at once.
    Cia402Drive drive(cfg, make_joint_model(2, 0.0), {}, 0);
    std::vector<Frame> out;
    drive.boot(0, out);
    EXPECT_EQ(sdo(drive, 3, cst, 1000000).size(), 1u);
    EXPECT_EQ(sdo_read(drive, 3, c4::object::modes_display, 1000000), 10u);
  }
  Cia402Drive drive(cfg, make_joint_model(2, 0.0), script("faults: [{kind: mode_display_delay, drive: 3, param: 5}]"), 0);
  std::vector<Frame> out;
  drive.boot(0, out);
  EXPECT_EQ(sdo(drive, 3, cst, 1000000).size(), 1u);
  EXPECT_EQ(sdo_read(drive, 3, c4::object::modes_of_operation, 1000000), 10u);  // 0x6060 itself at once
  EXPECT_EQ(sdo_read(drive, 3, c4::object::modes_display, 1000000), 0u);
  EXPECT_EQ(sdo_read(drive, 3, c4::object::modes_display, 5999999), 0u);
  EXPECT_EQ(sdo_read(drive, 3, c4::object::modes_display, 6000000), 10u);
}

TEST(DriveEmulator, Cia402EmcyAfterTheKthSdoAnswer) {
  const can::DriveConfig cfg = can::default_drive(2, can::Protocol::cia402);  // node 3
  Cia402Drive drive(cfg, make_joint_model(2, 0.0),
                    script("faults: [{kind: emcy, drive: 3, at_sdo: 2, param: 0x3210}]"), 0);
  std::vector<Frame> out;
  drive.boot(0, out);
  EXPECT_EQ(sdo_read(drive, 3, c4::object::statusword), 0x0250u);  // 1st: switch on disabled
  const std::vector<Frame> second = sdo(drive, 3, {c4::SdoRequest::Kind::read, c4::object::supported_modes, 0, 0, 0});
  ASSERT_EQ(second.size(), 2u);  // the answer, then the EMCY
  EXPECT_EQ(second[0].id, 0x583u);
  c4::Emcy e;
  ASSERT_EQ(c4::decode_emcy(second[1], 3, e), can::FrameStatus::ok);
  EXPECT_EQ(e.error_code, 0x3210);
  EXPECT_EQ(sdo_read(drive, 3, c4::object::statusword), 0x0218u);  // Fault
  EXPECT_EQ(sdo_read(drive, 3, c4::object::error_code), 0x3210u);
}

TEST(DriveEmulator, FaultScriptDrivePropertiesAndAtSdo) {
  const FaultResult ok = load_faults_text(
      "faults: [{kind: rated_torque, drive: 3, param: 150000}, {kind: mode_display_delay, drive: 3, param: 20},"
      " {kind: emcy, drive: 4, at_sdo: 7}]");
  ASSERT_TRUE(ok.ok) << ok.error;
  EXPECT_EQ(ok.faults[0].kind, FaultKind::rated_torque);
  EXPECT_EQ(ok.faults[0].param, 150000u);
  EXPECT_EQ(ok.faults[1].kind, FaultKind::mode_display_delay);
  EXPECT_EQ(ok.faults[2].at_sdo, 7u);
  const auto error = [](const char* yaml) { return load_faults_text(yaml).error; };
  EXPECT_NE(error("faults: [{kind: rated_torque, drive: 3}]").find("faults[0].param"), std::string::npos);
  EXPECT_NE(error("faults: [{kind: rated_torque, drive: 3, param: -1}]").find("faults[0].param"), std::string::npos);
  EXPECT_NE(error("faults: [{kind: rated_torque, drive: 3, param: 1, at: 5}]").find("faults[0].at"), std::string::npos);
  EXPECT_NE(error("faults: [{kind: mode_display_delay, drive: 3, param: 0}]").find("faults[0].param"), std::string::npos);
  EXPECT_NE(error("faults: [{kind: mode_display_delay, drive: 3, param: 5, count: 2}]").find("faults[0].count"),
            std::string::npos);
  EXPECT_NE(error("faults: [{kind: drop, drive: 3, at_sdo: 2}]").find("faults[0].at_sdo"), std::string::npos);
  EXPECT_NE(error("faults: [{kind: emcy, drive: 3, at_sdo: 0}]").find("faults[0].at_sdo"), std::string::npos);
  EXPECT_NE(error("faults: [{kind: emcy, drive: 3, at: 1, at_sdo: 2}]").find("either `at` or `at_sdo`"), std::string::npos);
  EXPECT_NE(error("faults: [{kind: emcy, drive: 3}]").find("faults[0].at"), std::string::npos);
  EXPECT_NE(error("faults: [{kind: rated_torque, sensor: imu, param: 1}]").find("not a sensor fault"), std::string::npos);
}

// CAN.md 1.4: a vendor MIT drive's reply carries an error code in byte 7. One that boots with
// a fault reports it from its first reply (the host's presence check, 4.2 step 1) on.
TEST(DriveEmulator, MitVendorErrorFromPowerOnIsInEveryReply) {
  can::DriveConfig cfg = can::default_drive(7, can::Protocol::mit);  // drive 8
  cfg.mit_vendor_reply = true;
  MitDrive drive(cfg, false, make_joint_model(7, 0.0), script("faults: [{kind: vendor_error, drive: 8, param: 0x15}]"), 0);
  std::vector<Frame> out;
  Frame f;
  can::mit::encode_special(8, can::mit::Special::exit_motor_mode, f);
  drive.on_frame(f, 0, out);
  (void)can::mit::encode_command(8, can::mit::Command{}, cfg.mit_ranges, f);
  drive.on_frame(f, 0, out);
  can::mit::encode_special(8, can::mit::Special::enter_motor_mode, f);
  drive.on_frame(f, 0, out);
  (void)can::mit::encode_command(8, can::mit::Command{}, cfg.mit_ranges, f);
  drive.on_frame(f, 0, out);
  ASSERT_EQ(out.size(), 4u);
  for (const Frame& reply : out) {
    can::mit::Reply r;
    ASSERT_EQ(can::mit::decode_reply(reply, cfg.mit_ranges, r), can::FrameStatus::ok);
    EXPECT_TRUE(r.has_vendor_bytes);
    EXPECT_EQ(r.error_code, 0x15);
  }
  const auto error = [](const char* yaml) { return load_faults_text(yaml).error; };
  EXPECT_NE(error("faults: [{kind: vendor_error, drive: 8}]").find("faults[0].param"), std::string::npos);
  EXPECT_NE(error("faults: [{kind: vendor_error, drive: 8, param: 0}]").find("faults[0].param"), std::string::npos);
  EXPECT_NE(error("faults: [{kind: vendor_error, drive: 8, param: 256}]").find("faults[0].param"), std::string::npos);
  EXPECT_NE(error("faults: [{kind: vendor_error, drive: 8, param: 5, at: 3}]").find("faults[0].at"), std::string::npos);
}

// A drive lost between the host's start-up steps (HIL: activate() failing on a later bus): with
// `silent` at_frame k it takes, answers and sends nothing from its k-th frame on. MIT: the
// presence check (1) and the zero command (2) are answered, enter motor mode (3) is not, and the
// drive never enables.
TEST(DriveEmulator, SilentAtFrameUnplugsTheDriveFromItsKthFrame) {
  const can::DriveConfig cfg = can::default_drive(9, can::Protocol::mit);  // drive 10
  MitDrive drive(cfg, false, make_joint_model(9, 0.0), script("faults: [{kind: silent, drive: 10, at_frame: 3}]"), 0);
  std::vector<Frame> out;
  Frame f;
  can::mit::encode_special(10, can::mit::Special::exit_motor_mode, f);
  drive.on_frame(f, 0, out);
  (void)can::mit::encode_command(10, can::mit::Command{}, cfg.mit_ranges, f);
  drive.on_frame(f, 0, out);
  EXPECT_EQ(out.size(), 2u);
  can::mit::encode_special(10, can::mit::Special::enter_motor_mode, f);
  drive.on_frame(f, 0, out);
  (void)can::mit::encode_command(10, can::mit::Command{}, cfg.mit_ranges, f);
  drive.on_frame(f, 0, out);
  EXPECT_EQ(out.size(), 2u);
  EXPECT_FALSE(drive.enabled());
  EXPECT_TRUE(drive.unplugged());
  EXPECT_EQ(drive.frames_in(), 2u);
  // CiA 402: no heartbeat either once unplugged (its SDO request is its first frame).
  const can::DriveConfig node = can::default_drive(2, can::Protocol::cia402);  // node 3
  Cia402Drive cia(node, make_joint_model(2, 0.0), script("faults: [{kind: silent, drive: 3, at_frame: 2}]"), 0);
  cia.boot(0, out);
  EXPECT_EQ(sdo(cia, 3, {c4::SdoRequest::Kind::write, c4::object::producer_heartbeat, 0, 10, 2}).size(), 1u);
  out.clear();
  cia.on_time(20000000, out);
  EXPECT_EQ(out.size(), 1u);  // a heartbeat
  EXPECT_TRUE(sdo(cia, 3, {c4::SdoRequest::Kind::read, c4::object::statusword, 0, 0, 0}).empty());
  out.clear();
  cia.on_time(40000000, out);
  EXPECT_TRUE(out.empty());
  const auto error = [](const char* yaml) { return load_faults_text(yaml).error; };
  EXPECT_NE(error("faults: [{kind: drop, drive: 3, at_frame: 2}]").find("faults[0].at_frame"), std::string::npos);
  EXPECT_NE(error("faults: [{kind: silent, drive: 3, at_frame: 0}]").find("faults[0].at_frame"), std::string::npos);
  EXPECT_NE(error("faults: [{kind: silent, drive: 3, at: 1, at_frame: 2}]").find("either `at` or `at_frame`"),
            std::string::npos);
  EXPECT_NE(error("faults: [{kind: silent, sensor: imu, at_frame: 2}]").find("faults[0].at_frame"), std::string::npos);
}

// A CiA 402 drive whose power stage cannot be enabled (enable_blocked, e.g. its safe torque off
// engaged): Enable operation leaves it Switched on; shutdown still takes it back to Ready.
TEST(DriveEmulator, Cia402EnableBlockedStaysSwitchedOn) {
  const can::DriveConfig cfg = can::default_drive(9, can::Protocol::cia402);  // node 10
  Cia402Drive drive(cfg, make_joint_model(9, 0.0), script("faults: [{kind: enable_blocked, drive: 10}]"), 0);
  std::vector<Frame> out;
  drive.boot(0, out);
  std::array<c4::SdoWrite, c4::kMaxMappingWrites> seq{};
  const int n = c4::pdo_mapping_sequence(10, c4::Mapping::compact, seq);
  for (int i = 0; i < n; ++i) {
    ASSERT_EQ(sdo(drive, 10, {c4::SdoRequest::Kind::write, seq[i].index, seq[i].sub, seq[i].value, seq[i].size}).size(), 1u);
  }
  Frame f;
  c4::encode_nmt(c4::NmtCommand::start, 10, f);
  drive.on_frame(f, 0, out);
  const auto cycle = [&](std::uint16_t cw) {
    c4::encode_rpdo1(10, c4::Rpdo1{cw, 0}, f);
    drive.on_frame(f, 0, out);
    c4::encode_sync(f);
    drive.on_frame(f, 0, out);
    return drive.status_word();
  };
  EXPECT_EQ(cycle(c4::controlword::shutdown), 0x0231);
  EXPECT_EQ(cycle(c4::controlword::switch_on), 0x0233);
  for (int k = 0; k < 5; ++k) EXPECT_EQ(cycle(c4::controlword::enable_operation), 0x0233) << k;
  EXPECT_FALSE(drive.enabled());
  EXPECT_EQ(cycle(c4::controlword::shutdown), 0x0231);
  const auto error = [](const char* yaml) { return load_faults_text(yaml).error; };
  EXPECT_NE(error("faults: [{kind: enable_blocked, drive: 10, param: 1}]").find("faults[0].param"), std::string::npos);
  EXPECT_NE(error("faults: [{kind: enable_blocked, drive: 10, at: 3}]").find("faults[0].at"), std::string::npos);
}

// CAN.md 4.3 step 1 as the host sees a drive: its stored producer heartbeat time is what power-on
// and NMT reset communication restore (0: silent until the host writes 0x1017); each reset is
// counted and answered with a boot-up frame.
TEST(DriveEmulator, Cia402StoredHeartbeatAndNmtResets) {
  const can::DriveConfig cfg = can::default_drive(2, can::Protocol::cia402);  // node 3
  {
    Cia402Drive silent(cfg, make_joint_model(2, 0.0), {}, 0);
    std::vector<Frame> out;
    silent.boot(0, out);
    out.clear();
    silent.on_time(1000000000, out);
    EXPECT_TRUE(out.empty()) << "no heartbeat before 0x1017 is written";
  }
  Cia402Drive drive(cfg, make_joint_model(2, 0.0), {}, 0, Cia402Options{100});
  EXPECT_FALSE(drive.powered());
  std::vector<Frame> out;
  drive.boot(0, out);
  EXPECT_TRUE(drive.powered());
  out.clear();
  drive.on_time(100000000, out);
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(out[0].id, 0x703u);
  EXPECT_EQ(bytes(out[0]), (std::vector<int>{0x7F}));  // pre-operational
  EXPECT_EQ(sdo(drive, 3, {c4::SdoRequest::Kind::write, c4::object::producer_heartbeat, 0, 10, 2}, 100000000).size(), 1u);
  Frame f;
  c4::encode_nmt(c4::NmtCommand::reset_communication, 3, f);
  out.clear();
  drive.on_frame(f, 110000000, out);
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(bytes(out[0]), (std::vector<int>{0x00}));  // boot-up
  EXPECT_EQ(drive.nmt_resets(), 1u);
  EXPECT_EQ(sdo_read(drive, 3, c4::object::producer_heartbeat, 110000000), 100u);  // the stored value again
  c4::encode_nmt(c4::NmtCommand::reset_communication, 4, f);  // another node's
  drive.on_frame(f, 120000000, out);
  c4::encode_nmt(c4::NmtCommand::reset_node, 0, f);  // every node's
  drive.on_frame(f, 130000000, out);
  EXPECT_EQ(drive.nmt_resets(), 2u);
}

// What else CAN.md allows a CiA 402 drive (Cia402Options): an NMT command taken in the drive's
// own cycle (a SYNC before then meets Pre-operational: no TPDO), only the PDOs CAN.md uses (the
// others' objects do not exist), every SDO answer sent twice.
TEST(DriveEmulator, Cia402OptionsCanMdAllows) {
  const can::DriveConfig cfg = can::default_drive(2, can::Protocol::cia402);  // node 3
  Cia402Options options;
  options.nmt_delay_ms = 5;
  options.only_used_pdos = true;
  options.repeat_sdo_answers = true;
  Cia402Drive drive(cfg, make_joint_model(2, 0.0), {}, 0, options);
  std::vector<Frame> out;
  drive.boot(0, out);
  const std::vector<Frame> twice = sdo(drive, 3, {c4::SdoRequest::Kind::read, c4::object::rpdo_comm + 2, 1, 0, 0}, 1000000);
  ASSERT_EQ(twice.size(), 2u);
  EXPECT_EQ(bytes(twice[0]), bytes(twice[1]));
  c4::SdoResponse res;
  ASSERT_EQ(c4::decode_sdo_response(twice[0], 3, res), can::FrameStatus::ok);
  EXPECT_EQ(res.kind, c4::SdoResponse::Kind::abort);
  EXPECT_EQ(res.value, c4::abort_code::no_object);
  const std::vector<Frame> tpdo2 = sdo(drive, 3, {c4::SdoRequest::Kind::read, c4::object::tpdo_comm + 1, 1, 0, 0}, 1000000);
  ASSERT_EQ(tpdo2.size(), 2u);
  ASSERT_EQ(c4::decode_sdo_response(tpdo2[0], 3, res), can::FrameStatus::ok);
  EXPECT_EQ(res.kind, c4::SdoResponse::Kind::read_ok) << "TPDO2 is there";
  EXPECT_EQ(res.value, c4::cob::tpdo2 + 3u);
  Frame nmt, sync;
  c4::encode_nmt(c4::NmtCommand::start, 3, nmt);
  c4::encode_sync(sync);
  out.clear();
  drive.on_frame(nmt, 2000000, out);
  drive.on_time(6000000, out);
  EXPECT_EQ(drive.nmt_state(), 0x7F) << "not yet: 5 ms after the command";
  drive.on_time(7000000, out);
  EXPECT_EQ(drive.nmt_state(), 0x05);
}

// Late answers (Cia402Options::answer_delay_ms, state_step_ms): an SDO answer goes out 10 ms after
// its request, not before; a state transition takes effect 90 ms after the SYNC that applied it.
TEST(DriveEmulator, Cia402AnswersLateAndStepsSlowlyWhenAsked) {
  const can::DriveConfig cfg = can::default_drive(2, can::Protocol::cia402);  // node 3
  Cia402Options options;
  options.answer_delay_ms = 10;
  options.state_step_ms = 90;
  Cia402Drive drive(cfg, make_joint_model(2, 0.0), {}, 0, options);
  std::vector<Frame> out;
  drive.boot(0, out);
  EXPECT_TRUE(sdo(drive, 3, {c4::SdoRequest::Kind::read, c4::object::statusword, 0, 0, 0}, 1000000).empty());
  out.clear();
  drive.on_time(10999999, out);
  EXPECT_TRUE(out.empty()) << "not yet: 10 ms after the request";
  drive.on_time(11000000, out);
  ASSERT_EQ(out.size(), 1u);
  c4::SdoResponse res;
  ASSERT_EQ(c4::decode_sdo_response(out[0], 3, res), can::FrameStatus::ok);
  EXPECT_EQ(res.value, 0x0250u);  // switch on disabled
  Frame nmt, rpdo, sync;
  c4::encode_nmt(c4::NmtCommand::start, 3, nmt);
  drive.on_frame(nmt, 20000000, out);
  c4::encode_rpdo1(3, c4::Rpdo1{c4::controlword::shutdown, 0}, rpdo);
  c4::encode_sync(sync);
  const auto tick = [&](std::int64_t now_ns) {
    drive.on_frame(rpdo, now_ns, out);
    drive.on_frame(sync, now_ns, out);
  };
  tick(30000000);  // the shutdown applied: ready to switch on at 120 ms
  tick(119000000);
  EXPECT_EQ(drive.status_word(), 0x0250);
  tick(120000000);
  EXPECT_EQ(drive.status_word(), 0x0231);
}

// A holding brake (Cia402Options::brake_ms): the steps into and out of Operation enabled take
// 80 ms (the brake releases, then engages), the others none.
TEST(DriveEmulator, Cia402BrakeDelaysOnlyTheStepsIntoAndOutOfOperationEnabled) {
  const can::DriveConfig cfg = can::default_drive(2, can::Protocol::cia402);  // node 3
  Cia402Options options;
  options.brake_ms = 80;
  Cia402Drive drive(cfg, make_joint_model(2, 0.0), {}, 0, options);
  std::vector<Frame> out;
  drive.boot(0, out);
  Frame nmt, sync;
  c4::encode_nmt(c4::NmtCommand::start, 3, nmt);
  drive.on_frame(nmt, 1000000, out);
  c4::encode_sync(sync);
  const auto tick = [&](std::uint16_t cw, std::int64_t now_ns) {
    Frame rpdo;
    c4::encode_rpdo1(3, c4::Rpdo1{cw, 0}, rpdo);
    drive.on_frame(rpdo, now_ns, out);
    drive.on_frame(sync, now_ns, out);
  };
  tick(c4::controlword::shutdown, 2000000);
  EXPECT_EQ(drive.status_word(), 0x0231) << "ready to switch on at once";
  tick(c4::controlword::switch_on, 3000000);
  EXPECT_EQ(drive.status_word(), 0x0233) << "switched on at once";
  tick(c4::controlword::enable_operation, 4000000);  // the brake releases: enabled at 84 ms
  tick(c4::controlword::enable_operation, 83000000);
  EXPECT_EQ(drive.status_word(), 0x0233);
  tick(c4::controlword::enable_operation, 84000000);
  EXPECT_EQ(drive.status_word(), 0x0237);
  tick(c4::controlword::disable_operation, 100000000);  // the brake engages: switched on at 180 ms
  tick(c4::controlword::disable_operation, 179000000);
  EXPECT_EQ(drive.status_word(), 0x0237);
  tick(c4::controlword::disable_operation, 180000000);
  EXPECT_EQ(drive.status_word(), 0x0233);
  tick(c4::controlword::shutdown, 181000000);
  EXPECT_EQ(drive.status_word(), 0x0231);
}

// CAN.md 4 / 5: the controller's error-passive report and its return to error active, as
// error frames on the drive's bus at the scripted cyclic ticks.
TEST(DriveEmulator, ErrorPassiveThenErrorActiveReports) {
  const can::DriveConfig cfg = can::default_drive(18, can::Protocol::mit);  // drive 19
  MitDrive drive(cfg, false, make_joint_model(18, 0.0),
                 script("faults: [{kind: error_passive, drive: 19, at: 2}, {kind: error_active, drive: 19, at: 3}]"), 0);
  std::vector<Frame> out;
  Frame f;
  can::mit::encode_special(19, can::mit::Special::enter_motor_mode, f);
  drive.on_frame(f, 0, out);
  (void)can::mit::encode_command(19, can::mit::Command{}, cfg.mit_ranges, f);
  std::vector<can::ErrorFrameInfo> reports;
  for (int tick = 1; tick <= 4; ++tick) {
    out.clear();
    drive.on_frame(f, 0, out);
    for (const Frame& e : out) {
      if (e.error) reports.push_back(can::classify_error_frame(e));
    }
  }
  ASSERT_EQ(reports.size(), 2u);
  EXPECT_TRUE(reports[0].error_passive);
  EXPECT_FALSE(reports[0].back_to_active);
  EXPECT_TRUE(reports[1].back_to_active);
  EXPECT_FALSE(reports[1].error_passive);
}

TEST(DriveEmulatorCli, PrintsTheLayoutAndItsBusLoads) {
  std::string out;
  EXPECT_EQ(run("--config " SPRINGBOK_SOURCE_DIR "/tests/hil/config/mit_fd5.yaml --print-layout", out), 0) << out;
  EXPECT_NE(out.find("arm    vcan4    yes mit          7       14     756.0   75.6%"), std::string::npos) << out;
  EXPECT_NE(out.find("layout ok"), std::string::npos);
  // The sensors' own bus: 3 IMU + 2 F/T frames, 675 us (CAN.md 6.3).
  EXPECT_NE(out.find("sensors vcan5    no  imu+ft       0        5     675.0   67.5%"), std::string::npos) << out;
}

// --sensors-preset / --sensors-seed (sim_hal's sensor model on the IMU and wrist F/T published
// with --motion bullet): parsed, a bad name refused, not together with the legacy --imu-*, and
// only with --motion bullet.
TEST(DriveEmulatorCli, SensorsPresetIsParsedAndRefusedWhenBad) {
  const std::string config = "--config " SPRINGBOK_SOURCE_DIR "/tests/hil/config/mit_classic7.yaml ";
  std::string out;
  EXPECT_EQ(run(config + "--print-layout --sensors-preset mems --sensors-seed 7", out), 0) << out;
  EXPECT_EQ(run(config + "--print-layout --sensors-preset tactical", out), 0) << out;
  out.clear();
  EXPECT_NE(run(config + "--print-layout --sensors-preset consumer", out), 0);
  EXPECT_NE(out.find("--sensors-preset"), std::string::npos) << out;
  out.clear();
  EXPECT_NE(run(config + "--print-layout --sensors-seed -3", out), 0);
  EXPECT_NE(out.find("--sensors-seed"), std::string::npos) << out;
  out.clear();
  EXPECT_NE(run(config + "--print-layout --sensors-preset mems --imu-gyro-noise-rad-s 0.01", out), 0);
  EXPECT_NE(out.find("excludes"), std::string::npos) << out;
  out.clear();
  EXPECT_NE(run(config + "--print-layout --sensors-seed 2 --imu-seed 3", out), 0);
  EXPECT_NE(out.find("excludes"), std::string::npos) << out;
  out.clear();
  EXPECT_EQ(run(config + "--sensors-preset mems --duration-s 0.01", out), 2);
  EXPECT_NE(out.find("--sensors-preset needs --motion bullet"), std::string::npos) << out;
  // A known gyro turn-on bias: three numbers, over the preset, not with the legacy options.
  out.clear();
  EXPECT_EQ(run(config + "--print-layout --sensors-preset mems --imu-gyro-bias-offset-rad-s 0.02,-0.02,0.02", out), 0)
      << out;
  out.clear();
  EXPECT_NE(run(config + "--print-layout --imu-gyro-bias-offset-rad-s 0.02,0.02", out), 0);
  EXPECT_NE(out.find("--imu-gyro-bias-offset-rad-s"), std::string::npos) << out;
  out.clear();
  EXPECT_NE(run(config + "--print-layout --imu-gyro-bias-offset-rad-s 0.02,nan,0", out), 0);
  EXPECT_NE(out.find("--imu-gyro-bias-offset-rad-s"), std::string::npos) << out;
  EXPECT_NE(out.find("not a finite number: nan"), std::string::npos) << out;
  out.clear();
  EXPECT_NE(run(config + "--print-layout --hand-force-n nan", out), 0);
  EXPECT_NE(out.find("--hand-force-n"), std::string::npos) << out;
  out.clear();
  EXPECT_NE(run(config + "--print-layout --imu-gyro-bias-offset-rad-s 0,0,0 --imu-gyro-bias-rad-s 0.01", out), 0);
  EXPECT_NE(out.find("excludes"), std::string::npos) << out;
  out.clear();
  EXPECT_EQ(run(config + "--imu-gyro-bias-offset-rad-s 0,0,0.02 --duration-s 0.01", out), 2);
  EXPECT_NE(out.find("--imu-gyro-bias-offset-rad-s needs --motion bullet"), std::string::npos) << out;
}

TEST(DriveEmulatorCli, RejectsABadConfigOrFaultScript) {
  const std::string bad = "/tmp/springbok_emu_cli_bad.yaml";
  std::ofstream(bad) << "can: {layout: classic7, timing: {tick_us: zero}}\n";
  std::string out;
  EXPECT_EQ(run("--config " + bad + " --print-layout", out), 2);
  EXPECT_NE(out.find("can.timing.tick_us"), std::string::npos) << out;
  std::ofstream(bad) << "faults: [{kind: melt, drive: 1, at: 1}]\n";
  out.clear();
  EXPECT_EQ(run("--config " SPRINGBOK_SOURCE_DIR "/tests/hil/config/mit_classic7.yaml --faults " + bad, out), 2);
  EXPECT_NE(out.find("faults[0].kind"), std::string::npos) << out;
  // CiA 402 drive properties on an MIT drive.
  std::ofstream(bad) << "faults: [{kind: rated_torque, drive: 1, param: 150000}]\n";
  out.clear();
  EXPECT_EQ(run("--config " SPRINGBOK_SOURCE_DIR "/tests/hil/config/mit_classic7.yaml --faults " + bad, out), 2);
  EXPECT_NE(out.find("fault 'rated_torque' names drive 1, which is an MIT drive"), std::string::npos) << out;
  // The vendor error byte: MIT drives only, and only those whose replies have it.
  std::ofstream(bad) << "faults: [{kind: vendor_error, drive: 1, param: 5}]\n";
  out.clear();
  EXPECT_EQ(run("--config " SPRINGBOK_SOURCE_DIR "/tests/hil/config/cia402_classic7.yaml --faults " + bad, out), 2);
  EXPECT_NE(out.find("fault 'vendor_error' names drive 1, which is a CiA 402 drive (MIT only)"), std::string::npos) << out;
  out.clear();
  EXPECT_EQ(run("--config " SPRINGBOK_SOURCE_DIR "/tests/hil/config/mit_classic7.yaml --faults " + bad, out), 2);
  EXPECT_NE(out.find("fault 'vendor_error' names drive 1, whose 6-byte replies have no error byte"), std::string::npos)
      << out;
  std::remove(bad.c_str());
  // The MIT drives' flash settings: a reply length the emulator does not send, an id past 11 bits,
  // a bus voltage past byte 6's range.
  const std::string config = "--config " SPRINGBOK_SOURCE_DIR "/tests/hil/config/mit_classic7.yaml --print-layout ";
  out.clear();
  EXPECT_NE(run(config + "--mit-reply-dlc 4", out), 0);
  EXPECT_NE(out.find("--mit-reply-dlc"), std::string::npos) << out;
  out.clear();
  EXPECT_NE(run(config + "--mit-bus-voltage-v 41", out), 0);
  EXPECT_NE(out.find("--mit-bus-voltage-v"), std::string::npos) << out;
  out.clear();
  EXPECT_EQ(run(config + "--mit-reply-dlc 7 --mit-bus-voltage-v 24", out), 0) << out;
  // A per-bus CiA 402 option: one value, or one per bus.
  out.clear();
  EXPECT_NE(run(config + "--cia402-answer-delay-ms 1,2", out), 0);
  EXPECT_NE(out.find("--cia402-answer-delay-ms: 2 values for 7 buses"), std::string::npos) << out;
  out.clear();
  EXPECT_EQ(run(config + "--cia402-answer-delay-ms 1,9,17,25,33,41,50 --cia402-state-step-ms 90", out), 0) << out;
  out.clear();
  EXPECT_NE(run(config + "--mit-master-id 2048", out), 0);
  EXPECT_NE(out.find("--mit-master-id"), std::string::npos) << out;
  out.clear();
  EXPECT_EQ(run(config + "--mit-master-id 0 --mit-reply-dlc 8", out), 0) << out;
}

}  // namespace
}  // namespace springbok::emu
