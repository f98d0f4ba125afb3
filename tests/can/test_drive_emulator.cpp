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
#include "springbok/drive_emulator/drives.hpp"

#include "frame_util.hpp"

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

int run(const std::string& args, std::string& output) {
  const std::string cmd = std::string(SPRINGBOK_BIN_DIR) + "/drive_emulator " + args + " 2>&1";
  FILE* p = ::popen(cmd.c_str(), "r");
  char buf[512];
  while (std::fgets(buf, sizeof buf, p) != nullptr) output += buf;
  const int status = ::pclose(p);
  return WEXITSTATUS(status);
}

TEST(DriveEmulatorCli, PrintsTheLayoutAndItsBusLoads) {
  std::string out;
  EXPECT_EQ(run("--config " SPRINGBOK_SOURCE_DIR "/tests/hil/config/mit_fd5.yaml --print-layout", out), 0) << out;
  EXPECT_NE(out.find("arm    vcan4    yes mit          7       14     756.0   75.6%"), std::string::npos) << out;
  EXPECT_NE(out.find("layout ok"), std::string::npos);
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
  std::remove(bad.c_str());
}

}  // namespace
}  // namespace springbok::emu
