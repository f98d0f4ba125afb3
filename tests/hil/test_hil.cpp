// HIL over vcan: the SocketCAN backend (springbok::can::CanHardware) against the
// drive emulator process on vcan0..6. Asserts behaviour and tick counts, never
// deadlines (under the VM's emulated CPU a round trip is ~0.1 ms typical, ms worst case).
#include <gtest/gtest.h>
#include <net/if.h>
#include <signal.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdlib>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <functional>
#include <iterator>
#include <map>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "alloc_trap.hpp"
#include "template_oracle.hpp"
#include "springbok/app/config.hpp"
#include "springbok/can/can_hardware.hpp"
#include "springbok/can/config_yaml.hpp"
#include "springbok/can/mit.hpp"
#include "springbok/dynamics/dynamics.hpp"

namespace springbok::can {
namespace {

const std::string kConfigDir = std::string(SPRINGBOK_SOURCE_DIR) + "/tests/hil/config/";
// The CiA 402 drives as on a robot whose drives were powered before the host started: their stored
// producer heartbeat time 100 ms, so the host hears they are up, resets them and sees them boot
// (CAN.md 4.3 step 1). Their power-on boot-up went out before the host listened.
const std::vector<std::string> kCia402DrivesUp{"--cia402-heartbeat-ms", "100"};

bool have_vcan(int buses) {
  for (int b = 0; b < buses; ++b) {
    if (if_nametoindex(("vcan" + std::to_string(b)).c_str()) == 0) return false;
  }
  const int s = ::socket(PF_CAN, SOCK_RAW, 1);
  if (s < 0) return false;
  ::close(s);
  return true;
}

#define REQUIRE_VCAN(n)                                                                   \
  if (!have_vcan(n)) GTEST_SKIP() << "needs vcan0..vcan" << (n) - 1 << ": run tools/hil"

// The drive emulator as a child process.
class Emulator {
 public:
  Emulator(const std::string& config, const std::string& faults_yaml, const std::vector<std::string>& extra = {}) {
    const std::string tag = std::to_string(::getpid()) + "_" + std::to_string(counter_++);
    ready_ = "/tmp/springbok_emu_ready_" + tag;
    out_ = "/tmp/springbok_emu_out_" + tag;
    std::vector<std::string> args{std::string(SPRINGBOK_BIN_DIR) + "/drive_emulator", "--config", config,
                                  "--ready-file", ready_};
    if (!faults_yaml.empty()) {
      faults_ = "/tmp/springbok_emu_faults_" + tag + ".yaml";
      std::ofstream(faults_) << faults_yaml;
      args.push_back("--faults");
      args.push_back(faults_);
    }
    args.insert(args.end(), extra.begin(), extra.end());
    ::unlink(ready_.c_str());
    pid_ = ::fork();
    if (pid_ == 0) {
      std::freopen(out_.c_str(), "w", stdout);
      std::vector<char*> argv;
      for (std::string& a : args) argv.push_back(a.data());
      argv.push_back(nullptr);
      ::execv(argv[0], argv.data());
      ::_exit(127);
    }
    for (int i = 0; i < 6000 && ::access(ready_.c_str(), F_OK) != 0; ++i) {  // Bullet settling: seconds in the VM
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
    ready_ok_ = ::access(ready_.c_str(), F_OK) == 0;
  }
  ~Emulator() { stop(); }
  bool ready() const { return ready_ok_; }
  // Stops the emulator; returns its summary (one line per drive).
  std::string stop() {
    if (pid_ > 0) {
      ::kill(pid_, SIGTERM);
      int status = 0;
      ::waitpid(pid_, &status, 0);
      pid_ = -1;
      std::ifstream in(out_);
      std::stringstream ss;
      ss << in.rdbuf();
      summary_ = ss.str();
      ::unlink(ready_.c_str());
      ::unlink(out_.c_str());
      if (!faults_.empty()) ::unlink(faults_.c_str());
    }
    return summary_;
  }

 private:
  static inline int counter_ = 0;
  pid_t pid_ = -1;
  bool ready_ok_ = false;
  std::string ready_, out_, faults_, summary_;
};

CanConfig load(const std::string& name) {
  const ConfigResult r = load_can_config_file(kConfigDir + name);
  EXPECT_TRUE(r.ok) << r.error;
  return r.config;
}

// Runs `ticks` ticks at a 1 ms period: read, observe, write (zero torque, light damping).
void run_ticks(CanHardware& hw, int ticks, const std::function<void(int, const hal::Measurements&, hal::IoStatus)>& observe) {
  hal::JointCommands cmd;
  cmd.mode = hal::CommandMode::enabled;
  cmd.kd_nms_per_rad.setConstant(0.5);
  hal::Measurements m;
  auto next = std::chrono::steady_clock::now();
  for (int k = 1; k <= ticks; ++k) {
    const hal::IoStatus s = hw.read(m);
    observe(k, m, s);
    EXPECT_EQ(hw.write(cmd), hal::IoStatus::ok);
    next += std::chrono::milliseconds(1);
    std::this_thread::sleep_until(next);
  }
}

double stance(int j) {
  if (j >= 12) return 0.0;
  const double front[3] = {0.0, 0.7, -1.4};
  return (j / 3 < 2 ? 1.0 : -1.0) * front[j % 3];
}

// The emulator's summary, per drive.
struct EmulatedDrive {
  int enabled = -1;
  unsigned long long frames_in = 0;  // frames the drive took (commands, special frames, SDO, ...)
  unsigned statusword = 0, nmt = 0;
  unsigned long long nmt_resets = 0;  // NMT reset node / reset communication taken
  unsigned long long sync_timeouts = 0;  // quick stops for lost communication (--cia402-sync-timeout-ms)
};
std::map<int, EmulatedDrive> emulated_drives(const std::string& summary) {
  std::map<int, EmulatedDrive> out;
  std::istringstream in(summary);
  for (std::string line; std::getline(in, line);) {
    int id = 0;
    unsigned sw = 0, nmt = 0;
    unsigned long long resets = 0, sync_timeouts = 0;
    if (std::sscanf(line.c_str(), "cia402 drive %d statusword 0x%x nmt 0x%x nmt_resets %llu sync_timeouts %llu", &id, &sw,
                    &nmt, &resets, &sync_timeouts) == 5) {
      out[id].statusword = sw;
      out[id].nmt = nmt;
      out[id].nmt_resets = resets;
      out[id].sync_timeouts = sync_timeouts;
    } else if (std::sscanf(line.c_str(), "drive %d", &id) == 1) {
      const auto at = line.find(" enabled ");
      if (at != std::string::npos) out[id].enabled = std::atoi(line.c_str() + at + 9);
      const auto in = line.find(" frames_in ");
      if (in != std::string::npos) out[id].frames_in = std::strtoull(line.c_str() + in + 11, nullptr, 10);
    }
  }
  return out;
}

// `emulator_args`: the drives' own settings where they differ from the config's (e.g. the
// MIT CAN_MASTER id); `host`: what the host's config then says of them; `check`: what else the
// last of the ticks after start-up must show.
void bring_up_all(const std::string& config_name, const std::vector<std::string>& emulator_args = {},
                  const std::function<void(CanConfig&)>& host = {},
                  const std::function<void(const CanHardware&, const hal::Measurements&)>& check = {}) {
  CanConfig cfg = load(config_name);
  if (host) host(cfg);
  Emulator emu(kConfigDir + config_name, "", emulator_args);
  ASSERT_TRUE(emu.ready());
  CanHardware hw(cfg);
  const hal::LifecycleResult c = hw.configure();
  ASSERT_TRUE(c.ok) << c.message;
  const hal::LifecycleResult a = hw.activate();
  ASSERT_TRUE(a.ok) << a.message;
  int ok_ticks = 0;
  hal::Measurements last;
  run_ticks(hw, 300, [&](int, const hal::Measurements& m, hal::IoStatus s) {
    ok_ticks += s == hal::IoStatus::ok ? 1 : 0;
    last = m;
  });
  // Under the VM's emulated CPU on a loaded host a reply may miss the receive deadline:
  // it then counts as missed (never silently), but no drive may reach the lost threshold.
  EXPECT_GE(ok_ticks, 240) << "ticks with every reply fresh";
  for (int j = 0; j < kNj; ++j) {
    const hal::DriveStatus& d = last.drives[static_cast<std::size_t>(j)];
    EXPECT_EQ(d.state, hal::DriveState::enabled) << "joint " << j;
    EXPECT_LE(d.missed_total, 30u) << "joint " << j;
    // Zero torque from rest: near the stance (MIT's zero torque is half an LSB off, so joints creep).
    EXPECT_NEAR(last.q_rad[j], stance(j), 0.05) << "joint " << j;
  }
  for (int b = 0; b < hw.bus_count(); ++b) {
    EXPECT_EQ(hw.diagnostics(b).fault, BusFault::none);
    EXPECT_EQ(hw.diagnostics(b).bad_frames, 0u);
    EXPECT_EQ(hw.diagnostics(b).unexpected_frames, 0u);
  }
  if (check) check(hw, last);
  // rt: read and write do not allocate (the whole tick path, sockets included).
  {
    hal::JointCommands cmd;
    cmd.mode = hal::CommandMode::enabled;
    hal::Measurements m;
    const std::size_t allocations = test::count_allocations([&] {
      for (int k = 0; k < 50; ++k) {
        (void)hw.read(m);
        (void)hw.write(cmd);
      }
    });
    EXPECT_EQ(allocations, 0u);
  }
  hw.deactivate();
  const std::string summary = emu.stop();
  for (const auto& [id, dr] : emulated_drives(summary)) EXPECT_EQ(dr.sync_timeouts, 0u) << "drive " << id << ": lost communication";
  // Every drive was disabled at shut-down (MIT exit motor mode / CiA 402 disable operation),
  // and the last position the backend decoded is the emulator's own (its oracle), within quantization.
  int drives = 0, disabled = 0, fd_drives = 0;
  std::istringstream in(summary);
  for (std::string line; std::getline(in, line);) {
    int id = 0;
    unsigned long long classic = 0;
    double q_emu = 0.0;
    // On a CAN FD bus every frame to a drive went out as FD (the emulator ignores classic ones).
    if (std::sscanf(line.c_str(), "fd_bus drive %d classic_frames %llu", &id, &classic) == 2) {
      ++fd_drives;
      EXPECT_EQ(classic, 0u) << line;
      continue;
    }
    if (std::sscanf(line.c_str(), "drive %d", &id) != 1) continue;
    ++drives;
    disabled += line.find("enabled 0") != std::string::npos ? 1 : 0;
    const auto at = line.find("q_rad ");
    ASSERT_NE(at, std::string::npos);
    q_emu = std::stod(line.substr(at + 6));
    EXPECT_NEAR(hw.joint(id - 1).q_rad, q_emu, 1e-3) << line;
  }
  EXPECT_EQ(drives, kNj) << summary;
  EXPECT_EQ(disabled, kNj) << summary;
  int fd_configured = 0;
  for (const BusConfig& b : cfg.buses) fd_configured += b.fd ? static_cast<int>(b.drives.size()) : 0;
  EXPECT_EQ(fd_drives, fd_configured) << summary;
}

TEST(Hil, BringUpAll19DrivesMit) {
  REQUIRE_VCAN(7);
  bring_up_all("mit_classic7.yaml");
}

TEST(Hil, BringUpAll19DrivesCia402) {
  REQUIRE_VCAN(7);
  bring_up_all("cia402_classic7.yaml", kCia402DrivesUp);
}

// What else CAN.md allows a CiA 402 drive: NMT start taken in the drive's own cycle (3 ms
// later: the walk's first SYNC meets a Pre-operational node, which sends no TPDO), only the PDOs
// CAN.md uses (disabling RPDO2-4 / TPDO3-4 answers "object does not exist"), every SDO answer
// sent twice (the repeat arrives while the next request waits). Each alone failed start-up
// before: "stuck in 'unknown' ... for 500 ms" (one SYNC, then a wait of state_step_timeout_ms),
// "SDO write 0x1401:1 ... aborted, object does not exist", "malformed or mismatched answer".
TEST(Hil, BringUpAll19DrivesCia402DoingWhatCanMdAllows) {
  REQUIRE_VCAN(7);
  std::vector<std::string> args = kCia402DrivesUp;
  for (const char* a : {"--cia402-nmt-delay-ms", "3", "--cia402-only-used-pdos", "--cia402-repeat-sdo-answers"}) {
    args.emplace_back(a);
  }
  bring_up_all("cia402_classic7.yaml", args);
}

// CAN.md 4.3 step 3: SYNC every tick from NMT start on. A drive that takes a silence as lost
// communication (0x6007 = 3: quick stop; here after 60 ms without SYNC) stays enabled: the
// buses enabled first keep getting SYNC and their RPDO1 (enable operation, zero torque) while
// the later ones are enabled (each bus's walk waits 20 ms here for its drives' NMT start).
// Before, they got nothing until the first tick, quick-stopped, and the first tick found them
// left Operation enabled (a drive fault).
TEST(Hil, BringUpAll19DrivesCia402WhoseDrivesWatchForLostCommunication) {
  REQUIRE_VCAN(7);
  std::vector<std::string> args = kCia402DrivesUp;
  for (const char* a : {"--cia402-sync-timeout-ms", "60", "--cia402-nmt-delay-ms", "20"}) args.emplace_back(a);
  bring_up_all("cia402_classic7.yaml", args);
}

// Drives that answer within CAN.md's limits but late, as start-up meets them: the host's timing as
// shipped (rx_deadline_us 900, state_step_timeout_ms 100), the drives' CiA 402 emulation slowed by
// the emulator's --cia402-* options. What is checked is the bring-up: every drive Operation enabled
// in the emulator as in the host, each bus's first ones kept enabled by the keep-alive while the
// later ones are walked, and every drive disabled again at shut-down. No ticks follow: at the
// shipped 900 us receive deadline the VM's own latency (CAN.md 5: several ms worst case) makes
// drives miss their ticks whatever they answer; the ticks after a CiA 402 bring-up are checked by
// the cases above, at the HIL configs' deadline.
void bring_up_all_cia402_late(const std::vector<std::string>& late) {
  std::vector<std::string> args = kCia402DrivesUp;
  args.insert(args.end(), late.begin(), late.end());
  CanConfig cfg = load("cia402_classic7.yaml");
  cfg.timing.rx_deadline_us = Timing{}.rx_deadline_us;
  cfg.timing.state_step_timeout_ms = Timing{}.state_step_timeout_ms;
  Emulator emu(kConfigDir + "cia402_classic7.yaml", "", args);
  ASSERT_TRUE(emu.ready());
  CanHardware hw(cfg);
  const hal::LifecycleResult c = hw.configure();
  ASSERT_TRUE(c.ok) << c.message;
  const hal::LifecycleResult a = hw.activate();
  ASSERT_TRUE(a.ok) << a.message;
  for (int j = 0; j < kNj; ++j) {
    EXPECT_EQ(hw.joint(j).status.state, hal::DriveState::enabled) << "joint " << j;
    EXPECT_EQ(cia402::decode_statusword(hw.joint(j).statusword), cia402::State::operation_enabled) << "joint " << j;
  }
  for (int b = 0; b < hw.bus_count(); ++b) {
    EXPECT_EQ(hw.diagnostics(b).fault, BusFault::none);
    EXPECT_EQ(hw.diagnostics(b).bad_frames, 0u);
    EXPECT_EQ(hw.diagnostics(b).unexpected_frames, 0u);
  }
  // The emulator's own record after shut-down: every drive taken through 0x0007, 0x0006 and NMT 80.
  hw.deactivate();
  const std::map<int, EmulatedDrive> drives = emulated_drives(emu.stop());
  ASSERT_EQ(drives.size(), static_cast<std::size_t>(kNj));
  for (const auto& [id, dr] : drives) {
    EXPECT_EQ(dr.sync_timeouts, 0u) << "drive " << id << ": lost communication";
    EXPECT_EQ(dr.enabled, 0) << "drive " << id << ": still enabled after shut-down";
    EXPECT_EQ(dr.statusword, 0x0231u) << "drive " << id << ": ready to switch on after 0x0007, 0x0006 (CAN.md 4.4)";
    EXPECT_EQ(dr.nmt, 0x7Fu) << "drive " << id << ": pre-operational after NMT 80 0";
  }
}

// Until Operation enabled, each bus's drives send the TPDOs of a SYNC and their SDO answers 1 to
// 50 ms late (lf 1 ms ... arm 50 ms): after the tick's receive deadline on every bus but lf.
// DISABLED in the suite: in the VM a state step is seen as the step plus the drive's lateness
// jitter plus the VM's stalls, which now and then passes state_step_timeout_ms (a bus 'stuck' for
// 100 ms on rh, one run in a clean-clone suite after 10 passes alone). Run it by hand:
//   test_hil --gtest_also_run_disabled_tests --gtest_filter='*AnsweringLate'
TEST(Hil, DISABLED_BringUpAll19DrivesCia402AnsweringLate) {
  REQUIRE_VCAN(7);
  bring_up_all_cia402_late({"--cia402-answer-delay-ms", "1,9,17,25,33,41,50"});
}

// Each state transition of every drive takes 90 ms of the 100 ms the host allows a step
// (state_step_timeout_ms as shipped, CAN.md 4.3 step 4); the shut-down waits for each step too
// (4.4 step 2: before, it sent NMT enter pre-operational one tick after 0x0006 and every drive
// stayed Operation enabled). Disabled: the host sees a step last 90 ms plus its cycle and the
// rig's latency, which in the CPU-starved VM often passes 100 ms ("stuck in 'switch on disabled'
// for 100 ms"), so the case is not reliable there. To run it in the VM:
// test_hil --gtest_also_run_disabled_tests --gtest_filter='*StateStepsTake90Ms'.
TEST(Hil, DISABLED_BringUpAll19DrivesCia402WhoseStateStepsTake90Ms) {
  REQUIRE_VCAN(7);
  bring_up_all_cia402_late({"--cia402-state-step-ms", "90"});
}

// Every drive has a holding brake that takes 80 ms to release (the step into Operation enabled)
// and to engage (the step out of it): bring-up waits for it within the 100 ms a step may take
// (CAN.md 4.3 step 4), and the shut-down waits for it before NMT enter pre-operational, every bus
// SYNCed meanwhile (4.4 step 2). Disabled in the suite as the 90 ms case: 5 of 5 alone in the VM,
// but in a clean-clone suite run a step was seen after 100 ms ('stuck in switched on', lh): the
// 20 ms left are within the VM's stalls. By hand:
//   test_hil --gtest_also_run_disabled_tests --gtest_filter='*BrakesTake80Ms'
TEST(Hil, DISABLED_BringUpAll19DrivesCia402WhoseBrakesTake80Ms) {
  REQUIRE_VCAN(7);
  bring_up_all_cia402_late({"--cia402-brake-ms", "80"});
}

TEST(Hil, BringUpAll19DrivesMitWithCanFdArm) {
  REQUIRE_VCAN(5);
  bring_up_all("mit_fd5.yaml");
}

// CAN.md 1.4: the drives reply on their CAN_MASTER id (factory default 0, here shared by
// all), in the CubeMars variant with 8 bytes; the host matches on byte 0 and ignores bytes
// 6..7 of a drive not configured as a vendor drive.
// CAN.md 1.4: drives never configured reply on their factory CAN_MASTER, 0, while the host's
// config names 0x100 + id (the distinct ids CAN.md advises): the host matches on byte 0 either
// way. Before, their replies were filtered out and start-up failed ("no reply to
// exit-motor-mode").
TEST(Hil, BringUpAll19DrivesMitLeftAtTheirFactoryMasterId) {
  REQUIRE_VCAN(7);
  bring_up_all("mit_classic7.yaml", {"--mit-master-id", "0"}, [](CanConfig& cfg) {
    for (const BusConfig& b : cfg.buses) {
      for (const DriveConfig& d : b.drives) ASSERT_EQ(d.mit_reply_id, 0x100 + d.drive_id);
    }
  });
}

TEST(Hil, BringUpAll19DrivesMitReplyingOnMasterIdZeroWithEightBytes) {
  REQUIRE_VCAN(7);
  bring_up_all("mit_classic7.yaml", {"--mit-master-id", "0", "--mit-reply-dlc", "8"}, [](CanConfig& cfg) {
    for (BusConfig& b : cfg.buses) {
      for (DriveConfig& d : b.drives) {
        d.mit_reply_id = 0;
        d.mit_vendor_reply = false;
      }
    }
  });
}

// CAN.md 1.4: the reference firmware since July 2023 replies with 7 bytes, byte 6 its bus
// voltage, reported per drive, against a 20 V warning and an 18 V fault: every drive brought up
// reports `volts` (within `within_v`: 8 bits on 0..40 V), flagged low or not as `low` says.
void bring_up_all_mit_reporting(double volts, double within_v, bool low,
                                const std::function<void(const CanHardware&)>& check = {}) {
  bring_up_all(
      "mit_classic7.yaml", {"--mit-reply-dlc", "7", "--mit-bus-voltage-v", std::to_string(volts)},
      [](CanConfig& cfg) {
        cfg.mit_bus_voltage_warning_v = 20.0;
        cfg.mit_bus_voltage_fault_v = 18.0;
      },
      [&](const CanHardware& hw, const hal::Measurements& m) {
        for (int j = 0; j < kNj; ++j) {
          EXPECT_NEAR(m.drives[static_cast<std::size_t>(j)].bus_voltage_v, volts, within_v) << "joint " << j;
          EXPECT_EQ(m.drives[static_cast<std::size_t>(j)].bus_voltage_low, low) << "joint " << j;
        }
        if (check) check(hw);
      });
}

// 24 V is code 153: exactly 24 V back.
TEST(Hil, BringUpAll19DrivesMitReplyingWithTheirBusVoltage) {
  REQUIRE_VCAN(7);
  bring_up_all_mit_reporting(24.0, 0.0, false, [](const CanHardware& hw) {
    EXPECT_NE(hw.diagnostics_report().find("can drive 1 (lf_haa_joint): bus_voltage_v=24.00 bus_voltage_low=0 "
                                           "wrong_dlc_replies=0"),
              std::string::npos)
        << hw.diagnostics_report();
  });
}

// Below the warning threshold the drives still follow (a warning per drive, not a fault).
TEST(Hil, MitDrivesBelowTheBusVoltageWarningAreFlaggedAndFollow) {
  REQUIRE_VCAN(7);
  bring_up_all_mit_reporting(19.0, 40.0 / 255.0, true);
}

// Below the fault threshold a drive is about to brown out: start-up fails naming the drive and
// its voltage, the drive fault latched (as a vendor error code is).
TEST(Hil, MitStartUpFailsOnADriveBelowTheBusVoltageFault) {
  REQUIRE_VCAN(7);
  CanConfig cfg = load("mit_classic7.yaml");
  cfg.mit_bus_voltage_warning_v = 20.0;
  cfg.mit_bus_voltage_fault_v = 18.0;
  Emulator emu(kConfigDir + "mit_classic7.yaml", "", {"--mit-reply-dlc", "7", "--mit-bus-voltage-v", "17"});
  ASSERT_TRUE(emu.ready());
  CanHardware hw(cfg);
  const hal::LifecycleResult c = hw.configure();
  ASSERT_FALSE(c.ok);
  EXPECT_NE(c.message.find("MIT start-up: drive 1 (joint lf_haa_joint, mit) on bus 'lf' (vcan0) reports a bus voltage "
                           "of 16.94 V, below can.mit_bus_voltage_fault_v 18.00 V"),
            std::string::npos)
      << c.message;
  EXPECT_EQ(hw.joint(0).status.state, hal::DriveState::fault);
  EXPECT_EQ(hw.joint(0).status.fault_code, kFaultBusUndervoltage);
}

// A reply of a length CAN.md 1.4 does not allow is dropped and counted, and the failed start-up
// says so instead of "no reply".
TEST(Hil, MitStartUpNamesRepliesOfAWrongLength) {
  REQUIRE_VCAN(7);
  const CanConfig cfg = load("mit_classic7.yaml");
  Emulator emu(kConfigDir + "mit_classic7.yaml", "", {"--mit-reply-dlc", "5"});
  ASSERT_TRUE(emu.ready());
  CanHardware hw(cfg);
  const hal::LifecycleResult c = hw.configure();
  ASSERT_FALSE(c.ok);
  const std::uint32_t tries = cfg.timing.mit_presence_retries + 1;
  EXPECT_NE(c.message.find("MIT start-up: no valid reply to exit-motor-mode after " + std::to_string(tries) +
                           " tries of " + std::to_string(cfg.timing.mit_presence_timeout_ms) +
                           " ms: drive 1 (joint lf_haa_joint, mit) on bus 'lf' (vcan0): " + std::to_string(tries) +
                           " replies of DLC 5 dropped"),
            std::string::npos)
      << c.message;
  EXPECT_EQ(c.message.find("no reply"), std::string::npos) << c.message;
  EXPECT_EQ(hw.joint(0).wrong_dlc_replies, tries);
  EXPECT_GE(hw.diagnostics(0).bad_frames, tries);
}

TEST(Hil, MissingDriveStopsStartUpNamingIt) {
  REQUIRE_VCAN(7);
  CanConfig cfg = load("mit_classic7.yaml");
  // The emulator knows 19 drives; the firmware expects drive 20 instead of drive 19.
  Emulator emu(kConfigDir + "mit_classic7.yaml", "");
  ASSERT_TRUE(emu.ready());
  cfg.buses[6].drives[1].drive_id = 20;
  cfg.buses[6].drives[1].mit_reply_id = 0x114;
  CanHardware hw(cfg);
  const hal::LifecycleResult c = hw.configure();
  EXPECT_FALSE(c.ok);
  EXPECT_NE(c.message.find("drive 20 (joint arm_joint_7, mit) on bus 'arm2' (vcan6)"), std::string::npos) << c.message;
}

// CAN.md 4.2 step 3: MIT start-up checks the drives' positions against the joint limits and the
// expected pose (can.start_pose, optional; given here). The emulated joints start in the stance,
// which the pose expects, but for arm joint 4 (drive 16, bus arm1): expected at 0.5 rad, more than the tolerance
// (0.3 rad) from where it is, though within its limits. configure() fails naming the joint, its
// position and the expected one, and only it; at 0.25 rad from the expected pose it starts.
TEST(Hil, MitStartUpRefusesAJointOffTheExpectedPose) {
  REQUIRE_VCAN(7);
  Emulator emu(kConfigDir + "mit_classic7.yaml", "");
  ASSERT_TRUE(emu.ready());
  CanConfig cfg = load("mit_classic7.yaml");
  ASSERT_FALSE(cfg.start_pose.given) << "the HIL configs leave it out: an emulator's joints may start anywhere";
  cfg.start_pose.given = true;  // the emulator's pose (--pose stance), the default tolerance
  cfg.start_pose.q_rad = {0.0, 0.7, -1.4, 0.0, 0.7, -1.4, 0.0, -0.7, 1.4, 0.0, -0.7, 1.4, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0};
  ASSERT_DOUBLE_EQ(cfg.start_pose.tolerance_rad, 0.3);
  ASSERT_EQ(springbok::can::validate(cfg), "");
  cfg.start_pose.q_rad[15] = 0.5;
  {
    CanHardware hw(cfg);
    const hal::LifecycleResult c = hw.configure();
    EXPECT_FALSE(c.ok);
    const std::string head =
        "MIT start-up: position off the expected start pose (can.start_pose, tolerance 0.300000 rad): drive 16 (joint "
        "arm_joint_4, mit) on bus 'arm1' (vcan5) at -0.000191 rad, expected 0.500000 rad";
    EXPECT_EQ(c.message, head) << c.message;
  }
  cfg.start_pose.q_rad[15] = 0.25;
  CanHardware hw(cfg);
  const hal::LifecycleResult c = hw.configure();
  EXPECT_TRUE(c.ok) << c.message;
}

TEST(Hil, SilentDriveIsLostAfterTheConfiguredTicks) {
  REQUIRE_VCAN(7);
  const CanConfig cfg = load("mit_classic7.yaml");
  const int n_lost = static_cast<int>(cfg.timing.missed_replies_lost);
  Emulator emu(kConfigDir + "mit_classic7.yaml", "faults: [{kind: silent, drive: 5, at: 50}]\n");
  ASSERT_TRUE(emu.ready());
  CanHardware hw(cfg);
  ASSERT_TRUE(hw.configure().ok);
  ASSERT_TRUE(hw.activate().ok);
  int lost_at = -1;
  bool others_lost = false;
  hal::IoStatus last_status = hal::IoStatus::ok;
  run_ticks(hw, 100, [&](int k, const hal::Measurements& m, hal::IoStatus s) {
    if (lost_at < 0 && m.drives[4].state == hal::DriveState::lost) lost_at = k;
    for (int j = 0; j < kNj; ++j) others_lost = others_lost || (j != 4 && m.drives[static_cast<std::size_t>(j)].state != hal::DriveState::enabled);
    last_status = s;
  });
  // The reply to the command sent at tick 50 is the first one missing (read at tick 51).
  EXPECT_GE(lost_at, 50 + n_lost - 1);
  EXPECT_LE(lost_at, 50 + n_lost + 1);
  EXPECT_FALSE(others_lost);
  EXPECT_EQ(last_status, hal::IoStatus::partial);
  EXPECT_GE(hw.joint(4).status.missed_in_row, 40u);
}

// CAN.md 4.1: age > N_stale is lost. With N_stale = 3, three replies missing in a row leave
// the joint stale (its last value used, flagged) and enabled; four make it lost.
TEST(Hil, AJointIsLostOnlyWhenItsAgeExceedsNStale) {
  REQUIRE_VCAN(7);
  CanConfig cfg = load("mit_classic7.yaml");
  cfg.timing.missed_replies_lost = 3;
  Emulator emu(kConfigDir + "mit_classic7.yaml",
               "faults:\n"
               "  - {kind: drop, drive: 2, at: 40, count: 3}\n"
               "  - {kind: drop, drive: 5, at: 40, count: 4}\n");
  ASSERT_TRUE(emu.ready());
  CanHardware hw(cfg);
  ASSERT_TRUE(hw.configure().ok);
  ASSERT_TRUE(hw.activate().ok);
  bool stale_one_lost = false;
  std::uint32_t most_missed = 0;
  hal::Measurements last;
  run_ticks(hw, 100, [&](int, const hal::Measurements& m, hal::IoStatus) {
    stale_one_lost = stale_one_lost || m.drives[1].state != hal::DriveState::enabled;
    most_missed = std::max(most_missed, m.drives[1].missed_in_row);
    last = m;
  });
  EXPECT_FALSE(stale_one_lost);
  EXPECT_EQ(most_missed, 3u);  // the three dropped replies, in a row
  EXPECT_TRUE(last.drives[1].fresh);
  EXPECT_EQ(last.drives[4].state, hal::DriveState::lost);
}

// A CiA 402 drive's EMCY in the run latches its fault, and only its. The emulator counts its
// drive's ticks in SYNCs, and the SYNCs that keep the buses enabled first alive while the later
// ones are enabled count too: its 150th comes on the run's 150th tick at the latest.
TEST(Hil, EmcyLatchesTheDriveFault) {
  REQUIRE_VCAN(7);
  const CanConfig cfg = load("cia402_classic7.yaml");
  Emulator emu(kConfigDir + "cia402_classic7.yaml", "faults: [{kind: emcy, drive: 8, at: 150, param: 0x2310}]\n",
               kCia402DrivesUp);
  ASSERT_TRUE(emu.ready());
  CanHardware hw(cfg);
  const hal::LifecycleResult c = hw.configure();
  ASSERT_TRUE(c.ok) << c.message;
  const hal::LifecycleResult a = hw.activate();
  ASSERT_TRUE(a.ok) << a.message;
  int fault_at = -1;
  hal::Measurements last;
  run_ticks(hw, 200, [&](int k, const hal::Measurements& m, hal::IoStatus) {
    if (fault_at < 0 && m.drives[7].state == hal::DriveState::fault) fault_at = k;
    last = m;
  });
  EXPECT_GE(fault_at, 1);
  EXPECT_LE(fault_at, 153);
  EXPECT_EQ(last.drives[7].state, hal::DriveState::fault);  // latched
  EXPECT_EQ(last.drives[7].fault_code, 0x2310);
  for (int j = 0; j < kNj; ++j) {
    if (j != 7) {
      EXPECT_EQ(last.drives[static_cast<std::size_t>(j)].state, hal::DriveState::enabled) << j;
    }
  }
}

// CAN.md 2.4 / 4.3 step 2: the drive's own 0x6076 scales 0x6071 / 0x6072 / 0x6077. Drive 13
// (arm_joint_1, 39 Nm limit) reports the spec's example rating, 150 Nm (0.15 Nm per unit);
// the config does not say (the default) or says 39 Nm: start-up goes on and notes the difference.
TEST(Hil, Cia402TorquesAreScaledByTheDrivesRatedTorque) {
  REQUIRE_VCAN(7);
  CanConfig cfg = load("cia402_classic7.yaml");
  cfg.buses[4].drives[0].rated_torque_nm = 39.0;  // what the config expects, not what the drive says
  Emulator emu(kConfigDir + "cia402_classic7.yaml", "faults: [{kind: rated_torque, drive: 13, param: 150000}]\n",
               kCia402DrivesUp);
  ASSERT_TRUE(emu.ready());
  CanHardware hw(cfg);
  const hal::LifecycleResult c = hw.configure();
  ASSERT_TRUE(c.ok) << c.message;
  EXPECT_EQ(hw.joint(12).rated_torque_mnm, 150000u);
  EXPECT_EQ(hw.joint(12).torque_scale.max_permille, 260);  // 0x6072 = 39 Nm / 0.15 Nm
  EXPECT_EQ(hw.joint(13).rated_torque_mnm, 39000u);        // the others: their effort limit
  EXPECT_EQ(hw.joint(13).torque_scale.max_permille, 1000);
  EXPECT_NE(hw.startup_notes().find("drive 13 (joint arm_joint_1, cia402) on bus 'arm0' (vcan4): motor rated torque "
                                    "0x6076 = 150000 mNm, the config's rated_torque_nm is 39"),
            std::string::npos)
      << hw.startup_notes();
  EXPECT_NE(hw.diagnostics_report().find("0x6076 = 150000 mNm"), std::string::npos);
  ASSERT_TRUE(hw.activate().ok);
  hal::JointCommands cmd;
  cmd.mode = hal::CommandMode::enabled;
  cmd.kd_nms_per_rad.setConstant(0.5);
  cmd.kd_nms_per_rad[12] = 0.0;
  hal::Measurements m;
  auto next = std::chrono::steady_clock::now();
  const auto run = [&](double tau_nm, int ticks) {
    cmd.tau_ff_nm[12] = tau_nm;
    for (int k = 0; k < ticks; ++k) {
      (void)hw.read(m);
      EXPECT_EQ(hw.write(cmd), hal::IoStatus::ok);
      next += std::chrono::milliseconds(1);
      std::this_thread::sleep_until(next);
    }
  };
  run(100.0, 40);  // clamped by the host to 0x6072: the joint's 39 Nm
  EXPECT_EQ(m.drives[12].state, hal::DriveState::enabled);
  EXPECT_NEAR(m.tau_nm[12], 39.0, 1e-9);
  run(3.0, 40);  // 20 units of 0.15 Nm
  EXPECT_EQ(m.drives[12].state, hal::DriveState::enabled);
  EXPECT_NEAR(m.tau_nm[12], 3.0, 1e-9);
  // The emulated drive's own torque (its oracle): what it applied from the last 0x6071.
  const std::string summary = emu.stop();
  const auto line_at = summary.find("drive 13 ");
  ASSERT_NE(line_at, std::string::npos) << summary;
  const std::string line = summary.substr(line_at, summary.find('\n', line_at) - line_at);
  const auto tau_at = line.find("tau_nm ");
  ASSERT_NE(tau_at, std::string::npos) << line;
  EXPECT_NEAR(std::stod(line.substr(tau_at + 7)), 3.0, 1e-4) << line;
}

// CAN.md 2.4 / 4.3 step 2: 0x6061 must read back 10 before enabling; a drive may show the new
// mode a cycle after the write, so the host polls it (bounded by state_step_timeout_ms).
TEST(Hil, Cia402StartUpWaitsForTheModeDisplay) {
  REQUIRE_VCAN(7);
  const CanConfig cfg = load("cia402_classic7.yaml");
  Emulator emu(kConfigDir + "cia402_classic7.yaml",
               "faults: [{kind: mode_display_delay, drive: 8, param: 30}, {kind: mode_display_delay, drive: 17, param: 5}]\n",
               kCia402DrivesUp);
  ASSERT_TRUE(emu.ready());
  CanHardware hw(cfg);
  const hal::LifecycleResult c = hw.configure();
  ASSERT_TRUE(c.ok) << c.message;
  const hal::LifecycleResult a = hw.activate();
  ASSERT_TRUE(a.ok) << a.message;
  hal::Measurements last;
  run_ticks(hw, 30, [&](int, const hal::Measurements& m, hal::IoStatus) { last = m; });
  for (int j = 0; j < kNj; ++j) EXPECT_EQ(last.drives[static_cast<std::size_t>(j)].state, hal::DriveState::enabled) << j;
}

TEST(Hil, Cia402ModeDisplayThatNeverFollowsFailsStartUpNamingTheDrive) {
  REQUIRE_VCAN(7);
  const CanConfig cfg = load("cia402_classic7.yaml");
  Emulator emu(kConfigDir + "cia402_classic7.yaml", "faults: [{kind: mode_display_delay, drive: 8, param: 60000}]\n",
               kCia402DrivesUp);
  ASSERT_TRUE(emu.ready());
  CanHardware hw(cfg);
  const hal::LifecycleResult c = hw.configure();
  EXPECT_FALSE(c.ok);
  EXPECT_NE(c.message.find("drive 8 (joint lh_hfe_joint, cia402) on bus 'lh' (vcan2)"), std::string::npos) << c.message;
  EXPECT_NE(c.message.find("0x6061 still reads 0"), std::string::npos) << c.message;
}

// CAN.md 2.2: any EMCY with a non-zero code latches a drive fault, start-up included. Drive 8
// sends EMCY 0x3210 (and goes to Fault) right after answering its third SDO of the
// Pre-operational configuration; the state machine walk would otherwise fault-reset it.
TEST(Hil, Cia402EmcyDuringStartUpFailsItNamingTheDriveAndTheCode) {
  REQUIRE_VCAN(7);
  const CanConfig cfg = load("cia402_classic7.yaml");
  Emulator emu(kConfigDir + "cia402_classic7.yaml", "faults: [{kind: emcy, drive: 8, at_sdo: 3, param: 0x3210}]\n",
               kCia402DrivesUp);
  ASSERT_TRUE(emu.ready());
  CanHardware hw(cfg);
  hal::LifecycleResult r = hw.configure();
  if (r.ok) r = hw.activate();
  EXPECT_FALSE(r.ok);
  EXPECT_NE(r.message.find("drive 8 (joint lh_hfe_joint, cia402) on bus 'lh' (vcan2)"), std::string::npos) << r.message;
  EXPECT_NE(r.message.find("EMCY 0x3210"), std::string::npos) << r.message;
  EXPECT_EQ(hw.joint(7).status.state, hal::DriveState::fault);
  EXPECT_EQ(hw.joint(7).status.fault_code, 0x3210);
}

// CAN.md 1.4 / 4.2: a vendor MIT drive (8-byte replies) reports an error code in byte 7; a
// non-zero one latches a drive fault, start-up included. Drive 8 boots with error 0x15 in every
// reply; MIT start-up would otherwise mark it ready and enable it. (The drives all reply with 8
// bytes; the host reads the error byte of drive 8 only: with all vendor replies the classic
// layout's bus lf would be above the load limit.)
TEST(Hil, MitVendorErrorDuringStartUpFailsItNamingTheDriveAndTheCode) {
  REQUIRE_VCAN(7);
  CanConfig cfg = load("mit_classic7.yaml");
  ASSERT_EQ(cfg.buses[2].drives[1].drive_id, 8);
  cfg.buses[2].drives[1].mit_vendor_reply = true;
  Emulator emu(kConfigDir + "mit_classic7.yaml", "faults: [{kind: vendor_error, drive: 8, param: 0x15}]\n",
               {"--mit-reply-dlc", "8"});
  ASSERT_TRUE(emu.ready());
  CanHardware hw(cfg);
  hal::LifecycleResult r = hw.configure();
  if (r.ok) r = hw.activate();
  EXPECT_FALSE(r.ok);
  EXPECT_NE(r.message.find("drive 8 (joint lh_hfe_joint, mit) on bus 'lh' (vcan2)"), std::string::npos) << r.message;
  EXPECT_NE(r.message.find("error code 0x15"), std::string::npos) << r.message;
  EXPECT_EQ(hw.joint(7).status.state, hal::DriveState::fault);
  EXPECT_EQ(hw.joint(7).status.fault_code, 0x15);
}

// What the emulator's summary says of each drive at its end: enabled (MIT motor mode / CiA 402
// Operation enabled) and, for a CiA 402 drive, its statusword and NMT state.

// CAN.md 4.4 step 2 after a failed activate(): drive 10 (bus rh, vcan3) is unplugged after the
// start-up's presence check and zero command (its third frame), so its enter-motor-mode goes
// unanswered after buses lf, rf and lh were enabled and while rh's other drives enter motor mode.
// activate() fails naming the drive, and no drive is left in motor mode.
TEST(Hil, FailedActivateLeavesNoMitDriveInMotorMode) {
  REQUIRE_VCAN(7);
  const CanConfig cfg = load("mit_classic7.yaml");
  Emulator emu(kConfigDir + "mit_classic7.yaml", "faults: [{kind: silent, drive: 10, at_frame: 3}]\n");
  ASSERT_TRUE(emu.ready());
  CanHardware hw(cfg);
  const hal::LifecycleResult c = hw.configure();
  ASSERT_TRUE(c.ok) << c.message;
  const hal::LifecycleResult a = hw.activate();
  EXPECT_FALSE(a.ok);
  EXPECT_NE(a.message.find("no valid reply to enter-motor-mode within 200 ms: drive 10 (joint rh_haa_joint, mit) on bus 'rh' (vcan3)"),
            std::string::npos)
      << a.message;
  EXPECT_NE(a.message.find("every drive on bus 'lf' (vcan0), 'rf' (vcan1), 'lh' (vcan2), 'rh' (vcan3) disabled again "
                           "(CAN.md 4.4 step 2)"),
            std::string::npos)
      << a.message;
  for (int j = 0; j < kNj; ++j) EXPECT_NE(hw.joint(j).status.state, hal::DriveState::enabled) << j;
  EXPECT_EQ(hw.write(hal::JointCommands{}), hal::IoStatus::error) << "not active";
  const std::string summary = emu.stop();
  const std::map<int, EmulatedDrive> drives = emulated_drives(summary);
  ASSERT_EQ(drives.size(), static_cast<std::size_t>(kNj)) << summary;
  for (const auto& [id, d] : drives) EXPECT_EQ(d.enabled, 0) << "drive " << id << "\n" << summary;
}

// The same for CiA 402: drive 10's power stage cannot be enabled (enable_blocked: it stays
// Switched on), so the state machine walk fails on bus rh after lf, rf and lh reached Operation
// enabled. Every node walked is disabled (0x0007, 0x0006: Ready to switch on) and pre-operational
// (NMT 80 0); the buses after rh were never walked.
TEST(Hil, FailedActivateLeavesNoCia402DriveOperationEnabled) {
  REQUIRE_VCAN(7);
  const CanConfig cfg = load("cia402_classic7.yaml");
  Emulator emu(kConfigDir + "cia402_classic7.yaml", "faults: [{kind: enable_blocked, drive: 10}]\n", kCia402DrivesUp);
  ASSERT_TRUE(emu.ready());
  CanHardware hw(cfg);
  const hal::LifecycleResult c = hw.configure();
  ASSERT_TRUE(c.ok) << c.message;
  const hal::LifecycleResult a = hw.activate();
  EXPECT_FALSE(a.ok);
  EXPECT_NE(a.message.find("drive 10 (joint rh_haa_joint, cia402) on bus 'rh' (vcan3) stuck in 'switched on'"),
            std::string::npos)
      << a.message;
  EXPECT_NE(a.message.find("every drive on bus 'lf' (vcan0), 'rf' (vcan1), 'lh' (vcan2), 'rh' (vcan3) disabled again"),
            std::string::npos)
      << a.message;
  for (int j = 0; j < kNj; ++j) EXPECT_NE(hw.joint(j).status.state, hal::DriveState::enabled) << j;
  const std::string summary = emu.stop();
  const std::map<int, EmulatedDrive> drives = emulated_drives(summary);
  ASSERT_EQ(drives.size(), static_cast<std::size_t>(kNj)) << summary;
  for (const auto& [id, d] : drives) {
    EXPECT_EQ(d.enabled, 0) << "drive " << id << "\n" << summary;
    EXPECT_EQ(d.nmt, 0x7Fu) << "drive " << id << ": pre-operational";
    // Walked (buses lf .. rh, drives 1..12): shut down to Ready to switch on; the others never left
    // Switch on disabled.
    EXPECT_EQ(d.statusword, id <= 12 ? 0x0231u : 0x0250u) << "drive " << id;
  }
}

// The CiA 402 robot (cia402_classic7) started and shut down against the emulator run with
// `emulator_args`; each drive's NMT reset count, from the emulator's summary (empty on failure).
std::map<int, EmulatedDrive> start_cia402_robot_counting_resets(const std::vector<std::string>& emulator_args) {
  const CanConfig cfg = load("cia402_classic7.yaml");
  Emulator emu(kConfigDir + "cia402_classic7.yaml", "", emulator_args);
  EXPECT_TRUE(emu.ready());
  CanHardware hw(cfg);
  const hal::LifecycleResult c = hw.configure();
  EXPECT_TRUE(c.ok) << c.message;
  const hal::LifecycleResult a = c.ok ? hw.activate() : c;
  EXPECT_TRUE(a.ok) << a.message;
  hw.deactivate();
  const std::map<int, EmulatedDrive> drives = emulated_drives(emu.stop());
  EXPECT_EQ(drives.size(), static_cast<std::size_t>(kNj));
  return c.ok && a.ok ? drives : std::map<int, EmulatedDrive>{};
}

// CAN.md 4.3 step 1: "Wait for the boot-up frame (0x700+n, 00) up to 5 s; if the node is already
// up (heartbeats seen), send NMT reset communication (82 n) and wait for its boot-up." Drives
// powered before the host, heartbeats on (stored 0x1017: 100 ms): each node is reset once, boots
// again and the robot starts.
TEST(Hil, Cia402NodesHeardUpAreResetOnceAndBootAgain) {
  REQUIRE_VCAN(7);
  const std::map<int, EmulatedDrive> drives = start_cia402_robot_counting_resets(kCia402DrivesUp);
  ASSERT_EQ(drives.size(), static_cast<std::size_t>(kNj));
  for (const auto& [id, d] : drives) EXPECT_EQ(d.nmt_resets, 1u) << "drive " << id;
}

// Drives powered 1.5 s after the host started listening (their boot-up is the first they say):
// the host waits for it and resets none, including the nodes of the buses after the first, which
// boot while the first bus starts (the reset a silent node gets at 500 ms reaches no unpowered one).
TEST(Hil, Cia402NodesBootingAfterTheHostStartedAreAwaitedNotReset) {
  REQUIRE_VCAN(7);
  ASSERT_GT(load("cia402_classic7.yaml").timing.boot_timeout_ms, 1500u);
  const std::map<int, EmulatedDrive> drives = start_cia402_robot_counting_resets({"--cia402-boot-after-ms", "1500"});
  ASSERT_EQ(drives.size(), static_cast<std::size_t>(kNj));
  for (const auto& [id, d] : drives) EXPECT_EQ(d.nmt_resets, 0u) << "drive " << id;
}

// Drives powered before the host and silent (stored 0x1017: 0, CiA 301's default: no heartbeat):
// the host missed their boot-up and nothing says they are up. After 500 ms each is sent NMT reset
// communication once, boots and the robot starts (CAN.md 4.3 step 1 waits for a boot-up; a node
// that is up with its heartbeat off would never send one). A drive silent from its first frame on
// (drive 2: unplugged) stops start-up after boot_timeout_ms, named.
TEST(Hil, Cia402NodesNeitherBootingNorHeardAreResetOnceAndBoot) {
  REQUIRE_VCAN(7);
  {
    const std::map<int, EmulatedDrive> drives = start_cia402_robot_counting_resets({});
    ASSERT_EQ(drives.size(), static_cast<std::size_t>(kNj));
    for (const auto& [id, d] : drives) EXPECT_EQ(d.nmt_resets, 1u) << "drive " << id;
  }
  CanConfig cfg = load("cia402_classic7.yaml");
  cfg.timing.boot_timeout_ms = 1000;
  Emulator emu(kConfigDir + "cia402_classic7.yaml", "faults: [{kind: silent, drive: 2, at_frame: 1}]\n");
  ASSERT_TRUE(emu.ready());
  CanHardware hw(cfg);
  const hal::LifecycleResult c = hw.configure();
  EXPECT_FALSE(c.ok);
  EXPECT_EQ(c.message,
            "CiA 402 start-up on bus 'lf': no boot-up within 1000 ms: drive 2 (joint lf_hfe_joint, cia402) on bus 'lf' "
            "(vcan0): neither boot-up nor heartbeat, nor a boot-up after NMT reset communication");
  emu.stop();
}

// A run of `ticks` ticks: the first whose read() reported an error (-1: none), and the last
// tick's measurements and status.
struct ErrorWatch {
  int error_at = -1;
  hal::Measurements last;
  hal::IoStatus last_status{};
};
ErrorWatch run_watching_for_error(CanHardware& hw, int ticks) {
  ErrorWatch w;
  run_ticks(hw, ticks, [&](int k, const hal::Measurements& m, hal::IoStatus s) {
    if (w.error_at < 0 && s == hal::IoStatus::error) w.error_at = k;
    w.last = m;
    w.last_status = s;
  });
  return w;
}

// 80 ticks with the emulator's bus-off of bus lf (vcan0, drive 1's) at tick 30: the bus faults,
// its drives are lost, the others run on.
void run_through_a_bus_off_at_30(CanHardware& hw) {
  const ErrorWatch w = run_watching_for_error(hw, 80);
  EXPECT_GE(w.error_at, 30);
  EXPECT_LE(w.error_at, 32);
  EXPECT_EQ(hw.diagnostics(0).fault, BusFault::bus_off);
  EXPECT_EQ(w.last_status, hal::IoStatus::error);
  for (int j = 0; j < 3; ++j) EXPECT_EQ(w.last.drives[static_cast<std::size_t>(j)].state, hal::DriveState::lost) << j;
  for (int j = 3; j < kNj; ++j) EXPECT_EQ(w.last.drives[static_cast<std::size_t>(j)].state, hal::DriveState::enabled) << j;
}

TEST(Hil, BusOffFaultsTheBusAndNeedsAnOperatorRecovery) {
  REQUIRE_VCAN(7);
  const CanConfig cfg = load("mit_classic7.yaml");
  Emulator emu(kConfigDir + "mit_classic7.yaml", "faults: [{kind: bus_off, drive: 1, at: 30}]\n");
  ASSERT_TRUE(emu.ready());
  CanHardware hw(cfg);
  ASSERT_TRUE(hw.configure().ok);
  ASSERT_TRUE(hw.activate().ok);
  run_through_a_bus_off_at_30(hw);
  // Nothing resumes by itself (the emulated drives still answer): recovery is an operator action.
  const hal::LifecycleResult r = hw.recover_bus(0);
  ASSERT_TRUE(r.ok) << r.message;
  int ok_ticks = 0;
  hal::Measurements after;
  run_ticks(hw, 50, [&](int, const hal::Measurements& m, hal::IoStatus s) {
    ok_ticks += s == hal::IoStatus::ok ? 1 : 0;
    after = m;
  });
  EXPECT_GE(ok_ticks, 45);
  EXPECT_EQ(hw.diagnostics(0).fault, BusFault::none);
  for (int j = 0; j < kNj; ++j) EXPECT_EQ(after.drives[static_cast<std::size_t>(j)].state, hal::DriveState::enabled) << j;
}

// A full transmit queue, made by the kernel: a pfifo qdisc of length 0 on vcan0 drops every
// frame, and the raw socket's write() fails with ENOBUFS, as on a real controller whose queue is
// full. One tick of it is counted (the rest of that bus's frames dropped, never retried); on
// tx_fault_ticks ticks in a row it faults the bus.
TEST(Hil, TransmitQueueFullIsCountedThenFaultsTheBus) {
  REQUIRE_VCAN(7);
  const CanConfig cfg = load("mit_classic7.yaml");
  Emulator emu(kConfigDir + "mit_classic7.yaml", "");
  ASSERT_TRUE(emu.ready());
  CanHardware hw(cfg);
  ASSERT_TRUE(hw.configure().ok);
  ASSERT_TRUE(hw.activate().ok);
  const auto no_op = [](int, const hal::Measurements&, hal::IoStatus) {};
  run_ticks(hw, 20, no_op);
  EXPECT_EQ(hw.diagnostics(0).tx_dropped, 0u);
  const auto queue = [](bool full) {
    return std::system(full ? "tc qdisc add dev vcan0 root pfifo limit 0" : "tc qdisc del dev vcan0 root");
  };
  if (queue(true) != 0) GTEST_SKIP() << "needs tc and the pfifo qdisc";
  run_ticks(hw, 1, no_op);  // one tick: 3 frames not sent
  ASSERT_EQ(queue(false), 0);
  hal::Measurements last;
  run_ticks(hw, 20, [&](int, const hal::Measurements& m, hal::IoStatus) { last = m; });
  EXPECT_EQ(hw.diagnostics(0).tx_dropped, 3u);  // the ENOBUFS frame and the rest of the tick
  EXPECT_EQ(hw.diagnostics(0).fault, BusFault::none);
  for (int j = 0; j < kNj; ++j) EXPECT_EQ(last.drives[static_cast<std::size_t>(j)].state, hal::DriveState::enabled) << j;
  for (int b = 1; b < hw.bus_count(); ++b) EXPECT_EQ(hw.diagnostics(b).tx_dropped, 0u) << b;

  ASSERT_EQ(queue(true), 0);
  hal::IoStatus last_status{};
  run_ticks(hw, static_cast<int>(cfg.timing.tx_fault_ticks) + 2, [&](int, const hal::Measurements& m, hal::IoStatus s) {
    last = m;
    last_status = s;
  });
  ASSERT_EQ(queue(false), 0);
  EXPECT_EQ(hw.diagnostics(0).fault, BusFault::tx_queue_full);
  EXPECT_GE(hw.diagnostics(0).tx_dropped, 3u + 3u * cfg.timing.tx_fault_ticks);
  EXPECT_EQ(last_status, hal::IoStatus::error);
  for (int j = 0; j < 3; ++j) EXPECT_EQ(last.drives[static_cast<std::size_t>(j)].state, hal::DriveState::lost) << j;
  for (int j = 3; j < kNj; ++j) EXPECT_EQ(last.drives[static_cast<std::size_t>(j)].state, hal::DriveState::enabled) << j;
}

// CAN.md 4.1: a heartbeat missing for heartbeat_lost_periods marks the drive lost even while its
// PDOs still flow (the supervisor then damps: tests/safety).
TEST(Hil, Cia402HeartbeatLossMarksTheDriveLostWhilePdosFlow) {
  REQUIRE_VCAN(7);
  CanConfig cfg = load("cia402_classic7.yaml");
  cfg.timing.heartbeat_lost_periods = 3;  // 300 ms at the 100 ms producer heartbeat time
  Emulator emu(kConfigDir + "cia402_classic7.yaml", "faults: [{kind: no_heartbeat, drive: 5, at: 120}]\n",
               kCia402DrivesUp);
  ASSERT_TRUE(emu.ready());
  CanHardware hw(cfg);
  const hal::LifecycleResult c = hw.configure();
  ASSERT_TRUE(c.ok) << c.message;
  ASSERT_TRUE(hw.activate().ok);
  int lost_at = -1;
  std::uint64_t missed_when_lost = 0;
  hal::Measurements last;
  run_ticks(hw, 500, [&](int k, const hal::Measurements& m, hal::IoStatus) {
    if (lost_at < 0 && m.drives[4].state == hal::DriveState::lost) {
      lost_at = k;
      missed_when_lost = m.drives[4].missed_total;
    }
    last = m;
  });
  // The drive's tick 120 (its SYNCs, the keep-alive's while later buses were enabled among them:
  // at most 100 here) came on the run's tick 20..120; the last heartbeat at most one period
  // (100 ticks) before it, lost 300 ticks after that.
  EXPECT_GE(lost_at, 20 - 100 + 300);
  EXPECT_LE(lost_at, 120 + 300 + 10);
  EXPECT_LE(missed_when_lost, 10u) << "its TPDOs kept coming";
  for (int j = 0; j < kNj; ++j) {
    if (j != 4) {
      EXPECT_EQ(last.drives[static_cast<std::size_t>(j)].state, hal::DriveState::enabled) << j;
    }
  }
}

TEST(Hil, TransientFaultsAreCountedNotFatal) {
  REQUIRE_VCAN(7);
  const CanConfig cfg = load("mit_classic7.yaml");
  Emulator emu(kConfigDir + "mit_classic7.yaml",
               "faults:\n"
               "  - {kind: drop, drive: 2, at: 20, count: 2}\n"
               "  - {kind: duplicate, drive: 4, at: 20, count: 3}\n"
               "  - {kind: corrupt, drive: 8, at: 30, count: 1}\n"
               "  - {kind: wrong_dlc, drive: 10, at: 30, count: 2}\n"
               "  - {kind: unexpected_id, drive: 13, at: 30, count: 2, param: 100}\n"
               "  - {kind: delay, drive: 16, at: 40, count: 1, param: 2}\n"
               "  - {kind: error_passive, drive: 19, at: 25}\n"
               "  - {kind: error_active, drive: 19, at: 60}\n");
  ASSERT_TRUE(emu.ready());
  CanHardware hw(cfg);
  ASSERT_TRUE(hw.configure().ok);
  ASSERT_TRUE(hw.activate().ok);
  hal::Measurements last;
  // Bus arm2 (vcan6, bus 6) degraded from its error-passive report to its error-active one.
  int degraded_from = -1, degraded_until = -1;
  std::uint32_t other_degraded = 0;
  run_ticks(hw, 80, [&](int k, const hal::Measurements& m, hal::IoStatus) {
    const bool degraded = (m.degraded_buses & (1u << 6)) != 0;
    if (degraded && degraded_from < 0) degraded_from = k;
    if (!degraded && degraded_from >= 0 && degraded_until < 0) degraded_until = k;
    other_degraded |= m.degraded_buses & ~(1u << 6);
    last = m;
  });
  EXPECT_GE(degraded_from, 25);
  EXPECT_LE(degraded_from, 28);
  EXPECT_GE(degraded_until, 60);
  EXPECT_LE(degraded_until, 63);
  EXPECT_EQ(other_degraded, 0u);
  EXPECT_EQ(last.degraded_buses, 0u);
  EXPECT_FALSE(hw.diagnostics(6).error_passive);             // back to normal
  EXPECT_EQ(hw.diagnostics(6).error_passive_events, 1u);
  for (int j = 0; j < kNj; ++j) EXPECT_EQ(last.drives[static_cast<std::size_t>(j)].state, hal::DriveState::enabled) << j;
  EXPECT_GE(last.drives[1].missed_total, 2u);                // dropped
  EXPECT_GE(hw.diagnostics(1).duplicates, 3u);               // drive 4 on bus rf
  EXPECT_GE(hw.diagnostics(2).bad_frames, 1u);               // drive 8: implausible position jump
  EXPECT_GE(last.drives[7].missed_total, 1u);
  EXPECT_GE(hw.diagnostics(3).bad_frames, 2u);               // drive 10: DLC 5
  EXPECT_GE(hw.diagnostics(4).unexpected_frames, 2u);        // drive 13 answering as drive 100: no drive of the robot
  EXPECT_EQ(hw.diagnostics(4).foreign_frames, 0u);
  EXPECT_GE(last.drives[15].missed_total, 1u);               // drive 16 delayed by 2 ticks
  EXPECT_EQ(hw.diagnostics(6).fault, BusFault::none);        // bus arm2 was only degraded
}

// CAN.md 4.1: "a valid frame with an id of another bus is a configuration fault". From its cyclic
// tick 30 drive 13 (bus arm0, vcan4) answers naming drive 5 (bus rf) in byte 0: the frame passes
// arm0's CAN_RAW_FILTER (its CAN id is drive 13's reply id, 0x10D) and would be taken for a reply.
// The bus faults: its drives are lost (the supervisor's drive-lost fault, damping), read()
// reports an error, the diagnostics name the bus, the drive and the id; the other buses go on.
// The bus still carries frames: deactivate() disables its drives too.
TEST(Hil, AFrameNamingADriveOfAnotherBusFaultsItsBus) {
  REQUIRE_VCAN(7);
  const CanConfig cfg = load("mit_classic7.yaml");
  Emulator emu(kConfigDir + "mit_classic7.yaml", "faults: [{kind: unexpected_id, drive: 13, at: 30, count: 5, param: 5}]\n");
  ASSERT_TRUE(emu.ready());
  CanHardware hw(cfg);
  ASSERT_TRUE(hw.configure().ok);
  ASSERT_TRUE(hw.activate().ok);
  const ErrorWatch w = run_watching_for_error(hw, 80);
  EXPECT_GE(w.error_at, 30);
  EXPECT_LE(w.error_at, 32);
  EXPECT_EQ(w.last_status, hal::IoStatus::error);
  const BusDiagnostics& d = hw.diagnostics(4);
  EXPECT_EQ(d.fault, BusFault::foreign_drive);
  EXPECT_GE(d.foreign_frames, 1u);
  EXPECT_EQ(d.foreign_drive_id, 5);
  EXPECT_EQ(d.foreign_can_id, 0x10Du);
  for (int j = 12; j < 15; ++j) EXPECT_EQ(w.last.drives[static_cast<std::size_t>(j)].state, hal::DriveState::lost) << j;
  for (int j = 0; j < kNj; ++j) {
    if (j < 12 || j >= 15) {
      EXPECT_EQ(w.last.drives[static_cast<std::size_t>(j)].state, hal::DriveState::enabled) << j;
    }
  }
  for (int b = 0; b < hw.bus_count(); ++b) {
    if (b != 4) {
      EXPECT_EQ(hw.diagnostics(b).fault, BusFault::none) << b;
    }
  }
  const std::string report = hw.diagnostics_report();
  EXPECT_NE(report.find("can bus arm0 (vcan4): fault=configuration fault: a frame of a drive configured on another bus"),
            std::string::npos)
      << report;
  EXPECT_NE(report.find(" foreign_drive=5 foreign_id=0x10D "), std::string::npos) << report;
  hw.deactivate();
  const std::map<int, EmulatedDrive> drives = emulated_drives(emu.stop());
  ASSERT_EQ(drives.size(), static_cast<std::size_t>(kNj));
  for (const auto& [id, dr] : drives) EXPECT_EQ(dr.enabled, 0) << "drive " << id;
  // The bus's drives are usable (CAN.md 4.4: "a fault that leaves drives usable"): they were
  // commanded through the 50 ticks after the fault and the shut-down's damping, as those of a
  // healthy bus (drive 1, bus lf), not left to hold their last command until CAN_TIMEOUT.
  for (const int id : {13, 14, 15}) {
    EXPECT_GE(drives.at(id).frames_in + 3, drives.at(1).frames_in) << "drive " << id;
  }
}

// CAN.md 4: after a bus-off, CAN_ERR_RESTARTED says the controller is back on the bus; its drives
// "must be re-enabled through start-up, never silently resumed". So the bus stays faulted and is
// not commanded, but a shut-down reaches it again and takes its drives out of motor mode (4.4
// step 2) instead of leaving them in motor mode at a zero command (CAN_TIMEOUT). Without the
// restart the bus is not reached.
TEST(Hil, AShutDownDisablesTheDrivesOfABusWhoseControllerRestartedAfterBusOff) {
  REQUIRE_VCAN(7);
  const CanConfig cfg = load("mit_classic7.yaml");
  for (const bool restart : {true, false}) {
    SCOPED_TRACE(restart ? "restarted" : "no restart");
    // The restart right after the bus-off (restart-ms short): an MIT drive's ticks are the
    // commands it takes, and none come after the bus-off.
    Emulator emu(kConfigDir + "mit_classic7.yaml",
                 restart ? "faults: [{kind: bus_off, drive: 1, at: 30}, {kind: restarted, drive: 1, at: 30}]\n"
                         : "faults: [{kind: bus_off, drive: 1, at: 30}]\n");
    ASSERT_TRUE(emu.ready());
    CanHardware hw(cfg);
    ASSERT_TRUE(hw.configure().ok);
    ASSERT_TRUE(hw.activate().ok);
    run_through_a_bus_off_at_30(hw);
    EXPECT_EQ(hw.diagnostics(0).controller_restarted, restart);
    hw.deactivate();
    const std::map<int, EmulatedDrive> drives = emulated_drives(emu.stop());
    ASSERT_EQ(drives.size(), static_cast<std::size_t>(kNj));
    for (const auto& [id, dr] : drives) {
      EXPECT_EQ(dr.enabled, id <= 3 && !restart ? 1 : 0) << "drive " << id;
      // Not commanded after the bus-off: the restarted bus gets only the shut-down's frame.
      if (id <= 3) {
        EXPECT_LE(dr.frames_in, drives.at(4).frames_in - 40) << "drive " << id;
      }
    }
  }
}

// The same fault met during start-up stops it: a reply naming drive 5 (bus rf) arrives on bus arm0
// between configure() and activate() (sent here, in drive 13's reply id). activate() fails naming
// the bus, the id and the drive, and leaves no drive enabled.
TEST(Hil, AFrameNamingADriveOfAnotherBusFailsStartUp) {
  REQUIRE_VCAN(7);
  const CanConfig cfg = load("mit_classic7.yaml");
  Emulator emu(kConfigDir + "mit_classic7.yaml", "");
  ASSERT_TRUE(emu.ready());
  CanHardware hw(cfg);
  const hal::LifecycleResult c = hw.configure();
  ASSERT_TRUE(c.ok) << c.message;
  SocketCanBus arm0;
  ASSERT_EQ(arm0.open("vcan4", false, {}, false), "");
  mit::Reply reply;
  reply.drive_id = 5;
  Frame f;
  mit::encode_reply(0x10D, reply, cfg.buses[1].drives[1].mit_ranges, mit::kReplyLen, f);
  ASSERT_EQ(arm0.send(f), TxStatus::ok);
  const hal::LifecycleResult a = hw.activate();
  EXPECT_FALSE(a.ok);
  EXPECT_NE(a.message.find("bus 'arm0' (vcan4): configuration fault: a frame of a drive configured on another bus "
                           "(CAN.md 4.1): CAN id 0x10D naming drive 5 (joint rf_hfe_joint, mit) on bus 'rf' (vcan1)"),
            std::string::npos)
      << a.message;
  EXPECT_NE(a.message.find("'arm0' (vcan4) disabled again"), std::string::npos) << a.message;
  for (int j = 0; j < kNj; ++j) EXPECT_NE(hw.joint(j).status.state, hal::DriveState::enabled) << j;
  const std::map<int, EmulatedDrive> drives = emulated_drives(emu.stop());
  ASSERT_EQ(drives.size(), static_cast<std::size_t>(kNj));
  for (const auto& [id, dr] : drives) EXPECT_EQ(dr.enabled, 0) << "drive " << id;
}

// The deployed binary as a child process; stdout and stderr into one file.
class Firmware {
 public:
  Firmware(const std::string& config, int time_scale) {
    out_ = "/tmp/springbok_fw_out_" + std::to_string(::getpid());
    std::vector<std::string> args{std::string(SPRINGBOK_BIN_DIR) + "/springbok", "--config", config, "--time-scale",
                                  std::to_string(time_scale)};
    pid_ = ::fork();
    if (pid_ == 0) {
      std::freopen(out_.c_str(), "w", stdout);
      ::dup2(::fileno(stdout), 2);
      std::vector<char*> argv;
      for (std::string& a : args) argv.push_back(a.data());
      argv.push_back(nullptr);
      ::execv(argv[0], argv.data());
      ::_exit(127);
    }
  }
  ~Firmware() { stop(); }
  bool running() {
    int status = 0;
    return pid_ > 0 && ::waitpid(pid_, &status, WNOHANG) == 0;
  }
  // SIGTERM (orderly stop: damping, drives disabled); returns everything it printed.
  std::string stop() {
    if (pid_ > 0) {
      ::kill(pid_, SIGTERM);
      ::waitpid(pid_, &status_, 0);
      pid_ = -1;
      std::ifstream in(out_);
      std::stringstream ss;
      ss << in.rdbuf();
      output_ = ss.str();
      ::unlink(out_.c_str());
    }
    return output_;
  }
  int exit_status() const { return status_; }

 private:
  pid_t pid_ = -1;
  int status_ = -1;
  std::string out_, output_;
};

// One line to the operator socket, its one-line answer ("" when the socket is not there).
std::string operator_line(const std::string& socket_path, const std::string& line) {
  const int fd = ::socket(AF_UNIX, SOCK_STREAM, 0);
  sockaddr_un addr{};
  addr.sun_family = AF_UNIX;
  std::snprintf(addr.sun_path, sizeof addr.sun_path, "%s", socket_path.c_str());
  std::string reply;
  if (::connect(fd, reinterpret_cast<const sockaddr*>(&addr), sizeof addr) == 0) {
    const std::string msg = line + "\n";
    if (::write(fd, msg.data(), msg.size()) == static_cast<ssize_t>(msg.size())) {
      char c = 0;
      while (::read(fd, &c, 1) == 1 && c != '\n') reply += c;
    }
  }
  ::close(fd);
  return reply;
}

// One line of the emulator's ground-truth trace (--truth-log; bullet_motion.hpp names the columns).
struct TruthSample {
  double t_s = 0.0, trunk_z_m = 0.0, tilt_rad = 0.0;
  int non_foot_contact = 0;
  double trunk_x_m = 0.0, trunk_y_m = 0.0;
  Vec3 hand_m = Vec3::Zero(), hand_force_n = Vec3::Zero();
  int foot_contacts = 0;  // bit per foot: lf 1, rf 2, lh 4, rh 8
  char command = 'o';     // what the drives were told: o off, z zero torque, d damping, p position PD, t torque
  unsigned long long step = 0;
};

// The emulator's ground-truth trace, as far as it is written (a partial last line is skipped).
std::vector<TruthSample> read_truth(const std::string& path) {
  std::vector<TruthSample> out;
  std::ifstream in(path);
  for (std::string line; std::getline(in, line);) {
    TruthSample t;
    double hx, hy, hz, fx, fy, fz;
    if (std::sscanf(line.c_str(), "%lf %lf %lf %d %lf %lf %lf %lf %lf %lf %lf %lf %d %c %llu", &t.t_s, &t.trunk_z_m,
                    &t.tilt_rad, &t.non_foot_contact, &t.trunk_x_m, &t.trunk_y_m, &hx, &hy, &hz, &fx, &fy, &fz,
                    &t.foot_contacts, &t.command, &t.step) != 15) {
      continue;
    }
    t.hand_m = Vec3(hx, hy, hz);
    t.hand_force_n = Vec3(fx, fy, fz);
    out.push_back(t);
  }
  return out;
}

// The time of the trace's last complete line (reads only the file's tail).
double truth_time(const std::string& path) {
  std::ifstream in(path, std::ios::ate);
  const std::streamoff size = in.tellg();
  if (size <= 0) return 0.0;
  in.seekg(std::max<std::streamoff>(0, size - 400));
  std::string tail((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const std::size_t end = tail.rfind('\n');
  if (end == std::string::npos) return 0.0;
  const std::size_t start = tail.rfind('\n', end == 0 ? 0 : end - 1);
  if (start == std::string::npos) return 0.0;
  return std::atof(tail.c_str() + start + 1);
}

// The deployed binary's --time-scale: SPRINGBOK_HIL_TIME_SCALE or `fallback`.
// A lost sensor damps the robot within stale_ticks + 2 emulator steps of the fault (a tick to
// see it stale, one for the command to reach the drives), one more when the last good sample
// before it reached the host a tick late (the VM's latency, CAN.md 5): it counted as fresh a
// tick later, and the staleness began a tick later.
constexpr unsigned long long kDampingSlackTicks = 3;

int hil_time_scale(int fallback) {
  const char* env = std::getenv("SPRINGBOK_HIL_TIME_SCALE");
  return env != nullptr ? std::atoi(env) : fallback;
}

// Waits (wall clock) until done() or the firmware exits or `limit_s` passes.
template <class Done>
bool wait_for(Firmware& fw, double limit_s, Done&& done) {
  const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(limit_s);
  while (std::chrono::steady_clock::now() < end) {
    if (done()) return true;
    if (!fw.running()) return false;
    std::this_thread::sleep_for(std::chrono::milliseconds(200));
  }
  return false;
}

// The trunk height over flat ground for these joint angles with the trunk level:
// the lowest foot sphere touches the ground (springbok::dyn forward kinematics).
double standing_height_m(const VecNj& q_joints) {
  const dyn::Model model;
  auto data = std::make_unique<dyn::Data>();
  VecNq q = VecNq::Zero();
  q[6] = 1.0;
  q.tail<kNj>() = q_joints;
  dyn::forward_kinematics(model, *data, q);
  double lowest = 0.0;
  for (int f = 0; f < kFeet; ++f) {
    lowest = std::min(lowest, data->frames[static_cast<std::size_t>(kFootFrames[static_cast<std::size_t>(f)])].translation.z());
  }
  return kFootRadius_m - lowest;
}

// Issue 10: the deployed binary stands the simulated robot through vcan for 5 s.
// LOCKSTEP: the emulator steps sim_hal's Bullet world once per firmware tick (when all 19
// commands of the tick are in) and the firmware runs --time-scale N times slower than
// wall time, so that under the VM's emulated CPU (a Bullet step ~6 ms) every reply still
// arrives before its receive deadline. All times below are simulated unless said wall.
TEST(Hil, DeployedBinaryStandsTheSimulatedRobotFor5s) {
  REQUIRE_VCAN(7);
  const int time_scale = hil_time_scale(20);
  ASSERT_GE(time_scale, 1);
  const std::string config = kConfigDir + "stand_mit7.yaml";
  const std::string socket_path = "/tmp/springbok_hil_stand.sock";  // operator.socket of the config
  const std::string truth = "/tmp/springbok_hil_truth_" + std::to_string(::getpid()) + ".txt";
  // --settle-s: the first Bullet steps are slow under the VM's emulated CPU (code not yet
  // translated); 0.1 s unpowered on the feet before the drives boot warms them up. Bus arm2's
  // controller reports error passive for a second (CAN.md 4): a warning, logged both ways. The
  // drives reply as the reference firmware has since July 2023: 7 bytes, byte 6 their supply
  // (CAN.md 1.4).
  Emulator emu(config,
               "faults:\n"
               "  - {kind: error_passive, drive: 19, at: 1000}\n"
               "  - {kind: error_active, drive: 19, at: 2000}\n",
               {"--motion", "bullet", "--truth-log", truth, "--settle-s", "0.1", "--mit-reply-dlc", "7",
                "--mit-bus-voltage-v", "24"});
  ASSERT_TRUE(emu.ready());
  ::unlink(socket_path.c_str());
  Firmware fw(config, time_scale);
  const double wall_per_sim_s = time_scale * 1.2 + 5.0;  // generous: the wall time a simulated second may take
  // The robot spawns crouched on its feet (sim_hal); idle only damps (it cannot hold the
  // robot up), so the operator starts the stand-up as soon as the firmware listens.
  std::string started;
  ASSERT_TRUE(wait_for(fw, 120.0, [&] {
    started = operator_line(socket_path, "start");
    return !started.empty();
  })) << fw.stop();
  EXPECT_EQ(started.rfind("ok", 0), 0u) << started;
  ASSERT_TRUE(wait_for(fw, 60.0, [&] { return !read_truth(truth).empty(); })) << fw.stop();
  const double crouch_z_m = read_truth(truth).front().trunk_z_m;
  std::string status;
  ASSERT_TRUE(wait_for(fw, 4.0 * wall_per_sim_s, [&] {
    status = operator_line(socket_path, "status");
    return status.find("mode=stand ") != std::string::npos || status.find("mode=damping") != std::string::npos;
  })) << status << "\n" << fw.stop();
  ASSERT_NE(status.find("mode=stand "), std::string::npos) << status << "\n" << fw.stop() << emu.stop();
  const double t_stand_s = truth_time(truth);
  ASSERT_TRUE(wait_for(fw, 6.0 * wall_per_sim_s, [&] { return truth_time(truth) >= t_stand_s + 5.0; }));
  status = operator_line(socket_path, "status");
  EXPECT_NE(status.find("mode=stand faults=none"), std::string::npos) << status;
  const std::string fw_out = fw.stop();
  EXPECT_TRUE(WIFEXITED(fw.exit_status()) && WEXITSTATUS(fw.exit_status()) == 0) << fw_out;
  EXPECT_NE(fw_out.find("mode=stand faults=none"), std::string::npos) << fw_out;
  EXPECT_NE(fw_out.find(" buses_degraded a=64 b=0 x=0 (degraded=bus6 was=none)\n"), std::string::npos) << fw_out;
  EXPECT_NE(fw_out.find(" buses_degraded a=0 b=64 x=0 (degraded=none was=bus6)\n"), std::string::npos) << fw_out;
  for (int j = 0; j < kNj; ++j) {  // each drive's supply, from its 7-byte replies
    const std::string line = "can drive " + std::to_string(j + 1) + " (" + std::string(robot::kJoints[static_cast<std::size_t>(j)].name) +
                             "): bus_voltage_v=24.00 bus_voltage_low=0 wrong_dlc_replies=0";
    EXPECT_NE(fw_out.find(line), std::string::npos) << line << "\n" << fw_out;
  }
  const std::string summary = emu.stop();

  // The emulator's ground truth over the 5 s of standing.
  const std::vector<TruthSample> samples = read_truth(truth);
  ::unlink(truth.c_str());
  double z_min = 1e9, z_max = -1e9, tilt_max = 0.0, z_min_late = 1e9, z_max_late = -1e9;
  int n = 0, non_foot = 0;
  for (const TruthSample& t : samples) {
    if (t.t_s < t_stand_s || t.t_s > t_stand_s + 5.0) continue;
    ++n;
    z_min = std::min(z_min, t.trunk_z_m);
    z_max = std::max(z_max, t.trunk_z_m);
    tilt_max = std::max(tilt_max, t.tilt_rad);
    non_foot += t.non_foot_contact;
    if (t.t_s >= t_stand_s + 2.0) {  // stand is entered within stand_tolerance_rad, still settling
      z_min_late = std::min(z_min_late, t.trunk_z_m);
      z_max_late = std::max(z_max_late, t.trunk_z_m);
    }
  }
  // The oracle: the trunk height at which the stand posture puts the feet on the ground.
  VecNj stand = VecNj::Zero();
  for (int j = 0; j < 12; ++j) stand[j] = stance(j);
  const double z_stand_m = standing_height_m(stand);
  std::printf("standing %.2f .. %.2f s: trunk z %.4f .. %.4f m (last 3 s %.4f .. %.4f; stand posture on flat ground: "
              "%.4f m; crouched at start-up %.4f m), max tilt %.4f rad\n",
              t_stand_s, t_stand_s + 5.0, z_min, z_max, z_min_late, z_max_late, z_stand_m, crouch_z_m, tilt_max);
  EXPECT_GE(n, 400) << "trace samples in the 5 s";
  EXPECT_LT(crouch_z_m, z_stand_m - 0.1) << "it stood up from a crouch";
  // The joint PD without gravity compensation sags a little (stand_tolerance_rad 0.15).
  EXPECT_NEAR(z_min, z_stand_m, 0.06);
  EXPECT_NEAR(z_max, z_stand_m, 0.06);
  EXPECT_LT(z_max_late - z_min_late, 0.005) << "it holds still (last 3 s)";
  EXPECT_LT(tilt_max, 0.05);
  EXPECT_EQ(non_foot, 0) << "only the feet touch the ground";
  // Lockstep held: every step had the commands of all 19 drives.
  EXPECT_NE(summary.find("forced_steps 0\n"), std::string::npos) << summary;
}

// ---- Issue 18: the deployed whole-body controller over CAN, with the trunk IMU and the wrist
// F/T on the sensor bus (vcan7), against the emulator's Bullet world in lockstep. Simulated
// times below (the emulator's clock; 0 = the end of its settling; sensor sample k = step k).

const std::string kWbcConfig = kConfigDir + "wbc_mit8.yaml";
const std::string kWbcSocket = "/tmp/springbok_hil_wbc.sock";  // operator.socket of that config

app::AppConfig wbc_hil_config() {
  const app::ConfigResult r = app::load_config_file(kWbcConfig);
  EXPECT_TRUE(r.ok) << (r.errors.empty() ? "" : r.errors.front());
  return r.config;
}

std::uint32_t wbc_hil_stale_ticks() {
  const CanConfig cfg = load("wbc_mit8.yaml");
  EXPECT_EQ(cfg.sensors.imu.stale_ticks, cfg.sensors.wrist_ft.stale_ticks);
  return cfg.sensors.imu.stale_ticks;
}

// The operator's path to the control mode: start (stand-up from the crouch), stand, the wrist
// F/T tared, mode control. Returns the simulated time control was entered (< 0: it was not).
double enter_control(Firmware& fw, const std::string& truth, double wall_per_sim_s, std::string& why) {
  std::string reply;
  if (!wait_for(fw, 120.0, [&] { return !(reply = operator_line(kWbcSocket, "start")).empty(); })) {
    why = "no operator socket";
    return -1.0;
  }
  if (reply.rfind("ok start", 0) != 0) {
    why = reply;
    return -1.0;
  }
  if (!wait_for(fw, 4.0 * wall_per_sim_s, [&] {
        reply = operator_line(kWbcSocket, "status");
        return reply.find("mode=stand ") != std::string::npos || reply.find("mode=damping") != std::string::npos;
      }) ||
      reply.find("mode=stand ") == std::string::npos) {
    why = "no stand: " + reply;
    return -1.0;
  }
  if (!wait_for(fw, 2.0 * wall_per_sim_s, [&] {
        reply = operator_line(kWbcSocket, "controller");
        return reply.find("tare=done") != std::string::npos;
      })) {
    why = "no tare: " + reply;
    return -1.0;
  }
  reply = operator_line(kWbcSocket, "mode control");
  if (reply.rfind("ok mode control", 0) != 0) {
    why = reply;
    return -1.0;
  }
  return truth_time(truth);
}

// The host's damping (CAN.md 4.4: kd = D in the drives, no target).
bool damps(char command) { return command == 'd'; }

// The first step from `from_step` on whose drive command is damping, 0 if none.
unsigned long long first_damping_step(const std::vector<TruthSample>& samples, unsigned long long from_step) {
  for (const TruthSample& t : samples) {
    if (t.step >= from_step && damps(t.command)) return t.step;
  }
  return 0;
}

// Cases 1 and 2: stand, tare, control; a 30 N step at the hand rendered as the template; trot
// 4.5 s on the operator's command; then a streak of corrupt quaternions. Its in-process twin
// (tests/app/timing: TheHilConfigRendersAPushThenTrotsWithTheCanPathsDelays) runs the same
// config and the same operator steps through the MIT codec, the emulator's joint friction and
// the CAN path's delays, deterministically; it found what made this case fail: the replies'
// 12-bit truncated velocity (push NRMSE 14 %; now the backend's velocity observer,
// can.mit_velocity_observer_rad_s), a trunk attitude task too soft for two ticks of latency on
// one diagonal (the fall; now WbcParams' defaults), the IMU's q_w as CAN.md 6.1 decodes it and
// as the gyro alone tracks it (the trunk_imu is upside down: mrad of false pitch, the base 4 %
// past F/K; now can::OrientationTrack with gravity), and the emulated joints' friction on the
// wrist (the hand 7.3 % off; now compensated, control.wbc.joint_friction). Measured here at the
// time scale 20 (2 vCPUs, 243 s wall): NRMSE base 0.71-1.26 %, hand 1.72-1.81 %, end
// displacement base 29.3-29.8 mm (F/K 30), hand 89.1-89.6 mm (90); the trot holds (every foot
// lifts, tilt 0.043 rad).
// SPRINGBOK_HIL_KEEP=<dir> keeps the trace, the controller's reports and the firmware's output.
TEST(Hil, DeployedWholeBodyControllerRendersTheTemplateThenTrots) {
  REQUIRE_VCAN(8);
  const int time_scale = hil_time_scale(20);
  ASSERT_GE(time_scale, 1);
  const double wall_per_sim_s = time_scale * 1.3 + 5.0;
  const app::AppConfig config = wbc_hil_config();
  const std::uint32_t stale_ticks = wbc_hil_stale_ticks();
  constexpr double kPushStart_s = 5.0, kPushEnd_s = 8.5, kForce_n = 30.0, kTrotAt_s = 9.0, kTrotUntil_s = 13.5;
  constexpr unsigned long long kStreakAt = 14000;
  const std::string truth = "/tmp/springbok_hil_wbc_truth_" + std::to_string(::getpid()) + ".txt";
  Emulator emu(kWbcConfig,
               "faults:\n"
               "  - {kind: corrupt_quaternion, sensor: imu, at: 4500, count: 3}\n"
               "  - {kind: corrupt_quaternion, sensor: imu, at: 14000, count: 1000000}\n",
               {"--motion", "bullet", "--truth-log", truth, "--truth-every", "1", "--settle-s", "0.1",
                "--hand-force-n", std::to_string(kForce_n), "--hand-force-axis", "x", "--hand-force-start-s",
                std::to_string(kPushStart_s), "--hand-force-duration-s", std::to_string(kPushEnd_s - kPushStart_s)});
  ASSERT_TRUE(emu.ready());
  ::unlink(kWbcSocket.c_str());
  const auto wall_start = std::chrono::steady_clock::now();
  Firmware fw(kWbcConfig, time_scale);
  std::string why;
  const double t_control_s = enter_control(fw, truth, wall_per_sim_s, why);
  ASSERT_GE(t_control_s, 0.0) << why << "\n" << fw.stop();
  ASSERT_LT(t_control_s, 4.4) << "the control mode must be on before the IMU burst and the push";

  ASSERT_TRUE(wait_for(fw, (kTrotAt_s - t_control_s + 1.0) * wall_per_sim_s,
                       [&] { return truth_time(truth) >= kTrotAt_s; }));
  std::string status = operator_line(kWbcSocket, "status");
  EXPECT_NE(status.find("mode=control faults=none"), std::string::npos) << status;
  const std::string trot = operator_line(kWbcSocket, "gait trot step_frequency=1.4 duty_factor=0.65");
  EXPECT_EQ(trot.rfind("ok gait trot (mode=control faults=none)", 0), 0u) << trot;
  const double t_trot_s = truth_time(truth);
  const char* keep = std::getenv("SPRINGBOK_HIL_KEEP");  // a directory: the trace and the controller's reports go there
  std::ofstream reports(keep != nullptr ? std::string(keep) + "/controller_reports.txt" : std::string("/dev/null"));
  ASSERT_TRUE(wait_for(fw, (kTrotUntil_s - t_trot_s + 1.0) * wall_per_sim_s, [&] {
    const double t = truth_time(truth);
    if (keep != nullptr) reports << t << " " << operator_line(kWbcSocket, "controller") << "\n";
    return t >= kTrotUntil_s;
  }));
  status = operator_line(kWbcSocket, "status");
  EXPECT_NE(status.find("mode=control faults=none"), std::string::npos) << status;
  const std::string report = operator_line(kWbcSocket, "controller");
  EXPECT_NE(report.find("gait=trot step_frequency=1.4 duty_factor=0.65"), std::string::npos) << report;
  ASSERT_TRUE(wait_for(fw, 1.5 * wall_per_sim_s, [&] { return truth_time(truth) >= kStreakAt / 1000.0 + 0.1; }));
  status = operator_line(kWbcSocket, "status");
  EXPECT_NE(status.find("mode=damping faults="), std::string::npos) << status;
  EXPECT_NE(status.find("imu_lost"), std::string::npos) << status;
  const std::string fw_out = fw.stop();
  const double wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - wall_start).count();
  const std::string summary = emu.stop();
  const std::vector<TruthSample> samples = read_truth(truth);
  if (keep != nullptr) {
    std::ofstream(std::string(keep) + "/truth.txt") << std::ifstream(truth).rdbuf();
    std::ofstream(std::string(keep) + "/firmware.txt") << fw_out;
  }
  ::unlink(truth.c_str());
  ASSERT_FALSE(samples.empty());

  // 4: the first actuating steps damp (CAN.md 4.2 step 5); zero torque never.
  char first_actuating = 'o';
  int zero_torque_steps = 0;
  for (const TruthSample& t : samples) {
    if (first_actuating == 'o') first_actuating = t.command;
    zero_torque_steps += t.command == 'z' ? 1 : 0;
  }
  EXPECT_EQ(first_actuating, 'd');
  EXPECT_EQ(zero_torque_steps, 0);

  // 1: the push, rendered. Displacements from the pose just before it; the template driven by
  // the force on the hand (what the tared F/T measures), integrated here from rest.
  springbok::test::PushScore score(springbok::test::template_axis_x(config.wbc.template_params), kPushStart_s,
                                   kPushEnd_s, 0.5);
  double base0 = 0.0, hand0 = 0.0;
  int n0 = 0;
  for (const TruthSample& t : samples) {
    if (t.t_s >= kPushStart_s - 0.1 && t.t_s < kPushStart_s) {
      base0 += t.trunk_x_m;
      hand0 += t.hand_m.x();
      ++n0;
    }
  }
  ASSERT_GT(n0, 50);
  base0 /= n0;
  hand0 /= n0;
  for (const TruthSample& t : samples) score.add(t.t_s, t.hand_force_n.x(), t.trunk_x_m - base0, t.hand_m.x() - hand0);
  ASSERT_GT(score.samples(), 3000);
  ASSERT_GT(score.end_samples(), 400);
  const double nrmse_b = score.nrmse_base(), nrmse_e = score.nrmse_hand();
  const double end_b = score.end_base_m(), end_e = score.end_hand_m();
  const double fk_b = score.static_base_m(kForce_n), fk_e = score.static_hand_m(kForce_n);

  // 2: the trot, from the emulator's ground truth.
  std::array<bool, kFeet> lifted{};
  int non_foot = 0;
  double z_min = 1e9, tilt_max = 0.0;
  for (const TruthSample& t : samples) {
    if (t.t_s < t_trot_s || t.t_s > kTrotUntil_s) continue;
    for (int f = 0; f < kFeet; ++f) lifted[f] = lifted[f] || (t.foot_contacts & (1 << f)) == 0;
    non_foot += t.non_foot_contact;
    z_min = std::min(z_min, t.trunk_z_m);
    tilt_max = std::max(tilt_max, t.tilt_rad);
  }
  // 3: the streak of corrupt quaternions: damping within stale_ticks + kDampingSlackTicks steps of its first sample.
  const unsigned long long damped_at = first_damping_step(samples, kStreakAt);

  std::printf("HIL wbc (time scale %d, wall %.0f s): control from %.3f s; 30 N push %.1f..%.1f s: NRMSE base %.2f %% "
              "hand %.2f %%, end displacement base %.4f m (F/K %.4f) hand %.4f m (%.4f); trot %.2f..%.2f s: lifted "
              "%d%d%d%d, min trunk z %.3f m, max tilt %.3f rad; corrupt-quaternion streak from step %llu: damping at "
              "step %llu (stale_ticks %u)\n",
              time_scale, wall_s, t_control_s, kPushStart_s, kPushEnd_s, 100 * nrmse_b, 100 * nrmse_e, end_b, fk_b,
              end_e, fk_e, t_trot_s, kTrotUntil_s, lifted[0], lifted[1], lifted[2], lifted[3], z_min, tilt_max,
              kStreakAt, damped_at, stale_ticks);
  RecordProperty("nrmse_base_pct", std::to_string(100 * nrmse_b));
  RecordProperty("nrmse_ee_pct", std::to_string(100 * nrmse_e));
  // The bounds: NRMSE hand <= 5 %, base <= 10 %, steady state within 2 % of F/K.
  // (Before the estimator's position-aided tilt the base ended 29.3-30.1 mm, F/K 30: the
  // trunk's pitch, in the IMU's q_w that CAN does not carry, drifted 0.3-0.5 mrad unseen.)
  EXPECT_LE(nrmse_b, 0.10);
  EXPECT_LE(nrmse_e, 0.05);
  EXPECT_NEAR(end_b, fk_b, 0.02 * fk_b);
  EXPECT_NEAR(end_e, fk_e, 0.02 * fk_e);
  for (int f = 0; f < kFeet; ++f) EXPECT_TRUE(lifted[f]) << "foot " << f;
  EXPECT_EQ(non_foot, 0) << "only the feet touch the ground";
  EXPECT_GT(z_min, 0.45);
  EXPECT_LT(tilt_max, 0.3);
  ASSERT_GT(damped_at, 0u) << fw_out;
  EXPECT_LE(damped_at, kStreakAt + stale_ticks + kDampingSlackTicks);
  EXPECT_GE(damped_at, kStreakAt + stale_ticks - 1) << "damped before the IMU was lost";
  // Logged with the sensor's name; the burst at 2.5 s counted, never a fault before the streak:
  // the first fault is the IMU's. (The damped robot then collapses; the emulator caps the
  // light wrist joints' damping at what a 1 ms step can render, so a wrist may outrun its
  // velocity limit and its drive be faulted for implausible positions afterwards.)
  const auto first_fault = fw_out.find("fault_latched");
  ASSERT_NE(first_fault, std::string::npos) << fw_out;
  EXPECT_EQ(fw_out.find("(new=imu_lost latched=imu_lost)"), fw_out.find('(', first_fault)) << fw_out;
  EXPECT_NE(fw_out.find("(control -> damping)"), std::string::npos) << fw_out;
  const auto at = fw_out.find("can sensor imu: ");
  ASSERT_NE(at, std::string::npos) << fw_out;
  unsigned long long bad_quaternion = 0;
  ASSERT_EQ(std::sscanf(fw_out.c_str() + fw_out.find("bad_quaternion=", at), "bad_quaternion=%llu", &bad_quaternion), 1);
  EXPECT_GE(bad_quaternion, 3u + stale_ticks);
  EXPECT_NE(summary.find("forced_steps 0\n"), std::string::npos) << summary;
}

// Case 3: a sensor the controller needs, lost in the control mode: damping within
// stale_ticks + kDampingSlackTicks steps, latched, logged with its name.
// `detect_ticks`: how many samples the fault takes to be one (0: the sensors' stale_ticks).
void expect_sensor_loss_damps(const std::string& fault_yaml, unsigned long long fault_at, const std::string& fault_name,
                              std::uint32_t detect_ticks = 0) {
  const int time_scale = hil_time_scale(20);
  ASSERT_GE(time_scale, 1);
  const double wall_per_sim_s = time_scale * 1.3 + 5.0;
  const std::uint32_t stale_ticks = detect_ticks > 0 ? detect_ticks : wbc_hil_stale_ticks();
  const std::string truth = "/tmp/springbok_hil_wbc_truth_" + std::to_string(::getpid()) + ".txt";
  Emulator emu(kWbcConfig, fault_yaml, {"--motion", "bullet", "--truth-log", truth, "--truth-every", "1", "--settle-s", "0.1"});
  ASSERT_TRUE(emu.ready());
  ::unlink(kWbcSocket.c_str());
  Firmware fw(kWbcConfig, time_scale);
  std::string why;
  const double t_control_s = enter_control(fw, truth, wall_per_sim_s, why);
  ASSERT_GE(t_control_s, 0.0) << why << "\n" << fw.stop();
  ASSERT_LT(t_control_s, fault_at / 1000.0 - 0.2) << "the control mode must be on before the fault";
  ASSERT_TRUE(wait_for(fw, (fault_at / 1000.0 - t_control_s + 0.5) * wall_per_sim_s,
                       [&] { return truth_time(truth) >= fault_at / 1000.0 + 0.2; }));
  const std::string status = operator_line(kWbcSocket, "status");
  const std::string reset = operator_line(kWbcSocket, "mode control");
  const std::string fw_out = fw.stop();
  emu.stop();
  const std::vector<TruthSample> samples = read_truth(truth);
  ::unlink(truth.c_str());
  // The idle ticks damp too: the first damping step after the control mode's torques.
  unsigned long long control_steps = 0, after_control = 0;
  for (const TruthSample& t : samples) {
    control_steps += t.command == 't' ? 1 : 0;
    if (t.command == 't') after_control = 0;
    if (damps(t.command) && after_control == 0 && control_steps > 0) after_control = t.step;
  }
  std::printf("HIL wbc: %s from step %llu: damping at step %llu (detected after %u samples); %llu torque-controlled steps before\n",
              fault_name.c_str(), fault_at, after_control, stale_ticks, control_steps);
  EXPECT_GT(control_steps, 200u) << "the whole-body controller ran before the fault";
  EXPECT_EQ(samples.front().command, 'd') << "the first actuating step damps (CAN.md 4.2 step 5)";
  EXPECT_LE(after_control, fault_at + stale_ticks + kDampingSlackTicks);
  EXPECT_GE(after_control, fault_at + stale_ticks - 1) << "damped before the sensor was lost";
  EXPECT_NE(status.find("mode=damping faults="), std::string::npos) << status;
  EXPECT_NE(status.find(fault_name), std::string::npos) << status;
  EXPECT_EQ(reset.rfind("error: mode control", 0), 0u) << "latched: " << reset;
  EXPECT_NE(fw_out.find("(new=" + fault_name + " latched=" + fault_name + ")"), std::string::npos) << fw_out;
  EXPECT_NE(fw_out.find("(control -> damping)"), std::string::npos) << fw_out;
}

// Case 3's corrupt quaternions and case 4: the first actuating steps damp (CAN.md 4.2 step 5),
// zero torque never; in the control mode a burst of corrupt IMU quaternions is counted and
// rejected without a fault; a streak of them loses the IMU: damping within stale_ticks + kDampingSlackTicks
// steps, latched, logged with the sensor's name.
TEST(Hil, DeployedWholeBodyControllerStartsDampedAndRejectsCorruptQuaternions) {
  REQUIRE_VCAN(8);
  const int time_scale = hil_time_scale(20);
  ASSERT_GE(time_scale, 1);
  const double wall_per_sim_s = time_scale * 1.3 + 5.0;
  const std::uint32_t stale_ticks = wbc_hil_stale_ticks();
  constexpr unsigned long long kBurstAt = 4500, kBurst = 3, kStreakAt = 5000;
  const std::string truth = "/tmp/springbok_hil_wbc_truth_" + std::to_string(::getpid()) + ".txt";
  Emulator emu(kWbcConfig,
               "faults:\n"
               "  - {kind: corrupt_quaternion, sensor: imu, at: 4500, count: 3}\n"
               "  - {kind: corrupt_quaternion, sensor: imu, at: 5000, count: 1000000}\n",
               {"--motion", "bullet", "--truth-log", truth, "--truth-every", "1", "--settle-s", "0.1"});
  ASSERT_TRUE(emu.ready());
  ::unlink(kWbcSocket.c_str());
  Firmware fw(kWbcConfig, time_scale);
  std::string why;
  const double t_control_s = enter_control(fw, truth, wall_per_sim_s, why);
  ASSERT_GE(t_control_s, 0.0) << why << "\n" << fw.stop();
  ASSERT_LT(t_control_s, kBurstAt / 1000.0 - 0.2) << "the control mode must be on before the burst";
  ASSERT_TRUE(wait_for(fw, (kStreakAt / 1000.0 - t_control_s + 0.5) * wall_per_sim_s,
                       [&] { return truth_time(truth) >= kStreakAt / 1000.0 - 0.1; }));
  const std::string after_burst = operator_line(kWbcSocket, "status");
  ASSERT_TRUE(wait_for(fw, 1.0 * wall_per_sim_s, [&] { return truth_time(truth) >= kStreakAt / 1000.0 + 0.2; }));
  const std::string after_streak = operator_line(kWbcSocket, "status");
  const std::string fw_out = fw.stop();
  const std::string summary = emu.stop();
  const std::vector<TruthSample> samples = read_truth(truth);
  ::unlink(truth.c_str());
  ASSERT_FALSE(samples.empty());

  char first_actuating = 'o';
  int zero_torque_steps = 0;
  unsigned long long torque_steps = 0, damped_at = 0;
  for (const TruthSample& t : samples) {
    if (first_actuating == 'o') first_actuating = t.command;
    zero_torque_steps += t.command == 'z' ? 1 : 0;
    torque_steps += t.command == 't' ? 1 : 0;
    if (damped_at == 0 && torque_steps > 0 && damps(t.command)) damped_at = t.step;
  }
  std::printf("HIL wbc: first actuating command '%c', zero-torque steps %d; %llu torque-controlled steps; corrupt "
              "quaternions: burst of %llu at step %llu, streak from step %llu: damping at step %llu (stale_ticks %u)\n",
              first_actuating, zero_torque_steps, torque_steps, kBurst, kBurstAt, kStreakAt, damped_at, stale_ticks);
  EXPECT_EQ(first_actuating, 'd');
  EXPECT_EQ(zero_torque_steps, 0);
  EXPECT_GT(torque_steps, 300u) << "the whole-body controller ran";
  EXPECT_NE(after_burst.find("mode=control faults=none"), std::string::npos) << after_burst;
  EXPECT_NE(after_streak.find("mode=damping faults="), std::string::npos) << after_streak;
  EXPECT_NE(after_streak.find("imu_lost"), std::string::npos) << after_streak;
  EXPECT_LE(damped_at, kStreakAt + stale_ticks + kDampingSlackTicks);
  EXPECT_GE(damped_at, kStreakAt + stale_ticks - 1) << "damped before the IMU was lost";
  EXPECT_NE(fw_out.find("(new=imu_lost latched=imu_lost)"), std::string::npos) << fw_out;
  EXPECT_NE(fw_out.find("(control -> damping)"), std::string::npos) << fw_out;
  // The first fault is the IMU's (a collapsing arm may trip the drives' checks after it).
  EXPECT_EQ(fw_out.find("fault_latched"), fw_out.find("fault_latched a=256 b=256")) << fw_out;
  const auto at = fw_out.find("can sensor imu: ");
  ASSERT_NE(at, std::string::npos) << fw_out;
  unsigned long long bad_quaternion = 0;
  ASSERT_EQ(std::sscanf(fw_out.c_str() + fw_out.find("bad_quaternion=", at), "bad_quaternion=%llu", &bad_quaternion), 1);
  EXPECT_GE(bad_quaternion, kBurst + stale_ticks) << "the burst's and the streak's samples counted";
  EXPECT_NE(summary.find("forced_steps 0\n"), std::string::npos) << summary;
}

TEST(Hil, DeployedWholeBodyControllerDampsWhenTheImuFallsSilent) {
  REQUIRE_VCAN(8);
  expect_sensor_loss_damps("faults: [{kind: silent, sensor: imu, at: 4600}]\n", 4600, "imu_lost");
}

TEST(Hil, DeployedWholeBodyControllerDampsWhenTheWristFtReportsInvalid) {
  REQUIRE_VCAN(8);
  expect_sensor_loss_damps("faults: [{kind: status_invalid, sensor: wrist_ft, at: 4600, count: 1000000}]\n", 4600,
                           "wrist_ft_lost");
}

// CAN.md 6.4: clipping samples are used and counted, "a streak is a fault": the wrist F/T
// at full scale (F_x 512 N) from step 4600; its clip_streak (2 in this config: 512 N on the
// hand for 10 ms throws the arm into a drive fault) samples in a row latch the fault.
TEST(Hil, DeployedWholeBodyControllerDampsOnAWristFtClippingStreak) {
  REQUIRE_VCAN(8);
  expect_sensor_loss_damps("faults: [{kind: saturate, sensor: wrist_ft, at: 4600, count: 1000000}]\n", 4600,
                           "wrist_ft_clipping_streak", 2);
}

TEST(Hil, RoundTripTime) {
  REQUIRE_VCAN(7);
  const CanConfig cfg = load("mit_classic7.yaml");
  Emulator emu(kConfigDir + "mit_classic7.yaml", "");
  ASSERT_TRUE(emu.ready());
  SocketCanBus bus;
  const std::uint32_t reply_id = cfg.buses[0].drives[0].mit_reply_id;
  ASSERT_EQ(bus.open("vcan0", false, std::span<const std::uint32_t>(&reply_id, 1), false), "");
  Frame cmd, rx;
  mit::encode_special(1, mit::Special::exit_motor_mode, cmd);
  std::vector<double> rtt_us;
  const int fd = bus.native_handle();
  for (int i = 0; i < 2000; ++i) {
    const std::int64_t t0 = monotonic_ns();
    ASSERT_EQ(bus.send(cmd), TxStatus::ok);
    bool got = false;
    while (!got && monotonic_ns() - t0 < 2000000000LL) {
      wait_readable(std::span<const int>(&fd, 1), 10000);
      got = bus.receive(rx) == RxStatus::frame;
    }
    ASSERT_TRUE(got) << "no reply to round trip " << i;
    rtt_us.push_back(1e-3 * static_cast<double>(monotonic_ns() - t0));
  }
  std::sort(rtt_us.begin(), rtt_us.end());
  const auto pct = [&](double p) { return rtt_us[static_cast<std::size_t>(p * (rtt_us.size() - 1))]; };
  std::printf("round trip host -> drive_emulator -> host, %zu frames, us: min %.0f p50 %.0f p90 %.0f p99 %.0f max %.0f\n",
              rtt_us.size(), rtt_us.front(), pct(0.5), pct(0.9), pct(0.99), rtt_us.back());
  RecordProperty("rtt_p50_us", static_cast<int>(pct(0.5)));
  RecordProperty("rtt_p99_us", static_cast<int>(pct(0.99)));
}

}  // namespace
}  // namespace springbok::can
