// The deployed program around one HAL backend: the RT recipe, the log
// drainer, the operator server, the executive on the monotonic clock in the
// RT thread, and an orderly stop (SIGINT/SIGTERM or a duration). Each
// executable (springbok: SocketCAN; springbok-on-sim: Bullet) is a small
// main() that builds its backend and calls run_firmware().
#pragma once

#include <functional>
#include <memory>
#include <string>

#include "springbok/app/config.hpp"
#include "springbok/hal/hardware.hpp"

namespace springbok::app {

struct RunOptions {
  bool require_rt = false;   // --require-rt: refuse to start without every RT step
  double duration_s = 0.0;   // 0: until SIGINT/SIGTERM (firmware time)
  int time_scale = 1;        // --time-scale: firmware time runs this many times slower than wall time (HIL)
};

// The process exit code: 0 after an orderly stop, 1 on a start-up error,
// 2 when --require-rt refused.
int run_firmware(hal::Hardware& hardware, const AppConfig& config, const RunOptions& options);

// The command line shared by the executables: --config, --check-config,
// --require-rt, --duration, --time-scale. Returns the exit code. The config file is read
// once: the app's sections (read_config), then `make_hardware(config, root)` reads the
// backend's own section of the same document (e.g. `can:`, its problems added to root's
// errors, whatever the app's sections held) and, when there is no problem at all, builds
// the backend without touching any device; it may fill the config's backend fields
// (control.tare_samples). Every problem of the file is printed, naming the field and line;
// --check-config therefore also checks the backend's part.
using MakeHardware = std::function<std::unique_ptr<hal::Hardware>(AppConfig& config, const yaml::Field& root)>;
int firmware_main(int argc, char** argv, const char* program, const MakeHardware& make_hardware);

struct CommandLine {
  std::string config_path;
  bool check_config = false;
  RunOptions run;
  bool exit_now = false;  // --help or a usage error
  int exit_code = 0;
};
CommandLine parse_command_line(int argc, char** argv, const char* program);

}  // namespace springbok::app
