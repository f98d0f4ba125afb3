// The HIL suite's rig. The suite runs the SocketCAN backend (springbok::can::CanHardware) and
// the deployed binary against the drive emulator process on vcan0..6, and asserts behaviour and
// tick counts, never deadlines (under the VM's emulated CPU a round trip is ~0.1 ms typical, ms
// worst case). Here: vcan present, the emulator as a child process, the CAN configs of
// tests/hil/config, a bench of emulator and host, ticks at 1 ms, the emulator's summary per drive.
#pragma once

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

namespace springbok::can::hil {


inline const std::string kConfigDir = std::string(SPRINGBOK_SOURCE_DIR) + "/tests/hil/config/";
// The CiA 402 drives as on a robot whose drives were powered before the host started: their stored
// producer heartbeat time 100 ms, so the host hears they are up, resets them and sees them boot
// (CAN.md 4.3 step 1). Their power-on boot-up went out before the host listened.
inline const std::vector<std::string> kCia402DrivesUp{"--cia402-heartbeat-ms", "100"};

inline bool have_vcan(int buses) {
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

inline CanConfig load(const std::string& name) {
  const ConfigResult r = load_can_config_file(kConfigDir + name);
  EXPECT_TRUE(r.ok) << r.error;
  return r.config;
}

// A HIL bench: the emulator started on tests/hil/config/`config_name` (`faults_yaml` its fault
// script, `emulator_args` the drives' own settings where they differ from the config's), then
// the host on `host_config` (that file as loaded, or what the test made of it). A test checks
// ASSERT_TRUE(rig.emu.ready()) first.
struct HilRig {
  HilRig(const std::string& config_name, CanConfig host_config, const std::string& faults_yaml = "",
         const std::vector<std::string>& emulator_args = {})
      : emu(kConfigDir + config_name, faults_yaml, emulator_args), hw(std::move(host_config)) {}
  // The start-up: configure(), then activate() if that succeeded.
  hal::LifecycleResult start() {
    const hal::LifecycleResult c = hw.configure();
    return c.ok ? hw.activate() : c;
  }
  Emulator emu;
  CanHardware hw;
};

// Runs `ticks` ticks at a 1 ms period: read, observe, write (zero torque, light damping).
inline void run_ticks(CanHardware& hw, int ticks, const std::function<void(int, const hal::Measurements&, hal::IoStatus)>& observe) {
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

inline double stance(int j) {
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
inline std::map<int, EmulatedDrive> emulated_drives(const std::string& summary) {
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


}  // namespace springbok::can::hil
