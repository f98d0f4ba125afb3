// Start-up and shut-down of the SocketCAN backend (CAN.md 4.2, 4.3, 4.4).
// Not real-time: may allocate (messages) and wait (bounded by the configured timeouts).
#include <time.h>

#include <cerrno>
#include <cmath>
#include <algorithm>
#include <cstdio>
#include <string>
#include <vector>

#include "springbok/can/bus_load.hpp"
#include "springbok/can/can_hardware.hpp"

namespace springbok::can {

namespace {
using hal::LifecycleResult;

// CAN.md 4.3 step 1: a CiA 402 node neither booting nor heard this long after its bus starts is
// sent NMT reset communication (it may be up with its heartbeat off, its boot-up missed).
constexpr std::uint32_t kSilentNodeResetMs = 500;

std::int64_t after_ms(std::uint32_t ms) { return monotonic_ns() + 1000000LL * ms; }

std::string hex(std::uint32_t v, int digits) {
  char buf[16];
  std::snprintf(buf, sizeof buf, "0x%0*X", digits, v);
  return buf;
}

void sleep_until_ns(std::int64_t t_ns) {
  const timespec ts{static_cast<time_t>(t_ns / 1000000000LL), static_cast<long>(t_ns % 1000000000LL)};
  while (::clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &ts, nullptr) == EINTR) {
  }
}
}  // namespace

// A drive that gave no valid answer, for a start-up message: its name, and the replies it sent in
// a length CAN.md 1.4 does not allow (dropped) when there were any: "no reply" would hide them.
std::string CanHardware::unanswered_drive(int j) const {
  const JointRuntime& jr = joints_[static_cast<std::size_t>(j)];
  std::string why = drive_name(j);
  if (jr.wrong_dlc_replies > 0) {
    why += ": " + std::to_string(jr.wrong_dlc_replies) + " replies of DLC " + std::to_string(jr.wrong_dlc_len) +
           " dropped (CAN.md 1.4: 6, 7 or 8 bytes)";
  }
  return why;
}

std::string CanHardware::drive_name(int j) const {
  const JointRuntime& jr = joints_[static_cast<std::size_t>(j)];
  const BusConfig& bc = config_.buses[static_cast<std::size_t>(jr.bus)];
  return "drive " + std::to_string(jr.cfg.drive_id) + " (joint " +
         std::string(robot::kJoints[static_cast<std::size_t>(j)].name) + ", " + to_string(jr.cfg.protocol) +
         ") on bus '" + bc.name + "' (" + bc.interface + ")";
}

template <class Done>
bool CanHardware::pump_until(std::int64_t deadline_ns, Done&& done) {
  std::array<int, kMaxBuses> fds{};
  const int n = handles(fds);
  for (;;) {
    keep_alive();
    for (int b = 0; b < bus_count_; ++b) {
      if (buses_[static_cast<std::size_t>(b)].socket.is_open()) (void)drain(b, kMaxRxFramesPerBusPerTick);
    }
    if (done()) return true;
    const std::int64_t now = monotonic_ns();
    if (now >= deadline_ns) return false;
    const std::int64_t wake = std::min(deadline_ns, next_keep_alive_ns_ > now ? next_keep_alive_ns_ : deadline_ns);
    wait_readable(std::span<const int>(fds.data(), static_cast<std::size_t>(n)), (wake - now) / 1000 + 1);
  }
}

void CanHardware::keep_alive() noexcept {
  if (active_) return;  // read() sends the tick's frames
  const std::int64_t now = monotonic_ns();
  if (now < next_keep_alive_ns_) return;
  bool any = false;
  for (int b = 0; b < bus_count_; ++b) {
    const Bus& bus = buses_[static_cast<std::size_t>(b)];
    if (!bus.synced || !bus.socket.is_open() || !bus_commanded(bus.diag.fault)) continue;
    any = true;
    for (int k = 0; k < bus.count; ++k) {
      const JointRuntime& jr = joints_[static_cast<std::size_t>(bus.joints[k])];
      if (jr.cfg.protocol != Protocol::cia402) continue;
      Frame f;
      cia402::encode_rpdo1(jr.cfg.drive_id, cia402::Rpdo1{cia402::controlword::enable_operation, 0}, f);
      send_now(b, f);
    }
    send_sync(b);
  }
  if (any) next_keep_alive_ns_ = now + 1000LL * config_.timing.tick_us;
}

LifecycleResult CanHardware::open_bus(int b) {
  const BusConfig& bc = config_.buses[static_cast<std::size_t>(b)];
  std::vector<std::uint32_t> ids;
  for (const DriveConfig& d : bc.drives) {
    if (d.protocol == Protocol::mit) {
      ids.push_back(d.mit_reply_id);
      ids.push_back(kMitFactoryMasterId);  // a drive left at its factory CAN_MASTER (CAN.md 1.4)
    } else {
      for (std::uint32_t base : {cia402::cob::emcy, cia402::cob::tpdo1, cia402::cob::tpdo2, cia402::cob::sdo_response,
                                 cia402::cob::heartbeat}) {
        ids.push_back(base + d.drive_id);
      }
    }
  }
  const SensorsConfig& sc = config_.sensors;
  if (sc.imu.enabled && sc.imu.bus == bc.name) ids.insert(ids.end(), sc.imu.ids.begin(), sc.imu.ids.end());
  if (sc.wrist_ft.enabled && sc.wrist_ft.bus == bc.name) {
    ids.insert(ids.end(), sc.wrist_ft.ids.begin(), sc.wrist_ft.ids.end());
  }
  Bus& bus = buses_[static_cast<std::size_t>(b)];
  const std::string err = bus.socket.open(bc.interface, bc.fd, ids, true);
  if (!err.empty()) return LifecycleResult::failure("bus '" + bc.name + "': " + err);
  bus.diag = BusDiagnostics{};
  bus.tx_full = TxBufferFull{};
  // What a CiA 402 node said of its NMT state counts from now on, while other buses start too.
  for (int k = 0; k < bus.count; ++k) {
    JointRuntime& jr = joints_[static_cast<std::size_t>(bus.joints[k])];
    jr.booted = false;
    jr.heartbeat_seen = false;
  }
  return LifecycleResult::success();
}

LifecycleResult CanHardware::configure() {
  if (active_) return LifecycleResult::failure("configure: the backend is active; deactivate first");
  if (const std::string err = validate(config_); !err.empty()) return LifecycleResult::failure("CAN config: " + err);
  if (const std::string err = check_bus_loads(config_); !err.empty()) {
    return LifecycleResult::failure("CAN layout refused: " + err);
  }
  bus_count_ = static_cast<int>(config_.buses.size());
  joints_ = {};
  startup_notes_.clear();
  for (int b = 0; b < bus_count_; ++b) {
    Bus& bus = buses_[static_cast<std::size_t>(b)];
    bus.count = 0;
    bus.any_mit = bus.any_cia = bus.synced = false;
    const std::string& name = config_.buses[static_cast<std::size_t>(b)].name;
    bus.has_imu = config_.sensors.imu.enabled && config_.sensors.imu.bus == name;
    bus.has_ft = config_.sensors.wrist_ft.enabled && config_.sensors.wrist_ft.bus == name;
    for (const DriveConfig& d : config_.buses[static_cast<std::size_t>(b)].drives) {
      JointRuntime& jr = joints_[static_cast<std::size_t>(d.joint)];
      jr.cfg = d;
      jr.bus = b;
      // The correction stays within a few LSB: the drive's truncation error is below one.
      jr.velocity.configure(d.protocol == Protocol::mit ? config_.mit_velocity_observer_rad_s : 0.0,
                            3.0 * mit::velocity_lsb_rad_s(d.mit_ranges));
      bus.joints[static_cast<std::size_t>(bus.count++)] = d.joint;
      bus.any_mit = bus.any_mit || d.protocol == Protocol::mit;
      bus.any_cia = bus.any_cia || d.protocol == Protocol::cia402;
    }
  }
  const std::uint64_t ticks_per_ms = std::max<std::uint64_t>(1, 1000 / config_.timing.tick_us);
  heartbeat_lost_ticks_ = std::uint64_t{config_.timing.heartbeat_period_ms} * config_.timing.heartbeat_lost_periods *
                          ticks_per_ms;
  imu_.configure(config_.sensors.imu, tick_);
  ft_.configure(config_.sensors.wrist_ft, tick_);
  for (int b = 0; b < bus_count_; ++b) {
    if (LifecycleResult r = open_bus(b); !r.ok) return r;
  }
  for (int b = 0; b < bus_count_; ++b) {
    if (LifecycleResult r = start_bus(b); !r.ok) return r;
  }
  configured_ = true;
  return LifecycleResult::success();
}

// A fault the bus latched since it was opened (an error frame, a frame of another bus's drive):
// start-up does not go on with that bus. Not real-time.
LifecycleResult CanHardware::bus_fault_failure(int b, const char* during) const {
  const BusDiagnostics& d = buses_[static_cast<std::size_t>(b)].diag;
  if (d.fault == BusFault::none) return LifecycleResult::success();
  const BusConfig& bc = config_.buses[static_cast<std::size_t>(b)];
  std::string why = std::string("CAN ") + during + ": bus '" + bc.name + "' (" + bc.interface + "): " + to_string(d.fault);
  if (d.fault == BusFault::foreign_drive) {
    const int other = find_foreign_joint(b, d.foreign_drive_id);
    why += ": CAN id " + hex(d.foreign_can_id, 3) + " naming " +
           (other >= 0 ? drive_name(other) : "drive " + std::to_string(d.foreign_drive_id));
  }
  return LifecycleResult::failure(why);
}

LifecycleResult CanHardware::start_bus(int b) {
  const Bus& bus = buses_[static_cast<std::size_t>(b)];
  if (bus.any_mit) {
    if (LifecycleResult r = start_mit(b); !r.ok) return r;
  }
  if (bus.any_cia) {
    if (LifecycleResult r = start_cia402(b); !r.ok) return r;
  }
  return bus_fault_failure(b, "start-up");
}

LifecycleResult CanHardware::enable_bus(int b) {
  const Bus& bus = buses_[static_cast<std::size_t>(b)];
  if (LifecycleResult r = bus_fault_failure(b, "enable"); !r.ok) return r;
  if (bus.any_mit) {
    if (LifecycleResult r = enable_mit(b); !r.ok) return r;
  }
  if (bus.any_cia) {
    if (LifecycleResult r = enable_cia402(b); !r.ok) return r;
  }
  if (LifecycleResult r = bus_fault_failure(b, "enable"); !r.ok) return r;
  buses_[static_cast<std::size_t>(b)].synced = bus.any_cia;
  // The first cyclic command, sent by the first read before the loop's first write: damping
  // (CAN.md 4.2 step 5, 4.3 step 5), never zero torque.
  hal::JointCommands damping;
  damping.mode = hal::CommandMode::enabled;
  damping.kd_nms_per_rad.setConstant(config_.timing.damping_kd_nms_per_rad);
  for (int k = 0; k < bus.count; ++k) {
    JointRuntime& jr = joints_[static_cast<std::size_t>(bus.joints[k])];
    // Clears what the walk itself latched (a drive found in Fault, then reset); a drive's own
    // fault code during start-up never gets here: it failed start-up above (startup_fault).
    jr.status = hal::DriveStatus{};
    jr.status.state = hal::DriveState::enabled;
    jr.last_rx_tick = tick_;
    jr.last_heartbeat_tick = tick_;
    jr.implausible_in_row = 0;
    queue_command(bus.joints[k], damping);
  }
  return LifecycleResult::success();
}

LifecycleResult CanHardware::activate() {
  if (!configured_) return LifecycleResult::failure("activate: configure() has not succeeded");
  if (active_) return LifecycleResult::success();
  for (int b = 0; b < bus_count_; ++b) {
    if (LifecycleResult r = enable_bus(b); !r.ok) return disable_after_failed_enable(0, b, std::move(r));
  }
  for (JointRuntime& jr : joints_) jr.replies_this_tick = 0;  // the keep-alive's TPDOs are not the first tick's
  active_ = true;
  last_send_ns_ = monotonic_ns();
  return LifecycleResult::success();
}

// A failed enable leaves no drive enabled: buses first..last were enabled, or were being enabled
// when `failure` happened (some of the failing bus's drives may be in motor mode / Operation
// enabled already), so each is disabled as in CAN.md 4.4 step 2. No damping first: the drives
// were enabled a moment ago, at rest, with zero torque (4.2 step 2) or none (4.3 step 4). A bus
// whose fault stops it carrying frames (bus-off with no restart since, ENETDOWN, ...) or that is
// closed cannot be reached, and the message says so.
LifecycleResult CanHardware::disable_after_failed_enable(int first, int last, LifecycleResult failure) {
  std::string disabled, unreachable;
  for (int b = first; b <= last; ++b) {
    const Bus& bus = buses_[static_cast<std::size_t>(b)];
    if (bus.count == 0) continue;  // sensors only
    const BusConfig& bc = config_.buses[static_cast<std::size_t>(b)];
    const std::string name = "'" + bc.name + "' (" + bc.interface + ")";
    if (!bus.socket.is_open() || !bus_reachable(bus.diag)) {
      unreachable += (unreachable.empty() ? "" : ", ") + name + ": " + to_string(bus.diag.fault);
    } else {
      disabled += (disabled.empty() ? "" : ", ") + name;
    }
  }
  disable_buses(first, last);
  // Let the drives' answers arrive so they do not count against a later start-up.
  pump_until(monotonic_ns() + 20000000LL, [] { return false; });
  if (!disabled.empty()) failure.message += "; every drive on bus " + disabled + " disabled again (CAN.md 4.4 step 2)";
  if (!unreachable.empty()) {
    failure.message += "; not reachable, its drives rely on their own timeouts: bus " + unreachable;
  }
  return failure;
}

// ---- MIT mode (CAN.md 4.2) ---------------------------------------------------------------------
LifecycleResult CanHardware::start_mit(int b) {
  const Bus& bus = buses_[static_cast<std::size_t>(b)];
  const auto mit_joints = [&](auto&& f) {
    for (int k = 0; k < bus.count; ++k) {
      if (joints_[static_cast<std::size_t>(bus.joints[k])].cfg.protocol == Protocol::mit) f(bus.joints[k]);
    }
  };
  const auto all_replied = [&] {
    bool all = true;
    mit_joints([&](int j) { all = all && joints_[static_cast<std::size_t>(j)].replies_this_tick > 0; });
    return all;
  };
  std::vector<int> drives;
  mit_joints([&](int j) {
    JointRuntime& jr = joints_[static_cast<std::size_t>(j)];
    jr.replies_this_tick = 0;
    jr.startup_fault_code = 0;
    jr.wrong_dlc_replies = 0;
    drives.push_back(j);
  });
  // 1. Exit motor mode: presence check; the reply gives the initial position.
  for (std::uint32_t attempt = 0; attempt <= config_.timing.mit_presence_retries && !all_replied(); ++attempt) {
    mit_joints([&](int j) {
      JointRuntime& jr = joints_[static_cast<std::size_t>(j)];
      if (jr.replies_this_tick > 0) return;
      Frame f;
      mit::encode_special(jr.cfg.drive_id, mit::Special::exit_motor_mode, f);
      send_now(b, f);
    });
    pump_until(after_ms(config_.timing.mit_presence_timeout_ms), all_replied);
  }
  if (LifecycleResult r = startup_fault(drives, "start-up"); !r.ok) return r;
  std::string missing;
  mit_joints([&](int j) {
    if (joints_[static_cast<std::size_t>(j)].replies_this_tick == 0) missing += (missing.empty() ? "" : "; ") + unanswered_drive(j);
  });
  if (!missing.empty()) {
    return LifecycleResult::failure("MIT start-up: no valid reply to exit-motor-mode after " +
                                    std::to_string(config_.timing.mit_presence_retries + 1) + " tries of " +
                                    std::to_string(config_.timing.mit_presence_timeout_ms) + " ms: " + missing);
  }
  // 2. A zero command, so the stored command is safe.
  mit_joints([&](int j) {
    joints_[static_cast<std::size_t>(j)].replies_this_tick = 0;
    Frame f;
    (void)mit::encode_command(joints_[static_cast<std::size_t>(j)].cfg.drive_id, mit::Command{},
                              joints_[static_cast<std::size_t>(j)].cfg.mit_ranges, f);
    send_now(b, f);
  });
  const bool answered = pump_until(after_ms(config_.timing.mit_presence_timeout_ms), all_replied);
  if (LifecycleResult r = startup_fault(drives, "start-up"); !r.ok) return r;
  if (!answered) {
    std::string unanswered;
    mit_joints([&](int j) {
      if (joints_[static_cast<std::size_t>(j)].replies_this_tick == 0) {
        unanswered += (unanswered.empty() ? "" : "; ") + unanswered_drive(j);
      }
    });
    return LifecycleResult::failure("MIT start-up: no valid reply to the zero command: " + unanswered);
  }
  // 3. Positions within the joint limits and, when the config gives it, at the expected pose
  // (can.start_pose).
  std::string outside, off_pose;
  const StartPose& pose = config_.start_pose;
  mit_joints([&](int j) {
    JointRuntime& jr = joints_[static_cast<std::size_t>(j)];
    jr.replies_this_tick = 0;
    const auto& lim = robot::kJoints[static_cast<std::size_t>(j)].limits;
    const double m = config_.timing.start_limit_margin_rad;
    if (lim.bounded && (jr.q_rad < lim.lower_rad - m || jr.q_rad > lim.upper_rad + m)) {
      outside += (outside.empty() ? "" : "; ") + drive_name(j) + " at " + std::to_string(jr.q_rad) + " rad, limits [" +
                 std::to_string(lim.lower_rad) + ", " + std::to_string(lim.upper_rad) + "]";
    } else if (pose.given && !at_start_pose(pose, j, jr.q_rad)) {
      off_pose += (off_pose.empty() ? "" : "; ") + drive_name(j) + " at " + std::to_string(jr.q_rad) +
                  " rad, expected " + std::to_string(pose.q_rad[static_cast<std::size_t>(j)]) + " rad";
    }
    jr.status.state = hal::DriveState::ready;
  });
  if (!outside.empty()) return LifecycleResult::failure("MIT start-up: position outside the joint limits: " + outside);
  if (!off_pose.empty()) {
    return LifecycleResult::failure("MIT start-up: position off the expected start pose (can.start_pose, tolerance " +
                                    std::to_string(pose.tolerance_rad) + " rad): " + off_pose);
  }
  return LifecycleResult::success();
}

LifecycleResult CanHardware::enable_mit(int b) {
  const Bus& bus = buses_[static_cast<std::size_t>(b)];
  bool all_sent = true;
  std::vector<int> drives;
  for (int k = 0; k < bus.count; ++k) {
    JointRuntime& jr = joints_[static_cast<std::size_t>(bus.joints[k])];
    if (jr.cfg.protocol != Protocol::mit) continue;
    drives.push_back(bus.joints[k]);
    jr.replies_this_tick = 0;
    Frame f;
    mit::encode_special(jr.cfg.drive_id, mit::Special::enter_motor_mode, f);
    all_sent = send_now(b, f) && all_sent;
  }
  const auto all_replied = [&] {
    for (int k = 0; k < bus.count; ++k) {
      const JointRuntime& jr = joints_[static_cast<std::size_t>(bus.joints[k])];
      if (jr.cfg.protocol == Protocol::mit && jr.replies_this_tick == 0) return false;
    }
    return true;
  };
  const bool ok = all_sent && pump_until(after_ms(config_.timing.mit_presence_timeout_ms), all_replied);
  std::string missing;
  for (int j : drives) {
    if (joints_[static_cast<std::size_t>(j)].replies_this_tick == 0) missing += (missing.empty() ? "" : "; ") + unanswered_drive(j);
  }
  for (int k = 0; k < bus.count; ++k) joints_[static_cast<std::size_t>(bus.joints[k])].replies_this_tick = 0;
  if (LifecycleResult r = startup_fault(drives, "enable"); !r.ok) return r;
  if (!all_sent) {
    return LifecycleResult::failure("MIT enable: enter-motor-mode could not be sent on bus '" +
                                    config_.buses[static_cast<std::size_t>(b)].name + "'");
  }
  if (!ok) {
    return LifecycleResult::failure("MIT enable: no valid reply to enter-motor-mode within " +
                                    std::to_string(config_.timing.mit_presence_timeout_ms) + " ms: " + missing);
  }
  return LifecycleResult::success();
}

// ---- CiA 402 (CAN.md 4.3) --------------------------------------------------------------------------
CanHardware::SdoOutcome CanHardware::sdo(int j, bool write, std::uint16_t index, std::uint8_t sub, std::uint32_t value,
                                         std::uint8_t size) {
  JointRuntime& jr = joints_[static_cast<std::size_t>(j)];
  SdoOutcome out;
  for (std::uint32_t attempt = 0; attempt <= config_.timing.sdo_retries; ++attempt) {
    cia402::SdoRequest req;
    req.kind = write ? cia402::SdoRequest::Kind::write : cia402::SdoRequest::Kind::read;
    req.index = index;
    req.sub = sub;
    req.value = value;
    req.size = size;
    Frame f;
    cia402::encode_sdo_request(jr.cfg.drive_id, req, f);
    jr.sdo_answered = false;
    send_now(jr.bus, f);
    // The answer names the request's object; another (a late answer to an earlier request, after
    // its retry went out, or a repeat) is dropped and the wait goes on.
    cia402::SdoResponse res;
    const auto answered = [&] {
      if (!jr.sdo_answered) return false;
      jr.sdo_answered = false;
      return cia402::decode_sdo_response(jr.sdo_answer, jr.cfg.drive_id, res) == FrameStatus::ok && res.index == index &&
             res.sub == sub;
    };
    if (!pump_until(after_ms(config_.timing.sdo_timeout_ms), answered)) continue;
    if (res.kind == cia402::SdoResponse::Kind::abort) {
      out.kind = SdoOutcome::Kind::abort;
      out.abort_code = res.value;
      return out;
    }
    if (res.kind != (write ? cia402::SdoResponse::Kind::write_ok : cia402::SdoResponse::Kind::read_ok)) {
      out.kind = SdoOutcome::Kind::bad_answer;
      return out;
    }
    out.kind = SdoOutcome::Kind::ok;
    out.value = res.value;
    return out;
  }
  out.kind = SdoOutcome::Kind::timeout;
  return out;
}

LifecycleResult CanHardware::configure_node(int j) {
  JointRuntime& jr = joints_[static_cast<std::size_t>(j)];
  const auto describe = [&](const SdoOutcome& o, bool write, std::uint16_t index, std::uint8_t sub) {
    std::string what = std::string("SDO ") + (write ? "write " : "read ") + hex(index, 4) + ":" + std::to_string(sub) +
                       " on " + drive_name(j) + ": ";
    switch (o.kind) {
      case SdoOutcome::Kind::ok: return what + "ok";
      case SdoOutcome::Kind::abort:
        return what + "aborted, " + hex(o.abort_code, 8) + " " + cia402::abort_code_name(o.abort_code);
      case SdoOutcome::Kind::timeout:
        return what + "no answer within " + std::to_string(config_.timing.sdo_timeout_ms) + " ms after " +
               std::to_string(config_.timing.sdo_retries + 1) + " tries";
      case SdoOutcome::Kind::bad_answer: return what + "malformed or mismatched answer";
    }
    return what;
  };
  const auto write = [&](std::uint16_t index, std::uint8_t sub, std::uint32_t value, std::uint8_t size,
                         bool optional) -> std::string {
    const SdoOutcome o = sdo(j, true, index, sub, value, size);
    if (o.kind == SdoOutcome::Kind::ok) return {};
    if (optional && o.kind == SdoOutcome::Kind::abort &&
        (o.abort_code == cia402::abort_code::no_object || o.abort_code == cia402::abort_code::no_subindex ||
         o.abort_code == cia402::abort_code::unsupported_access || o.abort_code == cia402::abort_code::read_only)) {
      startup_notes_ += "can start-up: " + drive_name(j) + ": " + hex(index, 4) + ":" + std::to_string(sub) +
                        " not written (" + cia402::abort_code_name(o.abort_code) + "): where present (CAN.md 2)\n";
      return {};  // "where present"
    }
    return describe(o, true, index, sub);
  };
  const auto read = [&](std::uint16_t index, std::uint8_t sub, std::uint32_t& value) -> std::string {
    const SdoOutcome o = sdo(j, false, index, sub, 0, 0);
    value = o.value;
    return o.kind == SdoOutcome::Kind::ok ? std::string{} : describe(o, false, index, sub);
  };
  using namespace cia402;
  std::string err;
  std::uint32_t value = 0;
  if (!(err = write(object::producer_heartbeat, 0, config_.timing.heartbeat_period_ms, 2, false)).empty()) return LifecycleResult::failure(err);
  if (!(err = read(object::supported_modes, 0, value)).empty()) return LifecycleResult::failure(err);
  if ((value & kSupportedModeCstBit) == 0) {
    return LifecycleResult::failure(drive_name(j) + ": 0x6502 = " + hex(value, 8) + ", cyclic synchronous torque not supported");
  }
  // The drive's own rated torque scales 0x6071 / 0x6072 / 0x6077 (CAN.md 2.4), so it is read
  // before 0x6072 is computed and written below. The config's rated_torque_nm only documents
  // what is expected: a difference is noted, not fatal.
  if (!(err = read(object::rated_torque, 0, value)).empty()) return LifecycleResult::failure(err);
  const double limit_nm = torque_limit_peak_nm(j);
  switch (make_torque_scale(value, jr.cfg.gear_ratio, limit_nm, jr.cfg.max_torque_permille, jr.torque_scale)) {
    case TorqueScaleStatus::ok: break;
    case TorqueScaleStatus::zero_rating:
      return LifecycleResult::failure(drive_name(j) + ": motor rated torque 0x6076 reads 0 mNm: no torque scaling");
    case TorqueScaleStatus::too_coarse:
      return LifecycleResult::failure(drive_name(j) + ": motor rated torque 0x6076 reads " + std::to_string(value) +
                                      " mNm: one 0x6071 unit (0.1 %, x gear ratio " + std::to_string(jr.cfg.gear_ratio) +
                                      ") is coarser than the joint's torque limit " + std::to_string(limit_nm) + " Nm");
  }
  jr.rated_torque_mnm = value;
  const double rated_nm = static_cast<double>(value) / 1000.0;
  if (jr.cfg.rated_torque_nm > 0.0 && std::abs(rated_nm - jr.cfg.rated_torque_nm) > 0.005 * jr.cfg.rated_torque_nm) {
    startup_notes_ += "can start-up: " + drive_name(j) + ": motor rated torque 0x6076 = " + std::to_string(value) +
                      " mNm, the config's rated_torque_nm is " + std::to_string(jr.cfg.rated_torque_nm) +
                      ": torques are scaled by the drive's value\n";
  }
  std::array<SdoWrite, kMaxMappingWrites> seq{};
  const int n = pdo_mapping_sequence(jr.cfg.drive_id, jr.cfg.mapping, seq);
  for (int i = 0; i < n; ++i) {
    if (!(err = write(seq[i].index, seq[i].sub, seq[i].value, seq[i].size, seq[i].optional)).empty()) {
      return LifecycleResult::failure(err);
    }
  }
  if (!(err = write(object::modes_of_operation, 0, static_cast<std::uint8_t>(kModeCst), 1, false)).empty()) return LifecycleResult::failure(err);
  if (!(err = write(object::interpolation_period, 1, 1, 1, false)).empty()) return LifecycleResult::failure(err);
  if (!(err = write(object::interpolation_period, 2, static_cast<std::uint8_t>(-3), 1, false)).empty()) return LifecycleResult::failure(err);
  if (!(err = write(object::max_torque, 0, jr.torque_scale.max_permille, 2, false)).empty()) return LifecycleResult::failure(err);
  if (!(err = write(object::cycle_period, 0, config_.timing.tick_us, 4, true)).empty()) return LifecycleResult::failure(err);
  if (!(err = write(object::abort_connection, 0, 3, 2, true)).empty()) return LifecycleResult::failure(err);
  if (!(err = write(object::error_behaviour, 1, 0, 1, true)).empty()) return LifecycleResult::failure(err);
  // 0x6061 must read back 10 before enabling (CAN.md 2.4); a drive may switch modes in its own
  // cycle after the write, so re-read it, one tick apart, until it shows CST or
  // state_step_timeout_ms (the bound on the drive's other state changes, 4.3 step 4) has passed.
  const std::int64_t mode_deadline = after_ms(config_.timing.state_step_timeout_ms);
  int mode_reads = 0;
  for (;;) {
    if (!(err = read(object::modes_display, 0, value)).empty()) return LifecycleResult::failure(err);
    ++mode_reads;
    if (static_cast<std::int8_t>(value & 0xFF) == kModeCst) break;
    if (monotonic_ns() >= mode_deadline) {
      return LifecycleResult::failure(drive_name(j) + ": modes of operation display 0x6061 still reads " +
                                      std::to_string(static_cast<std::int8_t>(value & 0xFF)) + " after " +
                                      std::to_string(mode_reads) + " reads over " +
                                      std::to_string(config_.timing.state_step_timeout_ms) +
                                      " ms, expected 10 (CST, written to 0x6060)");
    }
    sleep_until_ns(std::min<std::int64_t>(mode_deadline, monotonic_ns() + 1000LL * config_.timing.tick_us));
  }
  return LifecycleResult::success();
}

// A fault code from the drive itself latches a drive fault: any EMCY with a non-zero code (CAN.md
// 2.2), the non-zero error byte of a vendor MIT reply (1.4, drives with mit_vendor_reply). During
// start-up the CiA 402 state machine walk (4.3 step 4) fault-resets a drive in Fault and would
// enable it again, and MIT start-up marks every drive that answered ready (4.2 step 3), silently
// clearing that latch; so a code seen from the start of the bus's start-up to its enable fails
// start-up, naming the drive and the code, and the fault stays latched in its status. Clearing it
// is an operator action (as after bus-off, 4): fix the cause, then start up again. A CiA 402 drive
// found in Fault without an EMCY during this start-up (a fault left from before) is reset by the walk.
LifecycleResult CanHardware::startup_fault(const std::vector<int>& drives, const char* during) {
  for (int j : drives) {
    const JointRuntime& jr = joints_[static_cast<std::size_t>(j)];
    if (jr.startup_fault_code == 0) continue;
    const bool mit = jr.cfg.protocol == Protocol::mit;
    std::string what;
    if (mit && jr.startup_fault_code == kFaultBusUndervoltage) {
      char v[160];
      std::snprintf(v, sizeof v, " reports a bus voltage of %.2f V, below can.mit_bus_voltage_fault_v %.2f V",
                    jr.status.bus_voltage_v, config_.mit_bus_voltage_fault_v);
      what = std::string(v) + ": drive fault latched (CAN.md 1.4: about to brown out)";
    } else if (mit) {
      what = " reports vendor error code " + hex(jr.startup_fault_code, 2) + ": drive fault latched (CAN.md 1.4)";
    } else {
      what = " sent EMCY " + hex(jr.startup_fault_code, 4) + ": drive fault latched (CAN.md 2.2)";
    }
    return LifecycleResult::failure(std::string(mit ? "MIT " : "CiA 402 ") + during + ": " + drive_name(j) + what +
                                    "; clear its cause, then start up again");
  }
  return LifecycleResult::success();
}

LifecycleResult CanHardware::start_cia402(int b) {
  const Bus& bus = buses_[static_cast<std::size_t>(b)];
  const BusConfig& bc = config_.buses[static_cast<std::size_t>(b)];
  std::vector<int> nodes;
  for (int k = 0; k < bus.count; ++k) {
    if (joints_[static_cast<std::size_t>(bus.joints[k])].cfg.protocol == Protocol::cia402) nodes.push_back(bus.joints[k]);
  }
  const auto all_booted = [&] {
    for (int j : nodes) {
      if (!joints_[static_cast<std::size_t>(j)].booted) return false;
    }
    return true;
  };
  // 1. Boot-up: wait for each node's boot-up frame up to boot_timeout_ms. A node heard to be up
  // already (a heartbeat, since the bus was opened) is sent NMT reset communication, and its boot-up
  // waited for, again up to boot_timeout_ms from then. A node neither booting nor heard within
  // kSilentNodeResetMs is sent one too: it may be up with its heartbeat off (CiA 301's default
  // 0x1017 is 0) and its boot-up sent before the host listened; a node not yet powered ignores it
  // and boots on its own, so only a node that stays silent after it fails start-up.
  for (int j : nodes) joints_[static_cast<std::size_t>(j)].startup_fault_code = 0;
  enum class Reset : std::uint8_t { none, heard, silent };
  std::vector<Reset> reset(nodes.size(), Reset::none);
  const auto up_not_reset = [&] {
    for (std::size_t i = 0; i < nodes.size(); ++i) {
      const JointRuntime& jr = joints_[static_cast<std::size_t>(nodes[i])];
      if (!jr.booted && jr.heartbeat_seen && reset[i] == Reset::none) return true;
    }
    return false;
  };
  const std::int64_t silent_reset_ns = after_ms(kSilentNodeResetMs);
  std::int64_t deadline_ns = after_ms(config_.timing.boot_timeout_ms);
  for (bool silent_due = false;;) {
    pump_until(silent_due ? deadline_ns : std::min(deadline_ns, silent_reset_ns),
               [&] { return all_booted() || up_not_reset(); });
    if (all_booted()) break;
    silent_due = monotonic_ns() >= silent_reset_ns;
    bool sent = false;
    for (std::size_t i = 0; i < nodes.size(); ++i) {
      const JointRuntime& jr = joints_[static_cast<std::size_t>(nodes[i])];
      if (jr.booted || reset[i] != Reset::none || !(jr.heartbeat_seen || silent_due)) continue;
      Frame f;
      cia402::encode_nmt(cia402::NmtCommand::reset_communication, jr.cfg.drive_id, f);
      send_now(b, f);
      reset[i] = jr.heartbeat_seen ? Reset::heard : Reset::silent;
      sent = true;
    }
    if (sent) {
      deadline_ns = std::max(deadline_ns, after_ms(config_.timing.boot_timeout_ms));
    } else if (monotonic_ns() >= deadline_ns) {
      break;
    }
  }
  if (!all_booted()) {
    std::string missing;
    for (std::size_t i = 0; i < nodes.size(); ++i) {
      if (joints_[static_cast<std::size_t>(nodes[i])].booted) continue;
      const char* why = reset[i] == Reset::heard    ? ": up (heartbeat seen), no boot-up after NMT reset communication"
                        : reset[i] == Reset::silent ? ": neither boot-up nor heartbeat, nor a boot-up after NMT reset communication"
                                                    : ": neither boot-up nor heartbeat";
      missing += (missing.empty() ? "" : "; ") + drive_name(nodes[i]) + why;
    }
    return LifecycleResult::failure("CiA 402 start-up on bus '" + bc.name + "': no boot-up within " +
                                    std::to_string(config_.timing.boot_timeout_ms) + " ms: " + missing);
  }
  if (LifecycleResult r = startup_fault(nodes, "start-up"); !r.ok) return r;
  // 2. Pre-operational configuration by SDO.
  for (int j : nodes) {
    if (LifecycleResult r = configure_node(j); !r.ok) return r;
    if (LifecycleResult r = startup_fault(nodes, "start-up"); !r.ok) return r;
    joints_[static_cast<std::size_t>(j)].status.state = hal::DriveState::ready;
  }
  pump_until(monotonic_ns(), [] { return false; });  // what arrived after the last SDO answer
  return startup_fault(nodes, "start-up");
}

LifecycleResult CanHardware::enable_cia402(int b) {
  const Bus& bus = buses_[static_cast<std::size_t>(b)];
  std::vector<int> nodes;
  for (int k = 0; k < bus.count; ++k) {
    if (joints_[static_cast<std::size_t>(bus.joints[k])].cfg.protocol == Protocol::cia402) nodes.push_back(bus.joints[k]);
  }
  // 3. NMT start; SYNC every cycle from now on; TPDOs must appear.
  for (int j : nodes) {
    JointRuntime& jr = joints_[static_cast<std::size_t>(j)];
    jr.syncs_before_walk = bus.syncs_sent - jr.tpdo1_count;
    Frame f;
    cia402::encode_nmt(cia402::NmtCommand::start, jr.cfg.drive_id, f);
    send_now(b, f);
  }
  // 4. Walk the state machine with the controlword in RPDO1, target torque 0.
  // A step's time is the drive's: the cycles it answered in that state (cia402::StepClock).
  std::vector<cia402::State> state(nodes.size(), cia402::State::unknown);
  std::vector<cia402::StepClock> step(nodes.size(),
                                      cia402::StepClock(config_.timing.state_step_timeout_ms, config_.timing.tick_us));
  for (std::size_t i = 0; i < nodes.size(); ++i) {
    step[i].restart(joints_[static_cast<std::size_t>(nodes[i])].tpdo1_count, 0, monotonic_ns());
  }
  for (JointRuntime& jr : joints_) jr.statusword = 0;
  const std::int64_t period_ns = 1000LL * config_.timing.tick_us;
  std::int64_t next_cycle = monotonic_ns();
  for (;;) {
    bool all_enabled = true;
    for (std::size_t i = 0; i < nodes.size(); ++i) {
      JointRuntime& jr = joints_[static_cast<std::size_t>(nodes[i])];
      const cia402::State s = jr.replies_this_tick > 0 || jr.statusword != 0 ? cia402::decode_statusword(jr.statusword)
                                                                             : cia402::State::unknown;
      if (s != state[i]) {
        state[i] = s;
        step[i].restart(jr.tpdo1_count, unanswered_syncs(nodes[i]), monotonic_ns());
      } else if (s != cia402::State::operation_enabled && step[i].overdue(jr.tpdo1_count, monotonic_ns())) {
        return LifecycleResult::failure("CiA 402 enable: " + drive_name(nodes[i]) + " stuck in '" +
                                        cia402::to_string(s) + "' (statusword " + hex(jr.statusword, 4) + ") for " +
                                        std::to_string(config_.timing.state_step_timeout_ms) + " ms (" +
                                        std::to_string(step[i].cycles(jr.tpdo1_count)) + " SYNCs answered)");
      }
      all_enabled = all_enabled && s == cia402::State::operation_enabled;
      jr.controlword = cia402::controlword_towards_enabled(s, jr.controlword);
      jr.replies_this_tick = 0;
    }
    if (all_enabled) break;
    for (int j : nodes) {
      JointRuntime& jr = joints_[static_cast<std::size_t>(j)];
      Frame f;
      cia402::encode_rpdo1(jr.cfg.drive_id, cia402::Rpdo1{jr.controlword, 0}, f);
      send_now(b, f);
    }
    send_sync(b);
    const auto all_tpdo = [&] {
      for (int j : nodes) {
        if (joints_[static_cast<std::size_t>(j)].replies_this_tick == 0) return false;
      }
      return true;
    };
    // The TPDOs of this SYNC are awaited as a tick's replies are (rx_deadline_us), then the next
    // SYNC goes: a drive that missed one (its NMT start taken in its own cycle, a lost frame)
    // answers the next, and only a state held past state_step_timeout_ms fails.
    pump_until(monotonic_ns() + 1000LL * static_cast<std::int64_t>(config_.timing.rx_deadline_us), all_tpdo);
    if (LifecycleResult r = startup_fault(nodes, "enable"); !r.ok) return r;
    // One SYNC per tick: after a stall the cycles missed are skipped, not sent in a burst.
    next_cycle = std::max(next_cycle + period_ns, monotonic_ns());
    sleep_until_ns(next_cycle);
  }
  for (int j : nodes) joints_[static_cast<std::size_t>(j)].replies_this_tick = 0;
  return startup_fault(nodes, "enable");
}

// ---- recovery and shut-down -------------------------------------------------------------------------
LifecycleResult CanHardware::recover_bus(int b) {
  if (!configured_ || b < 0 || b >= bus_count_) return LifecycleResult::failure("recover_bus: no such bus");
  if (LifecycleResult r = open_bus(b); !r.ok) return r;
  if (LifecycleResult r = start_bus(b); !r.ok) return r;
  if (active_) {
    if (LifecycleResult r = enable_bus(b); !r.ok) return disable_after_failed_enable(b, b, std::move(r));
  }
  return LifecycleResult::success();
}

// CAN.md 4.4 step 2 for buses first..last, together: MIT exit motor mode (`...FD`) to every MIT
// drive; CiA 402 controlword 0x0007 (disable operation), then 0x0006 (shutdown), each in RPDO1
// followed by a SYNC on every bus every tick until every CiA 402 drive's statusword shows the step
// taken (left Operation enabled, then left Switched on too) or has spent state_step_timeout_ms on
// it (the bound on a step, 4.3 step 4, in the drive's cycles), then NMT enter pre-operational (`80 0`). A drive whose step
// takes longer than a tick (a brake to engage, a slow power stage) would otherwise be sent to
// Pre-operational, where no SYNC applies the step, and stay Operation enabled. The buses step
// together so that none goes without SYNC while another's drives are slow (a drive watching
// for lost communication, 0x6007, would fault). Enabled drives become ready and nothing more is
// sent for them. A faulted or closed bus cannot be reached: its drives rely on their own timeouts
// (CAN_TIMEOUT, 0x6007, 4.4 step 3). A bus with a configuration fault still carries frames, and
// one whose controller restarted after its bus-off carries them again: both are disabled like a
// healthy one (disabling resumes nothing).
void CanHardware::disable_buses(int first, int last) noexcept {
  const auto reachable = [&](int b) {
    const Bus& bus = buses_[static_cast<std::size_t>(b)];
    return bus.socket.is_open() && bus_reachable(bus.diag);
  };
  bool any_cia = false;
  for (int b = first; b <= last; ++b) {
    Bus& bus = buses_[static_cast<std::size_t>(b)];
    bus.synced = false;
    if (!reachable(b)) continue;
    any_cia = any_cia || bus.any_cia;
    // Ready before the steps: a TPDO that shows one taken is no drive leaving Operation enabled.
    for (int k = 0; k < bus.count; ++k) {
      JointRuntime& jr = joints_[static_cast<std::size_t>(bus.joints[k])];
      if (jr.status.state == hal::DriveState::enabled) jr.status.state = hal::DriveState::ready;
    }
  }
  // Each drive's step time is its own answered cycles (cia402::StepClock), as in the walk.
  std::array<cia402::StepClock, kNj> step{};
  // The step is over when every CiA 402 drive of a reachable bus has taken it or is overdue.
  const auto step_over = [&](std::uint16_t cw) {
    for (int b = first; b <= last; ++b) {
      if (!reachable(b)) continue;
      const Bus& bus = buses_[static_cast<std::size_t>(b)];
      for (int k = 0; k < bus.count; ++k) {
        const int j = bus.joints[k];
        const JointRuntime& jr = joints_[static_cast<std::size_t>(j)];
        if (jr.cfg.protocol != Protocol::cia402) continue;
        const cia402::State s = cia402::decode_statusword(jr.statusword);
        const bool taken = s != cia402::State::operation_enabled &&
                           (cw != cia402::controlword::shutdown || s != cia402::State::switched_on);
        if (!taken && !step[static_cast<std::size_t>(j)].overdue(jr.tpdo1_count, monotonic_ns())) return false;
      }
    }
    return true;
  };
  for (const std::uint16_t cw : {cia402::controlword::disable_operation, cia402::controlword::shutdown}) {
    if (!any_cia) break;
    for (int j = 0; j < kNj; ++j) {
      const JointRuntime& jr = joints_[static_cast<std::size_t>(j)];
      step[static_cast<std::size_t>(j)] = cia402::StepClock(config_.timing.state_step_timeout_ms, config_.timing.tick_us);
      step[static_cast<std::size_t>(j)].restart(jr.tpdo1_count, unanswered_syncs(j), monotonic_ns());
    }
    do {
      for (int b = first; b <= last; ++b) {
        const Bus& bus = buses_[static_cast<std::size_t>(b)];
        if (!bus.any_cia || !reachable(b)) continue;
        for (int k = 0; k < bus.count; ++k) {
          const JointRuntime& jr = joints_[static_cast<std::size_t>(bus.joints[k])];
          if (jr.cfg.protocol != Protocol::cia402) continue;
          Frame f;
          cia402::encode_rpdo1(jr.cfg.drive_id, cia402::Rpdo1{cw, 0}, f);
          send_now(b, f);
        }
        send_sync(b);
      }
      pump_until(monotonic_ns() + 1000LL * config_.timing.tick_us, [] { return false; });
    } while (!step_over(cw));
  }
  for (int b = first; b <= last; ++b) {
    Bus& bus = buses_[static_cast<std::size_t>(b)];
    if (!reachable(b)) continue;
    for (int k = 0; k < bus.count; ++k) {
      JointRuntime& jr = joints_[static_cast<std::size_t>(bus.joints[k])];
      if (jr.cfg.protocol == Protocol::mit) {
        Frame f;
        mit::encode_special(jr.cfg.drive_id, mit::Special::exit_motor_mode, f);
        send_now(b, f);
      }
      jr.has_pending = false;
      jr.awaiting = false;
    }
    if (bus.any_cia) {
      Frame f;
      cia402::encode_nmt(cia402::NmtCommand::enter_pre_operational, 0, f);
      send_now(b, f);
    }
  }
}

void CanHardware::deactivate() noexcept {
  if (!active_) return;
  // 1. Damping: tau = -D qd until slow or T_damp (CAN.md 4.4).
  hal::JointCommands damping;
  damping.mode = hal::CommandMode::enabled;
  damping.kd_nms_per_rad.setConstant(config_.timing.damping_kd_nms_per_rad);
  hal::Measurements m;
  const std::int64_t period_ns = 1000LL * config_.timing.tick_us;
  const std::int64_t end_ns = monotonic_ns() + 1000000LL * config_.timing.damping_time_ms;
  std::int64_t next = monotonic_ns();
  while (monotonic_ns() < end_ns) {
    (void)read(m);
    bool slow = true;
    for (int j = 0; j < kNj; ++j) {
      const hal::DriveState s = m.drives[static_cast<std::size_t>(j)].state;
      if (s == hal::DriveState::enabled && std::abs(m.qd_rad_s[j]) >= config_.timing.damping_stop_speed_rad_s) slow = false;
    }
    if (slow && tick_ > 1) break;
    (void)write(damping);
    next += period_ns;
    sleep_until_ns(next);
  }
  // 2. Disable. 3. Stop sending.
  disable_buses(0, bus_count_ - 1);
  // Let the last replies arrive so they do not count against a later start-up.
  pump_until(monotonic_ns() + 20000000LL, [] { return false; });
  active_ = false;
}

}  // namespace springbok::can
