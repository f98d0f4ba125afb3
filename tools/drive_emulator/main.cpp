// drive_emulator: answers on the configured CAN buses as the configured drives
// would (MIT mode or CiA 402, drive side, byte-exact), motion from a per-joint
// model or from sim_hal's Bullet robot (lockstep: one world step per host tick),
// faults injected from a script. Runs until SIGINT/SIGTERM or --duration-s.
//
//   drive_emulator --config can.yaml [--faults faults.yaml] [--pose stance|zero]
//                  [--mit-master-id ID] [--mit-reply-dlc 5|6|7|8] [--mit-bus-voltage-v V]
//                                                               (the MIT drives' flash settings, supply)
//                  [--cia402-heartbeat-ms MS] [--cia402-boot-after-ms MS]   (CiA 402: stored 0x1017, power-on)
//                  [--cia402-nmt-delay-ms MS] [--cia402-only-used-pdos] [--cia402-repeat-sdo-answers]
//                  [--cia402-sync-timeout-ms MS] [--cia402-answer-delay-ms MS[,MS...]]
//                  [--cia402-state-step-ms MS[,MS...]]   (one value for every bus, or one per bus)
//                  [--cia402-brake-ms MS]
//   drive_emulator --config can.yaml --motion bullet [--truth-log trunk.txt]
//   drive_emulator --config can.yaml --print-layout      (no CAN needed)
//
// With --motion bullet the sensors of `can.sensors` (CAN.md 6) publish one sample per
// world step on their buses: the IMU from the trunk's motion through trunk_imu (sim_hal's
// IMU model: --sensors-preset ideal|mems|tactical --sensors-seed N, or the legacy --imu-* noise
// and bias; --imu-gyro-bias-offset-rad-s X,Y,Z adds a known gyro turn-on bias), the wrist F/T from the wrench scripted on the hand (--hand-force-n N
// --hand-force-axis x|y|z|-x|-y|-z --hand-force-start-s T; with --sensors-preset mems or
// tactical through the realistic F/T model).
#include <signal.h>

#include <CLI/CLI.hpp>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <deque>
#include <fstream>
#include <memory>
#include <string>
#include <vector>

#include "springbok/can/bus_load.hpp"
#include "springbok/can/config_yaml.hpp"
#include "springbok/can/socketcan.hpp"
#include "springbok/drive_emulator/drives.hpp"
#include "springbok/drive_emulator/sensors.hpp"
#include "springbok/model/model.hpp"
#if SPRINGBOK_EMULATOR_HAS_BULLET
#include "springbok/drive_emulator/bullet_motion.hpp"
#endif

namespace {

std::atomic<bool> g_stop{false};
void on_signal(int) { g_stop = true; }

// Stance: the legs at the robot's nominal stance (its model's kStance_rad), the arm at zero.
double initial_position(int joint, const std::string& pose) {
  if (pose == "zero" || joint >= springbok::kFirstArmJoint) return 0.0;
  return springbok::robot::kStance_rad[static_cast<std::size_t>(joint)];
}

void print_layout(const springbok::can::CanConfig& c) {
  using namespace springbok::can;
  std::printf("%-6s %-8s %-3s %-7s %6s %8s %9s %7s\n", "bus", "iface", "fd", "proto", "joints", "frames", "bus_us", "load");
  for (const BusConfig& b : c.buses) {
    const BusLoad l = worst_case_load(b, c.timing.tick_us, c.sensors);
    std::string proto = b.drives.empty() ? "-" : to_string(b.drives.front().protocol);
    for (const DriveConfig& d : b.drives) {
      if (d.protocol != b.drives.front().protocol) proto = "mixed";
    }
    const bool imu = c.sensors.imu.enabled && c.sensors.imu.bus == b.name;
    const bool ft = c.sensors.wrist_ft.enabled && c.sensors.wrist_ft.bus == b.name;
    if (imu || ft) {
      const std::string which = imu && ft ? "imu+ft" : (imu ? "imu" : "ft");
      proto = b.drives.empty() ? which : proto + "+" + which;
    }
    std::printf("%-6s %-8s %-3s %-7s %6zu %8d %9.1f %6.1f%%\n", b.name.c_str(), b.interface.c_str(), b.fd ? "yes" : "no",
                proto.c_str(), b.drives.size(), l.frames_per_tick, l.bus_time_us, 100.0 * l.load);
  }
  const std::string err = check_bus_loads(c);
  std::printf("%s\n", err.empty() ? "layout ok: every bus at or below the load limit" : ("layout refused: " + err).c_str());
}

}  // namespace

int main(int argc, char** argv) {
  using namespace springbok;
  CLI::App app{"CAN drive emulator (MIT mode / CiA 402) for HIL over vcan"};
  std::string config_path, faults_path, pose = "stance", ready_file, motion = "joint", truth_log;
  int truth_every = 10;
  double settle_s = 0.0;
  double duration_s = 0.0;
  std::uint32_t can_timeout_ms = 0;
  bool layout_only = false;
  double hand_force_n = 0.0, hand_force_start_s = 0.0, hand_force_duration_s = 0.0;
  std::string hand_force_axis = "x";
  double imu_gyro_noise = 0.0, imu_accel_noise = 0.0, imu_gyro_bias = 0.0, imu_accel_bias = 0.0;
  std::uint64_t imu_seed = 1;
  std::string sensors_preset = "ideal";
  std::uint64_t sensors_seed = 1;
  std::vector<double> gyro_bias_offset_rad_s;
  int mit_master_id = -1;  // -1: as the config says
  emu::MitReplyOptions mit_reply;
  emu::Cia402Options cia402;
  std::uint32_t cia402_boot_after_ms = 0;
  std::vector<std::uint32_t> cia402_answer_delay_ms, cia402_state_step_ms;  // per bus, or one for all
  // CLI11's Range lets a NaN through (every comparison with it is false): each real number is
  // checked finite first.
  const CLI::Validator finite(
      [](std::string& text) {
        return std::isfinite(std::strtod(text.c_str(), nullptr)) ? std::string() : "not a finite number: " + text;
      },
      "FINITE");
  app.add_option("--config", config_path, "YAML file with the `can:` section (the same the firmware reads)")->required();
  app.add_option("--faults", faults_path, "YAML fault script (`faults:` list)");
  app.add_option("--pose", pose, "initial joint positions")->check(CLI::IsMember({"stance", "zero"}));
  app.add_option("--duration-s", duration_s, "stop after this many seconds (0 = until SIGTERM)")
      ->check(finite)
      ->check(CLI::NonNegativeNumber);
  app.add_option("--can-timeout-ms", can_timeout_ms, "MIT CAN_TIMEOUT: zero the stored command after this silence (0 = off)");
  app.add_option("--ready-file", ready_file, "written once the buses are open and the drives booted");
  // The MIT drives' own flash settings, where they differ from what the host's config says
  // of them (CAN.md 1.4: CAN_MASTER, factory default 0; CubeMars' 8-byte replies).
  app.add_option("--mit-master-id", mit_master_id, "MIT: every drive replies on this CAN id (CAN_MASTER), 0..0x7FF")
      ->check(CLI::Range(0, 0x7FF));
  app.add_option("--mit-reply-dlc", mit_reply.dlc,
                 "MIT: every drive replies with this many bytes: 6 (bgkatz before July 2023), 7 (since: + bus "
                 "voltage), 8 (CubeMars); 5: malformed, a length CAN.md 1.4 does not allow")
      ->check(CLI::IsMember({5, 6, 7, 8}));
  app.add_option("--mit-bus-voltage-v", mit_reply.bus_voltage_v,
                 "MIT: the drives' bus voltage, sent in byte 6 of 7-byte replies, V")
      ->check(finite)
      ->check(CLI::Range(0.0, 40.0));
  // The CiA 402 drives' stored 0x1017 and when they are powered on (CAN.md 4.3 step 1: the host
  // waits for each node's boot-up, and resets a node it hears heartbeats from).
  app.add_option("--cia402-heartbeat-ms", cia402.stored_heartbeat_ms,
                 "CiA 402: every drive's stored producer heartbeat time (0x1017 after power-on and NMT reset "
                 "communication), ms; 0: no heartbeat until the host writes 0x1017")
      ->check(CLI::Range(0, 65535));
  app.add_option("--cia402-boot-after-ms", cia402_boot_after_ms,
                 "CiA 402: the drives power on (boot-up frame) this long after the ready file is written; 0: before "
                 "it (a host started later misses their boot-up)")
      ->check(CLI::Range(0, 600000));
  // What else CAN.md allows a CiA 402 drive (emu::Cia402Options).
  app.add_option("--cia402-nmt-delay-ms", cia402.nmt_delay_ms,
                 "CiA 402: NMT commands take effect this long after they arrive (the drive's own cycle), ms")
      ->check(CLI::Range(0, 1000));
  app.add_flag("--cia402-only-used-pdos", cia402.only_used_pdos,
               "CiA 402: the drives have RPDO1, TPDO1 and TPDO2 only (the others: object does not exist)");
  app.add_flag("--cia402-repeat-sdo-answers", cia402.repeat_sdo_answers, "CiA 402: every SDO answer is sent twice");
  app.add_option("--cia402-sync-timeout-ms", cia402.sync_timeout_ms,
                 "CiA 402: a drive Operation enabled (0x6007 = 3) quick-stops when no SYNC came for this long, ms "
                 "(lost communication); 0: never")
      ->check(CLI::Range(0, 60000));
  app.add_option("--cia402-answer-delay-ms", cia402_answer_delay_ms,
                 "CiA 402: until Operation enabled, a drive sends the TPDOs of a SYNC and its SDO answers this "
                 "long after the frame asking for them, ms; one value for every bus or one per bus (comma-separated)")
      ->delimiter(',')
      ->check(CLI::Range(0, 1000));
  app.add_option("--cia402-state-step-ms", cia402_state_step_ms,
                 "CiA 402: a state machine transition takes effect this long after the SYNC that applied its "
                 "controlword, ms; one value for every bus or one per bus (comma-separated)")
      ->delimiter(',')
      ->check(CLI::Range(0, 1000));
  app.add_option("--cia402-brake-ms", cia402.brake_ms,
                 "CiA 402: every drive has a holding brake that takes this long to release (the step into "
                 "Operation enabled) and to engage (the step out of it), ms; 0: none")
      ->check(CLI::Range(0, 1000));
  app.add_option("--motion", motion,
                 "joint: a 1-DoF model per drive; bullet: the joints of the simulated robot (sim_hal), "
                 "stepped once per host tick, the robot spawned crouched on its feet")
      ->check(CLI::IsMember({"joint", "bullet"}));
  app.add_option("--truth-log", truth_log,
                 "bullet: trace of the ground truth, one line per --truth-every steps (columns: bullet_motion.hpp)");
  app.add_option("--truth-every", truth_every, "bullet: one trace line every this many steps")->check(CLI::Range(1, 1000000));
  app.add_option("--settle-s", settle_s, "bullet: the robot lies unpowered this long before the drives boot")
      ->check(finite)
      ->check(CLI::Range(0.0, 60.0));
  app.add_flag("--print-layout", layout_only, "print frames per tick and worst-case load per bus, then exit");
  app.add_option("--hand-force-n", hand_force_n, "bullet: a step force on the hand (EE frame origin), N (0 = none)")
      ->check(finite);
  app.add_option("--hand-force-axis", hand_force_axis, "bullet: its direction, world axes")
      ->check(CLI::IsMember({"x", "y", "z", "-x", "-y", "-z"}));
  app.add_option("--hand-force-start-s", hand_force_start_s, "bullet: when it starts, s after the settling")
      ->check(finite)
      ->check(CLI::NonNegativeNumber);
  app.add_option("--hand-force-duration-s", hand_force_duration_s, "bullet: how long it lasts (0 = until the end)")
      ->check(finite)
      ->check(CLI::NonNegativeNumber);
  CLI::Option* preset_opt =
      app.add_option("--sensors-preset", sensors_preset,
                     "bullet: sim_hal's sensor model for the IMU and the wrist F/T published: ideal (exact), mems "
                     "(BMI088 class, Mini45-class F/T), tactical (KVH 1775 class, Mini45-class F/T); "
                     "tools/scenarios/README.md, Sensor models")
          ->check(CLI::IsMember({"ideal", "mems", "tactical"}));
  CLI::Option* seed_opt = app.add_option("--sensors-seed", sensors_seed, "bullet: seed of the sensor model (>= 0)")
                              ->check(CLI::NonNegativeNumber);
  CLI::Option* offset_opt =
      app.add_option("--imu-gyro-bias-offset-rad-s", gyro_bias_offset_rad_s,
                     "bullet: a known gyro turn-on bias X,Y,Z (IMU axes, rad/s) added to the sensor model's draw")
          ->delimiter(',')
          ->expected(3)
          ->check(finite)
          ->check(CLI::Range(-10.0, 10.0));
  // The legacy IMU options: sim_hal's model as a white noise std per sample and a turn-on std
  // (mapped onto the sensor model as sim.imu is); not together with --sensors-*.
  CLI::Option* legacy[] = {
      app.add_option("--imu-gyro-noise-rad-s", imu_gyro_noise, "bullet: IMU gyro white noise std per sample (legacy)")
          ->check(finite)
          ->check(CLI::Range(0.0, 10.0)),
      app.add_option("--imu-accel-noise-m-s2", imu_accel_noise, "bullet: IMU accelerometer white noise std (legacy)")
          ->check(finite)
          ->check(CLI::Range(0.0, 100.0)),
      app.add_option("--imu-gyro-bias-rad-s", imu_gyro_bias, "bullet: std of the IMU gyro bias drawn once (legacy)")
          ->check(finite)
          ->check(CLI::Range(0.0, 10.0)),
      app.add_option("--imu-accel-bias-m-s2", imu_accel_bias, "bullet: std of the accelerometer bias drawn once (legacy)")
          ->check(finite)
          ->check(CLI::Range(0.0, 100.0)),
      app.add_option("--imu-seed", imu_seed, "bullet: seed of the IMU noise (legacy)")};
  for (CLI::Option* o : legacy) {
    preset_opt->excludes(o);
    seed_opt->excludes(o);
    offset_opt->excludes(o);
  }
  CLI11_PARSE(app, argc, argv);

  const can::ConfigResult cfg = can::load_can_config_file(config_path);
  if (!cfg.ok) {
    std::fprintf(stderr, "drive_emulator: %s\n", cfg.error.c_str());
    return 2;
  }
  // A per-bus option: one value for every bus, or one per bus.
  const std::size_t n_buses = cfg.config.buses.size();
  for (const auto& [name, values] : {std::pair{"--cia402-answer-delay-ms", &cia402_answer_delay_ms},
                                     std::pair{"--cia402-state-step-ms", &cia402_state_step_ms}}) {
    if (values->size() > 1 && values->size() != n_buses) {
      std::fprintf(stderr, "drive_emulator: %s: %zu values for %zu buses (give one, or one per bus)\n", name,
                   values->size(), n_buses);
      return 2;
    }
  }
  const auto per_bus = [](const std::vector<std::uint32_t>& values, std::size_t b) -> std::uint32_t {
    return values.empty() ? 0 : values[values.size() == 1 ? 0 : b];
  };
  if (layout_only) {
    print_layout(cfg.config);
    return can::check_bus_loads(cfg.config).empty() ? 0 : 1;
  }
  std::vector<emu::Fault> faults;
  if (!faults_path.empty()) {
    const emu::FaultResult fr = emu::load_faults_file(faults_path);
    if (!fr.ok) {
      std::fprintf(stderr, "drive_emulator: %s\n", fr.error.c_str());
      return 2;
    }
    faults = fr.faults;
  }

  // Every fault names a configured drive or sensor (checked before any socket opens).
  for (const emu::Fault& f : faults) {
    if (f.sensor != emu::SensorId::none) {
      const bool configured = f.sensor == emu::SensorId::imu ? cfg.config.sensors.imu.enabled
                                                             : cfg.config.sensors.wrist_ft.enabled;
      if (!configured) {
        std::fprintf(stderr, "drive_emulator: fault '%s' names sensor %s, which is not configured (can.sensors)\n",
                     emu::to_string(f.kind), emu::to_string(f.sensor));
        return 2;
      }
      continue;
    }
    const can::DriveConfig* drive = nullptr;
    for (const can::BusConfig& bc : cfg.config.buses) {
      for (const can::DriveConfig& d : bc.drives) {
        if (d.drive_id == f.drive_id) drive = &d;
      }
    }
    if (drive == nullptr) {
      std::fprintf(stderr, "drive_emulator: fault '%s' names drive %d, which is not configured\n", emu::to_string(f.kind),
                   f.drive_id);
      return 2;
    }
    const bool mit_only = f.kind == emu::FaultKind::vendor_error;
    if (((emu::is_property(f.kind) && !mit_only) || f.at_sdo != 0) && drive->protocol != can::Protocol::cia402) {
      std::fprintf(stderr, "drive_emulator: fault '%s'%s names drive %d, which is an MIT drive (CiA 402 only)\n",
                   emu::to_string(f.kind), f.at_sdo != 0 ? " with at_sdo" : "", f.drive_id);
      return 2;
    }
    if (mit_only && drive->protocol != can::Protocol::mit) {
      std::fprintf(stderr, "drive_emulator: fault '%s' names drive %d, which is a CiA 402 drive (MIT only)\n",
                   emu::to_string(f.kind), f.drive_id);
      return 2;
    }
    if (mit_only && !(mit_reply.dlc > 0 ? mit_reply.dlc == 8 : drive->mit_vendor_reply)) {
      std::fprintf(stderr,
                   "drive_emulator: fault '%s' names drive %d, whose 6-byte replies have no error byte "
                   "(vendor_reply: true in the config, or --mit-reply-dlc 8)\n",
                   emu::to_string(f.kind), f.drive_id);
      return 2;
    }
  }

  std::unique_ptr<emu::Motion> world;
  std::FILE* truth_file = nullptr;
  if (motion == "bullet") {
#if SPRINGBOK_EMULATOR_HAS_BULLET
    if (!truth_log.empty() && (truth_file = std::fopen(truth_log.c_str(), "w")) == nullptr) {
      std::fprintf(stderr, "drive_emulator: --truth-log: cannot write %s\n", truth_log.c_str());
      return 2;
    }
    emu::BulletOptions options;
    options.settle_s = settle_s;
    options.imu_gyro_noise_rad_s = imu_gyro_noise;
    options.imu_accel_noise_m_s2 = imu_accel_noise;
    options.imu_gyro_bias_rad_s = imu_gyro_bias;
    options.imu_accel_bias_m_s2 = imu_accel_bias;
    options.imu_seed = imu_seed;
    options.sensors_preset = sensors_preset == "mems"       ? emu::SensorsPreset::mems
                             : sensors_preset == "tactical" ? emu::SensorsPreset::tactical
                                                            : emu::SensorsPreset::ideal;
    options.sensors_seed = sensors_seed;
    if (!gyro_bias_offset_rad_s.empty()) {
      options.gyro_bias_offset_rad_s = Eigen::Vector3d(gyro_bias_offset_rad_s[0], gyro_bias_offset_rad_s[1],
                                                       gyro_bias_offset_rad_s[2]);
    }
    if (hand_force_n != 0.0) {
      options.hand_force = true;
      options.hand.force_n = hand_force_n;
      options.hand.start_s = hand_force_start_s;
      if (hand_force_duration_s > 0.0) options.hand.duration_s = hand_force_duration_s;
      const double sign = hand_force_axis.front() == '-' ? -1.0 : 1.0;
      options.hand.axis_world = sign * Eigen::Vector3d::Unit(hand_force_axis.back() - 'x');
    }
    try {
      world = std::make_unique<emu::BulletMotion>(truth_file, truth_every, options);
    } catch (const std::exception& e) {
      std::fprintf(stderr, "drive_emulator: %s\n", e.what());
      return 2;
    }
#else
    std::fprintf(stderr, "drive_emulator: --motion bullet: this build has no Bullet (SPRINGBOK_BUILD_SIM=OFF)\n");
    return 2;
#endif
  } else if (!truth_log.empty()) {
    std::fprintf(stderr, "drive_emulator: --truth-log needs --motion bullet\n");
    return 2;
  } else if (hand_force_n != 0.0) {
    std::fprintf(stderr, "drive_emulator: --hand-force-n needs --motion bullet\n");
    return 2;
  } else if (sensors_preset != "ideal") {
    std::fprintf(stderr, "drive_emulator: --sensors-preset needs --motion bullet (the sensors publish only then)\n");
    return 2;
  } else if (!gyro_bias_offset_rad_s.empty()) {
    std::fprintf(stderr, "drive_emulator: --imu-gyro-bias-offset-rad-s needs --motion bullet\n");
    return 2;
  }

  struct BusIo {
    can::SocketCanBus socket;
    std::vector<std::unique_ptr<emu::Drive>> drives;
    std::uint64_t tx_failed = 0;
    std::deque<can::Frame> held;  // lockstep: frames waiting for the world to step, in order
  };
  std::vector<BusIo> buses(cfg.config.buses.size());
  const std::int64_t t0 = can::monotonic_ns();
  for (std::size_t b = 0; b < buses.size(); ++b) {
    const can::BusConfig& bc = cfg.config.buses[b];
    if (const std::string err = buses[b].socket.open(bc.interface, bc.fd, {}, false); !err.empty()) {
      std::fprintf(stderr, "drive_emulator: bus '%s': %s\n", bc.name.c_str(), err.c_str());
      return 3;
    }
    for (const can::DriveConfig& d : bc.drives) {
      std::vector<emu::Fault> mine;
      for (const emu::Fault& f : faults) {
        if (f.drive_id == d.drive_id) mine.push_back(f);
      }
      const emu::JointModel model = emu::make_joint_model(d.joint, initial_position(d.joint, pose));
      if (d.protocol == can::Protocol::mit) {
        can::DriveConfig flash = d;
        if (mit_master_id >= 0) flash.mit_reply_id = static_cast<std::uint16_t>(mit_master_id);
        buses[b].drives.push_back(std::make_unique<emu::MitDrive>(flash, bc.fd, model, mine, can_timeout_ms, mit_reply));
      } else {
        emu::Cia402Options options = cia402;
        options.answer_delay_ms = per_bus(cia402_answer_delay_ms, b);
        options.state_step_ms = per_bus(cia402_state_step_ms, b);
        buses[b].drives.push_back(std::make_unique<emu::Cia402Drive>(d, model, mine, t0, options));
      }
      buses[b].drives.back()->attach(world.get());
    }
  }
  // The sensors (CAN.md 6.5): one sample per world step, on their buses.
  const auto bus_index = [&](const std::string& name) {
    for (std::size_t b = 0; b < cfg.config.buses.size(); ++b) {
      if (cfg.config.buses[b].name == name) return static_cast<int>(b);
    }
    return -1;
  };
  const can::SensorsConfig& sensors_cfg = cfg.config.sensors;
  const int imu_bus = sensors_cfg.imu.enabled ? bus_index(sensors_cfg.imu.bus) : -1;
  const int ft_bus = sensors_cfg.wrist_ft.enabled ? bus_index(sensors_cfg.wrist_ft.bus) : -1;
  emu::SensorEmulator sensors(sensors_cfg, faults);
  std::vector<can::Frame> imu_frames, ft_frames;
  std::uint64_t sensor_tx_failed = 0;
#if SPRINGBOK_EMULATOR_HAS_BULLET
  if (auto* bullet = dynamic_cast<emu::BulletMotion*>(world.get()); bullet != nullptr && (imu_bus >= 0 || ft_bus >= 0)) {
    bullet->set_step_callback([&](const hal::Imu& imu, const hal::Wrench& wrist) {
      sensors.publish(imu, wrist, imu_frames, ft_frames);
      for (const auto& [bus, frames] : {std::pair{imu_bus, &imu_frames}, std::pair{ft_bus, &ft_frames}}) {
        for (const can::Frame& frame : *frames) {
          if (buses[static_cast<std::size_t>(bus)].socket.send(frame) != can::TxStatus::ok) ++sensor_tx_failed;
        }
        frames->clear();
      }
    });
  }
#endif
  if (!world && (imu_bus >= 0 || ft_bus >= 0)) {
    std::fprintf(stderr, "drive_emulator: note: the sensors of can.sensors publish only with --motion bullet\n");
  }
  ::signal(SIGINT, on_signal);
  ::signal(SIGTERM, on_signal);

  std::vector<can::Frame> out;
  const auto flush = [&](BusIo& io) {
    for (const can::Frame& f : out) {
      if (io.socket.send(f) != can::TxStatus::ok) ++io.tx_failed;
    }
    out.clear();
  };
  // CiA 402 power-on: the boot-up frames, now or --cia402-boot-after-ms after the ready file.
  const auto power_on = [&](std::int64_t now) {
    for (BusIo& io : buses) {
      for (auto& d : io.drives) {
        if (auto* c = dynamic_cast<emu::Cia402Drive*>(d.get()); c != nullptr && !c->powered()) c->boot(now, out);
      }
      flush(io);
    }
  };
  if (cia402_boot_after_ms == 0) power_on(t0);
  if (!ready_file.empty()) std::ofstream(ready_file) << "ready\n";
  const std::int64_t power_on_ns = can::monotonic_ns() + 1000000LL * cia402_boot_after_ms;
  bool powered_on = cia402_boot_after_ms == 0;

  std::vector<int> fds;
  for (const BusIo& io : buses) fds.push_back(io.socket.native_handle());
  const std::int64_t end_ns = duration_s > 0 ? t0 + static_cast<std::int64_t>(duration_s * 1e9) : INT64_MAX;
  can::Frame f;
  const auto deliver = [&](BusIo& io, const can::Frame& frame, std::int64_t now) {
    for (auto& d : io.drives) d->on_frame(frame, now, out);
    flush(io);
  };
  // Lockstep (--motion bullet): a drive's next cyclic command waits until the world has
  // stepped with the current ones, so an emulator that falls behind (reading one bus while
  // the host already sent the next tick on another) never steps the world early. The frames
  // behind a held one on its bus wait too (bus order is kept).
  const auto blocked = [](const BusIo& io, const can::Frame& frame) {
    for (const auto& d : io.drives) {
      if (d->waits_for_step(frame)) return true;
    }
    return false;
  };
  const auto release_held = [&](std::int64_t now) {
    for (bool progress = true; progress;) {
      progress = false;
      for (BusIo& io : buses) {
        while (!io.held.empty() && !blocked(io, io.held.front())) {
          const can::Frame frame = io.held.front();
          io.held.pop_front();
          deliver(io, frame, now);
          progress = true;
        }
      }
    }
  };
  // More held frames than three ticks of a bus: a command the world waits for was lost.
  constexpr std::size_t kMaxHeldFrames = 3 * (can::kMaxDrivesPerBus + 1);
  // One pass takes at most two ticks' frames of each bus, then serves the next bus, and every
  // drive's clock (its late answers, heartbeat, delayed NMT) reads the time it is served at. Each
  // bus's drives are separate hardware: a bus whose frames arrive faster than this one process
  // serves them (the host's SYNC every tick on the buses it has enabled, in a CPU-starved VM)
  // must not starve the other buses' drives, nor hold back answers due meanwhile. Before, a
  // pass drained each bus until it was empty under one time read at its start: a late answer
  // went out only after the pass that was under way at its due time, tens of ms late, and a
  // bus behind busy ones was not served at all. Returns whether a bus has frames left.
  constexpr int kFramesPerBusPerPass = 2 * (can::kMaxDrivesPerBus + 1);
  const auto serve_pending = [&] {
    bool left = false;
    for (BusIo& io : buses) {
      int taken = 0;
      for (; taken < kFramesPerBusPerPass && io.socket.receive(f) == can::RxStatus::frame; ++taken) {
        const std::int64_t now = can::monotonic_ns();
        if (!io.held.empty() || blocked(io, f)) {
          io.held.push_back(f);
        } else {
          deliver(io, f, now);
          release_held(now);
        }
      }
      left = left || taken == kFramesPerBusPerPass;
      const std::int64_t now = can::monotonic_ns();
      for (auto& d : io.drives) d->on_time(now, out);
      flush(io);
    }
    for (const BusIo& io : buses) {
      if (world && io.held.size() > kMaxHeldFrames) {
        world->force_step();
        release_held(can::monotonic_ns());
        break;
      }
    }
    return left;
  };
  for (bool left = false; !g_stop && can::monotonic_ns() < end_ns;) {
    if (!left) can::wait_readable(fds, 1000);
    if (!powered_on && can::monotonic_ns() >= power_on_ns) {
      power_on(can::monotonic_ns());
      powered_on = true;
    }
    left = serve_pending();
  }
  // A stop can arrive while a bus still has frames queued (e.g. the firmware's shut-down
  // frames): they are answered before the summary, for at most a second should a host still send.
  for (const std::int64_t until = can::monotonic_ns() + 1000000000LL; serve_pending() && can::monotonic_ns() < until;) {
  }
  for (bool any_held = true; world && any_held;) {
    any_held = false;
    for (const BusIo& io : buses) any_held = any_held || !io.held.empty();
    if (any_held) {
      world->force_step();
      release_held(can::monotonic_ns());
    }
  }
  for (std::size_t b = 0; b < buses.size(); ++b) {
    for (const auto& d : buses[b].drives) {
      std::printf("drive %d joint %s bus %s tick %llu frames_in %llu replies_out %llu enabled %d q_rad %.6f tau_nm %.4f\n",
                  d->config().drive_id, std::string(robot::kJoints[static_cast<std::size_t>(d->config().joint)].name).c_str(),
                  cfg.config.buses[b].name.c_str(), static_cast<unsigned long long>(d->tick()),
                  static_cast<unsigned long long>(d->frames_in()), static_cast<unsigned long long>(d->replies_out()),
                  d->enabled() ? 1 : 0, d->model().q_rad, d->model().tau_nm);
      if (const auto* c = dynamic_cast<const emu::Cia402Drive*>(d.get()); c != nullptr) {
        std::printf("cia402 drive %d statusword 0x%04X nmt 0x%02X nmt_resets %llu sync_timeouts %llu\n",
                    d->config().drive_id, c->status_word(), c->nmt_state(), static_cast<unsigned long long>(c->nmt_resets()),
                    static_cast<unsigned long long>(c->sync_timeouts()));
      }
      if (const auto* mit = dynamic_cast<const emu::MitDrive*>(d.get()); mit != nullptr && cfg.config.buses[b].fd) {
        std::printf("fd_bus drive %d classic_frames %llu\n", d->config().drive_id,
                    static_cast<unsigned long long>(mit->classic_frames()));
      }
    }
    std::printf("bus %s tx_failed %llu\n", cfg.config.buses[b].name.c_str(),
                static_cast<unsigned long long>(buses[b].tx_failed));
  }
  if (imu_bus >= 0 || ft_bus >= 0) {
    std::printf("sensors imu_samples %llu ft_samples %llu frames_out %llu tx_failed %llu\n",
                static_cast<unsigned long long>(sensors.imu_samples()),
                static_cast<unsigned long long>(sensors.ft_samples()),
                static_cast<unsigned long long>(sensors.frames_out()),
                static_cast<unsigned long long>(sensor_tx_failed));
  }
#if SPRINGBOK_EMULATOR_HAS_BULLET
  if (const auto* bullet = dynamic_cast<const emu::BulletMotion*>(world.get())) {
    const emu::TruthSummary& t = bullet->truth();
    std::printf("truth steps %llu time_s %.3f trunk_z_m %.5f trunk_tilt_rad %.5f non_foot_contact %d forced_steps %llu\n",
                static_cast<unsigned long long>(t.steps), t.time_s, t.trunk_z_m, t.trunk_tilt_rad,
                t.non_foot_ground_contact ? 1 : 0, static_cast<unsigned long long>(t.forced_steps));
    std::printf("imu gyro_bias_rad_s %.6f %.6f %.6f accel_bias_m_s2 %.6f %.6f %.6f\n", t.imu_gyro_bias_rad_s.x(),
                t.imu_gyro_bias_rad_s.y(), t.imu_gyro_bias_rad_s.z(), t.imu_accel_bias_m_s2.x(),
                t.imu_accel_bias_m_s2.y(), t.imu_accel_bias_m_s2.z());
  }
#endif
  if (truth_file != nullptr) std::fclose(truth_file);
  return 0;
}
