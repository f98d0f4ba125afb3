// The deployed program around one HAL backend: the RT recipe, the log
// drainer, the operator server, the executive on the monotonic clock in the
// RT thread, and an orderly stop (SIGINT/SIGTERM or a duration). Each
// executable (springbok: SocketCAN; springbok-on-sim: Bullet) is a small
// main() that builds its backend and calls run_firmware().
#pragma once

#include <cstdio>
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
// --require-rt, --duration, --time-scale. Returns the exit code. `make_hardware(config,
// config_path)` builds the backend without touching any device (nullptr after
// printing the error) and may fill the config's backend fields (wrist_tare_samples);
// --check-config therefore also checks the backend's part.
template <class MakeHardware>
int firmware_main(int argc, char** argv, const char* program, MakeHardware&& make_hardware);

struct CommandLine {
  std::string config_path;
  bool check_config = false;
  RunOptions run;
  bool exit_now = false;  // --help or a usage error
  int exit_code = 0;
};
CommandLine parse_command_line(int argc, char** argv, const char* program);

template <class MakeHardware>
int firmware_main(int argc, char** argv, const char* program, MakeHardware&& make_hardware) {
  const CommandLine cli = parse_command_line(argc, argv, program);
  if (cli.exit_now) return cli.exit_code;
  ConfigResult loaded = load_config_file(cli.config_path);
  if (!loaded.ok) {
    for (const auto& e : loaded.errors) std::fprintf(stderr, "%s: config error: %s\n", program, e.c_str());
    return 1;
  }
  auto hardware = make_hardware(loaded.config, cli.config_path);
  if (!hardware) return 1;
  if (cli.check_config) {
    std::printf("%s: config OK: %s\n", program, cli.config_path.c_str());
    return 0;
  }
  return run_firmware(*hardware, loaded.config, cli.run);
}

}  // namespace springbok::app
