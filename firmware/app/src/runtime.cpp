#include "springbok/app/runtime.hpp"

#include <CLI/CLI.hpp>
#include <signal.h>

#include <atomic>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <memory>

#include "springbok/app/firmware.hpp"
#include "springbok/app/operator_server.hpp"
#include "springbok/yaml/reader.hpp"
#include "springbok/app/slowed_clock.hpp"
#include "springbok/app/version.hpp"
#include "springbok/rt/clock.hpp"
#include "springbok/isa/isa.hpp"
#include "springbok/rt/executive.hpp"
#include "springbok/rt/log.hpp"
#include "springbok/rt/realtime.hpp"

namespace springbok::app {

CommandLine parse_command_line(int argc, char** argv, const char* program) {
  CommandLine cli;
  CLI::App app{std::string(program) + ": the springbok whole-body controller firmware"};
  app.set_version_flag("--version",
                       std::string(program) + " " + version() + " (revision " + revision() + ")\n" + isa::describe(),
                       "print the version, the source revision and the kernels' instruction-set level, then exit");
  app.add_option("--config", cli.config_path, "robot configuration (YAML)")->required()->check(CLI::ExistingFile);
  app.add_flag("--check-config", cli.check_config, "validate the configuration and exit");
  app.add_flag("--require-rt", cli.run.require_rt,
               "refuse to start without SCHED_FIFO, mlockall and a PREEMPT_RT kernel");
  app.add_option("--duration", cli.run.duration_s, "stop after this many seconds (0: run until SIGTERM)")
      ->check(CLI::Range(0.0, 1e7));
  app.add_option("--time-scale", cli.run.time_scale,
                 "run the firmware clock this many times slower than wall time (integer; 1 = real time). "
                 "Hardware-in-the-loop against a simulated robot on a slow host only, never on a robot")
      ->check(CLI::Range(1, static_cast<int>(kMaxTimeScale)));
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    cli.exit_now = true;
    cli.exit_code = app.exit(e);
  }
  return cli;
}

namespace {

using FirmwareExecutive = rt::Executive<SlowedClock, Firmware::Loop>;

void print_histogram(const char* name, const rt::DurationHistogram& h) {
  std::printf("%s [us]: n=%llu p50=%.0f p99=%.0f p99.9=%.0f max=%.1f\n", name,
              static_cast<unsigned long long>(h.count()), h.quantile_ns(0.5) / 1e3, h.quantile_ns(0.99) / 1e3,
              h.quantile_ns(0.999) / 1e3, static_cast<double>(h.max_ns()) / 1e3);
}

}  // namespace

int run_firmware(hal::Hardware& hardware, const AppConfig& config, const RunOptions& options) {
  rt::RtConfig rt_config = config.rt;
  rt_config.require = rt_config.require || options.require_rt;
  rt::RtReport report;
  const rt::RtProcess process(rt_config, report);
  if (!report.refusal.empty()) {
    rt::print_report(report, stderr);
    return 2;
  }

  // SIGINT/SIGTERM are taken by sigtimedwait in this thread only.
  sigset_t stop_signals;
  sigemptyset(&stop_signals);
  sigaddset(&stop_signals, SIGINT);
  sigaddset(&stop_signals, SIGTERM);
  pthread_sigmask(SIG_BLOCK, &stop_signals, nullptr);

  std::FILE* log_file = config.log_path == "-" ? stderr : std::fopen(config.log_path.c_str(), "a");
  if (log_file == nullptr) {
    std::fprintf(stderr, "log.path: cannot open %s\n", config.log_path.c_str());
    return 1;
  }
  const auto log_ring = std::make_unique<rt::LogRing>();
  rt::LogDrainer drainer(*log_ring, log_file, 10, describe_log_record);

  const auto lifecycle_step = [&hardware](hal::LifecycleResult (hal::Hardware::*step)()) {
    const hal::LifecycleResult r = (hardware.*step)();
    if (!r.ok) {
      std::fprintf(stderr, "hal %.*s: %s\n", static_cast<int>(hardware.name().size()), hardware.name().data(),
                   r.message.c_str());
      hardware.deactivate();
    }
    return r.ok;
  };
  if (!lifecycle_step(&hal::Hardware::configure)) return 1;

  Firmware firmware(hardware, config, log_ring.get());
  Firmware::Loop& loop = firmware.loop();
  SlowedClock clock(options.time_scale);
  const auto executive =
      std::make_unique<FirmwareExecutive>(clock, loop, rt::kNsPerS / config.rate_hz, log_ring.get());

  // Live telemetry (telemetry.hpp): the loop fills the ring, the sender's thread sends.
  const auto telemetry_ring = std::make_unique<TelemetryRing>();
  TelemetrySender telemetry;
  if (config.telemetry.enabled) {
    if (const std::string error = telemetry.open(config.telemetry); !error.empty()) {
      std::fprintf(stderr, "%s\n", error.c_str());
      hardware.deactivate();
      return 1;
    }
    loop.set_telemetry(telemetry_ring.get(), telemetry_every_ticks(config.telemetry, config.rate_hz));
    telemetry.start(*telemetry_ring);
  }

  // The flight recorder (flight_recorder.hpp): the loop records every tick, its thread writes.
  std::unique_ptr<FlightRecorder> recorder;
  if (config.recorder.enabled) {
    recorder = std::make_unique<FlightRecorder>(
        static_cast<std::size_t>(std::lround(config.recorder.seconds * config.rate_hz)), config.recorder.dir);
    loop.set_recorder(recorder.get());
    recorder->start();
  }

  OperatorServer server(firmware.mailbox(), firmware.status(), executive->published());
  server.set_recorder(recorder.get());
  if (const std::string error = server.open(config.operator_socket); !error.empty()) {
    std::fprintf(stderr, "%s\n", error.c_str());
    hardware.deactivate();
    return 1;
  }
  server.start();

  // The drives are enabled last, right before the loop starts: from then on they expect a
  // command (CiA 402: SYNC) every tick (CAN.md 4.3 step 3).
  if (!lifecycle_step(&hal::Hardware::activate)) {
    server.stop();
    return 1;
  }
  std::atomic<bool> stop{false};
  auto body = [&] {
    executive->start();
    executive->run_ticks(static_cast<std::uint64_t>(config.warmup_ticks));  // idle: the drives damp (D_start)
    executive->reset_stats();
    executive->run_until(stop);
  };
  rt::RtThread thread;
  const bool started = thread.start(rt_config, body, report);
  rt::print_report(report, stderr);
  if (!started) {
    server.stop();
    hardware.deactivate();
    return report.refusal.empty() ? 1 : 2;
  }
  std::fprintf(stderr, "springbok: control mode runs %s\n",
               config.control_mode == ControlModeKind::wbc ? "the whole-body controller (IMU + leg-kinematics estimate)"
                                                           : "the joint PD hold of gains.control");
  std::fprintf(stderr, "springbok %s (revision %s); %s\n", version(), revision(), isa::describe().c_str());
  std::fprintf(stderr, "springbok: running at %d Hz on %.*s; operator socket %s\n", config.rate_hz,
               static_cast<int>(hardware.name().size()), hardware.name().data(), config.operator_socket.c_str());
  if (clock.scale() > 1) {
    std::fprintf(stderr, "springbok: time scale %lld: the firmware clock runs %lld times slower than wall time\n",
                 static_cast<long long>(clock.scale()), static_cast<long long>(clock.scale()));
  }

  timespec wait{};
  wait.tv_nsec = 100'000'000;
  const std::int64_t end_ns = options.duration_s > 0.0
                                  ? clock.now_ns() + static_cast<std::int64_t>(options.duration_s * 1e9)
                                  : INT64_MAX;
  while (clock.now_ns() < end_ns) {
    const int sig = sigtimedwait(&stop_signals, nullptr, &wait);
    if (sig == SIGINT || sig == SIGTERM) {
      std::fprintf(stderr, "springbok: signal %d, stopping\n", sig);
      break;
    }
  }
  stop.store(true);
  thread.join();
  hardware.deactivate();
  server.stop();
  telemetry.stop();
  if (recorder) {  // the last seconds, at every stop
    recorder->stop();
    std::string error;
    const std::string path = recorder->write(DumpReason::stop, error);
    if (path.empty()) {
      std::fprintf(stderr, "springbok: %s\n", error.c_str());
    } else {
      std::fprintf(stderr, "springbok: flight recorder (stop): %s (%.2f s to write)\n", path.c_str(),
                   recorder->last_write_s());
    }
  }
  drainer.stop();
  if (log_file != stderr) std::fclose(log_file);

  const rt::ExecutiveStats& s = executive->stats();
  std::printf("ticks=%llu overruns=%llu skipped=%llu max_overrun_streak=%u mode=%s faults=%s\n",
              static_cast<unsigned long long>(s.ticks), static_cast<unsigned long long>(s.overruns),
              static_cast<unsigned long long>(s.skipped_ticks), s.max_overrun_streak,
              safety::to_string(firmware.supervisor().mode()), fault_list(firmware.supervisor().faults()).c_str());
  print_histogram("wake latency", s.wake_latency);
  print_histogram("compute", s.compute);
  std::printf("log records dropped=%llu\n", static_cast<unsigned long long>(log_ring->dropped()));
  if (config.telemetry.enabled) {
    std::printf("telemetry to %s:%d every %u ticks: datagrams sent=%llu dropped=%llu send_errors=%llu\n",
                config.telemetry.address.c_str(), config.telemetry.port,
                telemetry_every_ticks(config.telemetry, config.rate_hz), static_cast<unsigned long long>(telemetry.sent()),
                static_cast<unsigned long long>(telemetry_ring->dropped()),
                static_cast<unsigned long long>(telemetry.send_errors()));
  }
  std::printf("%s", hardware.diagnostics_report().c_str());
  return 0;
}

int firmware_main(int argc, char** argv, const char* program, const MakeHardware& make_hardware) {
  const CommandLine cli = parse_command_line(argc, argv, program);
  if (cli.exit_now) return cli.exit_code;
  if (!isa::environment_error().empty()) {
    std::fprintf(stderr, "%s: %s\n", program, isa::environment_error().c_str());
    return 1;
  }
  const yaml::Document doc = yaml::parse_file(cli.config_path);
  if (!doc.ok) {
    std::fprintf(stderr, "%s: config error: %s\n", program, doc.error.c_str());
    return 1;
  }
  yaml::Errors errors;
  const yaml::Field root(doc.root, "", errors);
  AppConfig app = read_config(root);
  std::unique_ptr<hal::Hardware> hardware = make_hardware(app, root);  // reads its section whatever came before
  for (const std::string& e : errors.lines()) {
    std::fprintf(stderr, "%s: config error: %s: %s\n", program, cli.config_path.c_str(), e.c_str());
  }
  if (!errors.empty() || !hardware) return 1;
  if (cli.check_config) {
    std::printf("%s: config OK: %s\n", program, cli.config_path.c_str());
    return 0;
  }
  return run_firmware(*hardware, app, cli.run);
}

}  // namespace springbok::app
