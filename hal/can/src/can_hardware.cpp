// The tick path of the SocketCAN backend: frame processing, reply accounting,
// sending. Start-up and shut-down are in can_startup.cpp.
#include "springbok/can/can_hardware.hpp"

#include <algorithm>
#include <cerrno>
#include <cmath>

#include "springbok/can/bus_load.hpp"

namespace springbok::can {

namespace {
// Fault codes for DriveStatus::fault_code when the drive itself gave none.
constexpr std::uint16_t kFaultImplausible = 0xFF01;   // position jumps twice in a row
constexpr std::uint16_t kFaultStatusword = 0x1000;    // CiA 402 fault bit without an EMCY (generic error)
constexpr std::uint16_t kFaultLeftEnabled = 0xFF02;   // CiA 402 drive left Operation enabled
}  // namespace

const char* to_string(BusFault f) noexcept {
  switch (f) {
    case BusFault::none: return "none";
    case BusFault::bus_off: return "bus-off";
    case BusFault::restarted: return "controller restarted after bus-off";
    case BusFault::net_down: return "network down (ENETDOWN)";
    case BusFault::tx_queue_full: return "transmit queue full (ENOBUFS) on consecutive ticks";
    case BusFault::socket_error: return "socket error";
    case BusFault::no_ack: return "no acknowledge";
    case BusFault::foreign_drive: return "configuration fault: a frame of a drive configured on another bus (CAN.md 4.1)";
  }
  return "?";
}

bool bus_commanded(BusFault f) noexcept { return f == BusFault::none || f == BusFault::foreign_drive; }

bool bus_reachable(const BusDiagnostics& d) noexcept {
  return bus_commanded(d.fault) || ((d.fault == BusFault::bus_off || d.fault == BusFault::restarted) && d.controller_restarted);
}

CanHardware::CanHardware(CanConfig config) : config_(std::move(config)) {}

CanHardware::~CanHardware() {
  deactivate();
  for (Bus& b : buses_) b.socket.close();
}

int CanHardware::handles(std::array<int, kMaxBuses>& out) const noexcept {
  int n = 0;
  for (int b = 0; b < bus_count_; ++b) {
    if (buses_[b].socket.is_open()) out[static_cast<std::size_t>(n++)] = buses_[b].socket.native_handle();
  }
  return n;
}

int CanHardware::find_joint(int b, std::uint8_t drive_id, Protocol p) const noexcept {
  const Bus& bus = buses_[static_cast<std::size_t>(b)];
  for (int k = 0; k < bus.count; ++k) {
    const JointRuntime& jr = joints_[static_cast<std::size_t>(bus.joints[k])];
    if (jr.cfg.drive_id == drive_id && jr.cfg.protocol == p) return bus.joints[k];
  }
  return -1;
}

int CanHardware::find_foreign_joint(int b, std::uint8_t drive_id) const noexcept {
  for (int j = 0; j < kNj; ++j) {
    const JointRuntime& jr = joints_[static_cast<std::size_t>(j)];
    if (jr.bus >= 0 && jr.bus != b && jr.cfg.drive_id == drive_id) return j;
  }
  return -1;
}

BusFault record_foreign_frame(const Frame& f, std::uint8_t drive_id, BusDiagnostics& d) noexcept {
  if (d.foreign_frames++ == 0) {
    d.foreign_drive_id = drive_id;
    d.foreign_can_id = f.id;
  }
  return BusFault::foreign_drive;
}

void CanHardware::latch_fault(int j, std::uint16_t code) noexcept {
  hal::DriveStatus& s = joints_[static_cast<std::size_t>(j)].status;
  if (s.state == hal::DriveState::fault) return;  // keep the first code
  s.state = hal::DriveState::fault;
  s.fault_code = code;
}

void CanHardware::fault_bus(int b, BusFault why) noexcept {
  Bus& bus = buses_[static_cast<std::size_t>(b)];
  if (bus.diag.fault == BusFault::none) bus.diag.fault = why;
  for (int k = 0; k < bus.count; ++k) {
    JointRuntime& jr = joints_[static_cast<std::size_t>(bus.joints[k])];
    if (jr.status.state != hal::DriveState::fault) jr.status.state = hal::DriveState::lost;
    jr.awaiting = false;
  }
}

bool CanHardware::accept_position(int j, double q_rad) noexcept {
  JointRuntime& jr = joints_[static_cast<std::size_t>(j)];
  if (!jr.have_state || jr.status.state != hal::DriveState::enabled) return true;
  // CAN.md 4.1: |dq| > v_max * dt * (age + 1) is implausible (plus two position LSBs).
  const double v_max = robot::kJoints[static_cast<std::size_t>(j)].limits.velocity_rad_s;
  const double dt_s = 1e-6 * config_.timing.tick_us;
  const double age = static_cast<double>(tick_ - jr.last_rx_tick);
  const double lsb = jr.cfg.protocol == Protocol::mit
                         ? (jr.cfg.mit_ranges.p_max_rad - jr.cfg.mit_ranges.p_min_rad) / 65535.0
                         : 1.0 / jr.cfg.counts_per_rad;
  if (std::abs(q_rad - jr.q_rad) <= v_max * dt_s * (age + 1.0) + 2.0 * lsb) {
    jr.implausible_in_row = 0;
    return true;
  }
  ++buses_[static_cast<std::size_t>(jr.bus)].diag.bad_frames;
  if (++jr.implausible_in_row >= 2) latch_fault(j, kFaultImplausible);
  return false;
}

bool CanHardware::is_mit_reply_id(int b, std::uint32_t id) const noexcept {
  const Bus& bus = buses_[static_cast<std::size_t>(b)];
  if (!bus.any_mit) return false;
  if (id == kMitFactoryMasterId) return true;
  for (int k = 0; k < bus.count; ++k) {
    const JointRuntime& jr = joints_[static_cast<std::size_t>(bus.joints[k])];
    if (jr.cfg.protocol == Protocol::mit && jr.cfg.mit_reply_id == id) return true;
  }
  return false;
}

void CanHardware::process_mit_reply(int b, const Frame& f) noexcept {
  Bus& bus = buses_[static_cast<std::size_t>(b)];
  // Byte 0 (the drive id) is authoritative and picks the ranges to decode with.
  if (f.len < 1) {
    ++bus.diag.bad_frames;
    return;
  }
  const int j = find_joint(b, f.data[0], Protocol::mit);
  if (j < 0) {
    // Byte 0 is authoritative (CAN.md 1.4): a valid reply naming a drive of another bus is a
    // configuration fault (4.1), one naming no drive of the robot is only counted.
    const int other = find_foreign_joint(b, f.data[0]);
    mit::Reply r;
    if (other < 0) {
      ++bus.diag.unexpected_frames;
    } else if (mit::decode_reply(f, joints_[static_cast<std::size_t>(other)].cfg.mit_ranges, r) != FrameStatus::ok) {
      ++bus.diag.bad_frames;
    } else {
      fault_bus(b, record_foreign_frame(f, f.data[0], bus.diag));
    }
    return;
  }
  JointRuntime& jr = joints_[static_cast<std::size_t>(j)];
  mit::Reply r;
  // DLC 6, 7 or 8 whatever the drive type (CAN.md 1.4); bytes 6..7 of 8 only for a vendor drive.
  if (const FrameStatus s = mit::decode_reply(f, jr.cfg.mit_ranges, r); s != FrameStatus::ok) {
    ++bus.diag.bad_frames;
    if (s == FrameStatus::wrong_dlc) {
      ++jr.wrong_dlc_replies;
      jr.wrong_dlc_len = f.len;
    }
    return;
  }
  if (!accept_position(j, r.p_rad)) return;
  if (jr.replies_this_tick > 0) ++bus.diag.duplicates;  // keep the newest
  ++jr.replies_this_tick;
  // A duplicate in the same tick restarts nothing: it updates with the same dt as the first.
  const double dt_s = jr.have_state ? static_cast<double>(tick_ - jr.last_rx_tick) * 1e-6 * config_.timing.tick_us : -1.0;
  jr.qd_rad_s = jr.velocity.update(r.p_rad, r.v_rad_s, dt_s);
  jr.q_rad = r.p_rad;
  jr.tau_nm = r.t_nm;
  jr.have_state = true;
  jr.last_rx_tick = tick_;
  if (jr.cfg.mit_vendor_reply && r.has_vendor_bytes && r.error_code != 0) {
    if (jr.startup_fault_code == 0) jr.startup_fault_code = r.error_code;  // start-up fails on it
    latch_fault(j, r.error_code);
  }
  if (r.has_bus_voltage) check_bus_voltage(j, r.bus_voltage_v);
}

void CanHardware::check_bus_voltage(int j, double v) noexcept {
  JointRuntime& jr = joints_[static_cast<std::size_t>(j)];
  jr.status.bus_voltage_v = v;
  jr.status.bus_voltage_low = config_.mit_bus_voltage_warning_v > 0.0 && v < config_.mit_bus_voltage_warning_v;
  if (config_.mit_bus_voltage_fault_v > 0.0 && v < config_.mit_bus_voltage_fault_v) {
    if (jr.startup_fault_code == 0) jr.startup_fault_code = kFaultBusUndervoltage;  // start-up fails on it
    latch_fault(j, kFaultBusUndervoltage);
  }
}

void CanHardware::process_cia402_frame(int b, const Frame& f) noexcept {
  Bus& bus = buses_[static_cast<std::size_t>(b)];
  const auto node = static_cast<std::uint8_t>(f.id & 0x7F);
  const std::uint32_t function = f.id & 0x780;
  const int j = find_joint(b, node, Protocol::cia402);
  if (j < 0) {
    // The bus's CAN_RAW_FILTER passes only its own nodes' COB-IDs, so a node of another bus
    // cannot show here; should one, it is the configuration fault of CAN.md 4.1.
    if (find_foreign_joint(b, node) >= 0) {
      fault_bus(b, record_foreign_frame(f, node, bus.diag));
    } else {
      ++bus.diag.unexpected_frames;
    }
    return;
  }
  JointRuntime& jr = joints_[static_cast<std::size_t>(j)];
  switch (function) {
    case cia402::cob::emcy: {
      cia402::Emcy e;
      if (cia402::decode_emcy(f, node, e) != FrameStatus::ok) {
        ++bus.diag.bad_frames;
        return;
      }
      if (e.error_code != 0) {
        if (jr.startup_fault_code == 0) jr.startup_fault_code = e.error_code;  // start-up fails on it
        latch_fault(j, e.error_code);
      }
      return;
    }
    case cia402::cob::tpdo1: {
      cia402::Feedback fb;
      if (cia402::decode_tpdo1(f, node, jr.cfg.mapping, fb) != FrameStatus::ok) {
        ++bus.diag.bad_frames;
        return;
      }
      const double q_rad = static_cast<double>(fb.position) / jr.cfg.counts_per_rad;
      if (!accept_position(j, q_rad)) return;
      if (jr.replies_this_tick > 0) ++bus.diag.duplicates;
      ++jr.replies_this_tick;
      ++jr.tpdo1_count;
      if (jr.cfg.mapping == cia402::Mapping::compact) {
        // No velocity object in the compact mapping: the position difference over the reply age.
        const double age_ticks = static_cast<double>(std::max<std::uint64_t>(1, tick_ - jr.last_rx_tick));
        jr.qd_rad_s = jr.have_state ? (q_rad - jr.q_rad) / (age_ticks * 1e-6 * config_.timing.tick_us) : 0.0;
        jr.tau_nm = cia402::permille_to_torque(fb.torque, jr.torque_scale);
      }
      jr.q_rad = q_rad;
      jr.have_state = true;
      jr.last_rx_tick = tick_;
      jr.statusword = fb.statusword;
      const cia402::State s = cia402::decode_statusword(fb.statusword);
      if (s == cia402::State::fault || s == cia402::State::fault_reaction_active) {
        latch_fault(j, kFaultStatusword);
      } else if (jr.status.state == hal::DriveState::enabled && s != cia402::State::operation_enabled) {
        latch_fault(j, kFaultLeftEnabled);
      }
      return;
    }
    case cia402::cob::tpdo2: {
      cia402::Feedback fb;
      if (jr.cfg.mapping != cia402::Mapping::two_tpdo || cia402::decode_tpdo2(f, node, fb) != FrameStatus::ok) {
        ++bus.diag.bad_frames;
        return;
      }
      jr.qd_rad_s = static_cast<double>(fb.velocity) / jr.cfg.velocity_units_per_rad_s;
      jr.tau_nm = cia402::permille_to_torque(fb.torque, jr.torque_scale);
      jr.tpdo2_this_tick = true;
      return;
    }
    case cia402::cob::sdo_response:
      jr.sdo_answer = f;
      jr.sdo_answered = true;
      return;
    case cia402::cob::heartbeat: {
      cia402::NmtState st{};
      if (cia402::decode_heartbeat(f, node, st) != FrameStatus::ok) {
        ++bus.diag.bad_frames;
        return;
      }
      jr.last_heartbeat_tick = tick_;
      if (st == cia402::NmtState::boot_up) {
        jr.booted = true;
      } else {
        jr.heartbeat_seen = true;
      }
      // A drive that rebooted or left Operational no longer follows the PDOs.
      if (jr.status.state == hal::DriveState::enabled && st != cia402::NmtState::operational) {
        jr.status.state = hal::DriveState::lost;
      }
      return;
    }
    default:
      ++bus.diag.unexpected_frames;
      return;
  }
}

BusFault record_error_frame(const Frame& f, BusDiagnostics& d) noexcept {
  ++d.error_frames;
  const ErrorFrameInfo e = classify_error_frame(f);
  if (e.warning) ++d.warnings;
  if (e.error_passive) {
    d.error_passive = true;
    ++d.error_passive_events;
  }
  if (e.back_to_active) d.error_passive = false;
  if (e.overflow) ++d.overflows;
  if (e.has_counters) {
    d.have_error_counters = true;
    d.tx_error_counter = e.tx_errors;
    d.rx_error_counter = e.rx_errors;
  }
  // CAN_ERR_ACK / TX_TIMEOUT / TRX act like a silent bus: the missing replies count.
  if (e.bus_off) {
    d.controller_restarted = false;
    return BusFault::bus_off;
  }
  if (!e.restarted) return BusFault::none;
  d.controller_restarted = true;
  return BusFault::restarted;
}

void CanHardware::process_error_frame(int b, const Frame& f) noexcept {
  const BusFault fault = record_error_frame(f, buses_[static_cast<std::size_t>(b)].diag);
  if (fault != BusFault::none) fault_bus(b, fault);
}

bool CanHardware::process_sensor_frame(int b, const Frame& f) noexcept {
  Bus& bus = buses_[static_cast<std::size_t>(b)];
  if (bus.has_imu && imu_.frame_index(f.id) >= 0) {
    ++bus.diag.sensor_frames;
    if (imu_.push(f, tick_) == SensorEvent::accepted) imu_stamp_ns_ = monotonic_ns();
    return true;
  }
  if (bus.has_ft && ft_.frame_index(f.id) >= 0) {
    ++bus.diag.sensor_frames;
    if (ft_.push(f, tick_) == SensorEvent::accepted) ft_stamp_ns_ = monotonic_ns();
    return true;
  }
  return false;
}

void CanHardware::process_frame(int b, const Frame& f) noexcept {
  if (f.error) {
    process_error_frame(b, f);
    return;
  }
  if (process_sensor_frame(b, f)) return;
  const Bus& bus = buses_[static_cast<std::size_t>(b)];
  if (is_mit_reply_id(b, f.id)) {
    process_mit_reply(b, f);
  } else if (bus.any_cia) {
    process_cia402_frame(b, f);
  } else {
    ++buses_[static_cast<std::size_t>(b)].diag.unexpected_frames;
  }
}

bool CanHardware::drain(int b, int max_frames) noexcept {
  Bus& bus = buses_[static_cast<std::size_t>(b)];
  Frame f;
  for (int n = 0; n < max_frames; ++n) {
    const RxStatus s = bus.socket.receive(f);
    if (s == RxStatus::empty) return true;
    if (s == RxStatus::error) {
      if (bus.socket.last_errno() == ENETDOWN) fault_bus(b, BusFault::net_down);
      ++bus.diag.tx_errors;
      return true;
    }
    ++bus.diag.frames_received;
    process_frame(b, f);
  }
  return false;
}

namespace {
// The status fields hal::Imu and hal::Wrench share, from the sensor's diagnostics. rt: no alloc
template <class Sensor>
void fill_sensor_status(const SensorDiagnostics& d, bool usable, std::int64_t stamp_ns, Sensor& out) noexcept {
  out.valid = usable;
  out.lost = d.lost;
  out.clipping = (d.last_status & sensor_status::clipping) != 0;
  out.clip_streak = d.clip_streak_fault;
  out.age_ticks = static_cast<std::uint32_t>(std::min<std::uint64_t>(d.age_ticks, 0xFFFFFFFFu));
  out.stamp_ns = stamp_ns;
}

// A sensor brought up to `tick` (its staleness), its status into `out`, `ready` from its
// diagnostics (the IMU's converged, the F/T's bias taken), and its newest reading through
// `fill_reading` when it is usable. rt: no alloc
template <class Decoder, class Sensor, class FillReading>
void fill_sensor(Decoder& sensor, std::uint64_t tick, std::int64_t stamp_ns, Sensor& out, bool& ready,
                 FillReading&& fill_reading) noexcept {
  sensor.update(tick);
  fill_sensor_status(sensor.diagnostics(), sensor.usable(), stamp_ns, out);
  ready = !sensor.diagnostics().not_ready;
  if (out.valid) fill_reading(sensor.reading());
}
}  // namespace

void CanHardware::fill_sensors(hal::Measurements& out) noexcept {
  if (config_.sensors.imu.enabled) {
    fill_sensor(imu_, tick_, imu_stamp_ns_, out.imu, out.imu.converged, [&out](const ImuReading& r) noexcept {
      out.imu.orientation = r.orientation;
      out.imu.angular_rate_rad_s = r.angular_rate_rad_s;
      out.imu.linear_accel_m_s2 = r.linear_accel_m_s2;
    });
  }
  if (config_.sensors.wrist_ft.enabled) {
    fill_sensor(ft_, tick_, ft_stamp_ns_, out.wrist, out.wrist.bias_taken, [&out](const FtReading& r) noexcept {
      out.wrist.force_n = r.force_n;
      out.wrist.torque_nm = r.torque_nm;
    });
  }
}

bool CanHardware::replies_complete() const noexcept {
  for (const JointRuntime& jr : joints_) {
    if (!jr.awaiting) continue;
    if (jr.replies_this_tick == 0) return false;
    if (jr.cfg.protocol == Protocol::cia402 && jr.cfg.mapping == cia402::Mapping::two_tpdo && !jr.tpdo2_this_tick) {
      return false;
    }
  }
  return true;
}

void CanHardware::evaluate_joints() noexcept {
  for (JointRuntime& jr : joints_) {
    if (jr.bus < 0) continue;
    hal::DriveStatus& s = jr.status;
    if (jr.awaiting) {
      const bool fresh = jr.replies_this_tick > 0 &&
                         (jr.cfg.protocol == Protocol::mit || jr.cfg.mapping == cia402::Mapping::compact ||
                          jr.tpdo2_this_tick);
      s.fresh = fresh;
      if (fresh) {
        s.missed_in_row = 0;
      } else {
        ++s.missed_in_row;
        ++s.missed_total;
        if (s.missed_in_row > config_.timing.missed_replies_lost && s.state == hal::DriveState::enabled) {
          s.state = hal::DriveState::lost;
        }
      }
    } else {
      s.fresh = false;
    }
    if (active_ && jr.cfg.protocol == Protocol::cia402 && s.state == hal::DriveState::enabled &&
        tick_ - jr.last_heartbeat_tick > heartbeat_lost_ticks_) {
      s.state = hal::DriveState::lost;  // CAN.md 4.1: heartbeat missing for 3 periods
    }
    jr.awaiting = false;
    jr.replies_this_tick = 0;
    jr.tpdo2_this_tick = false;
  }
}

bool CanHardware::send_now(int b, const Frame& f) noexcept {
  Bus& bus = buses_[static_cast<std::size_t>(b)];
  // On a CAN FD bus the drives speak MIT-style frames as FD frames with the bit-rate
  // switch (CAN.md 3.2-3.3): seven classic commands would not fit in a tick.
  Frame fd_frame;
  const Frame* out = &f;
  if (config_.buses[static_cast<std::size_t>(b)].fd && !f.fd && !f.error) {
    fd_frame = f;
    fd_frame.fd = true;
    out = &fd_frame;
  }
  const TxStatus s = bus.socket.send(*out);
  bus.tx_full.record(s);
  switch (s) {
    case TxStatus::ok: ++bus.diag.frames_sent; return true;
    case TxStatus::queue_full:
    case TxStatus::buffer_full: ++bus.diag.tx_dropped; return false;
    case TxStatus::net_down: fault_bus(b, BusFault::net_down); return false;
    case TxStatus::short_write: ++bus.diag.short_writes; return false;
    case TxStatus::error: ++bus.diag.tx_errors; return false;
  }
  return false;
}

bool CanHardware::send_sync(int b) noexcept {
  Frame sync;
  cia402::encode_sync(sync);
  if (!send_now(b, sync)) return false;
  ++buses_[static_cast<std::size_t>(b)].syncs_sent;
  return true;
}

std::uint64_t CanHardware::unanswered_syncs(int j) const noexcept {
  const JointRuntime& jr = joints_[static_cast<std::size_t>(j)];
  if (jr.bus < 0) return 0;  // on no bus
  const std::uint64_t sent = buses_[static_cast<std::size_t>(jr.bus)].syncs_sent - jr.syncs_before_walk;
  return sent > jr.tpdo1_count ? sent - jr.tpdo1_count : 0;
}

void CanHardware::send_pending() noexcept {
  for (int b = 0; b < bus_count_; ++b) {
    Bus& bus = buses_[static_cast<std::size_t>(b)];
    if (!bus_commanded(bus.diag.fault) || !bus.socket.is_open()) continue;
    bus.tx_full.begin_tick();
    for (int k = 0; k < bus.count; ++k) {
      JointRuntime& jr = joints_[static_cast<std::size_t>(bus.joints[k])];
      if (!jr.has_pending) continue;
      if (bus.tx_full.dropping()) {
        ++bus.diag.tx_dropped;
        continue;
      }
      if (send_now(b, jr.pending) && jr.cfg.protocol == Protocol::mit) jr.awaiting = true;
    }
    if (bus.any_cia) {
      if (bus.tx_full.dropping()) {
        ++bus.diag.tx_dropped;
      } else if (send_sync(b)) {
        for (int k = 0; k < bus.count; ++k) {
          JointRuntime& jr = joints_[static_cast<std::size_t>(bus.joints[k])];
          if (jr.cfg.protocol == Protocol::cia402) jr.awaiting = true;
        }
      }
    }
    if (bus.tx_full.end_tick(config_.timing.tx_fault_ticks)) fault_bus(b, BusFault::tx_queue_full);
  }
}

hal::IoStatus CanHardware::read(hal::Measurements& out) noexcept {
  if (!configured_) return hal::IoStatus::error;
  ++tick_;
  for (int b = 0; b < bus_count_; ++b) buses_[static_cast<std::size_t>(b)].rx_budget = kMaxRxFramesPerBusPerTick;
  std::array<int, kMaxBuses> fds{};
  const std::int64_t deadline_ns = last_send_ns_ + 1000LL * config_.timing.rx_deadline_us;
  for (;;) {
    int n_fds = 0;  // the buses that may still be read this tick
    for (int b = 0; b < bus_count_; ++b) {
      Bus& bus = buses_[static_cast<std::size_t>(b)];
      if (!bus.socket.is_open() || bus.rx_budget <= 0) continue;
      const std::uint64_t before = bus.diag.frames_received;
      const bool emptied = drain(b, bus.rx_budget);
      bus.rx_budget -= static_cast<int>(bus.diag.frames_received - before);
      if (!emptied) {
        bus.rx_budget = 0;
        ++bus.diag.rx_budget_exhausted;  // the rest waits for the next tick
        continue;
      }
      fds[static_cast<std::size_t>(n_fds++)] = bus.socket.native_handle();
    }
    const std::int64_t now_ns = monotonic_ns();
    if (replies_complete() || now_ns >= deadline_ns || n_fds == 0) break;
    wait_readable(std::span<const int>(fds.data(), static_cast<std::size_t>(n_fds)), (deadline_ns - now_ns) / 1000 + 1);
  }
  evaluate_joints();

  out.sequence = ++sequence_;
  out.stamp_ns = monotonic_ns();
  int fresh = 0, expected = 0;
  bool bus_fault = false;
  for (int j = 0; j < kNj; ++j) {
    const JointRuntime& jr = joints_[static_cast<std::size_t>(j)];
    out.q_rad[j] = jr.q_rad;
    out.qd_rad_s[j] = jr.qd_rad_s;
    out.tau_nm[j] = jr.tau_nm;
    out.drives[static_cast<std::size_t>(j)] = jr.status;
    if (jr.bus < 0) continue;
    ++expected;
    fresh += jr.status.fresh ? 1 : 0;
  }
  static_assert(kMaxBuses <= 32, "hal::Measurements::degraded_buses has a bit per bus");
  out.degraded_buses = 0;
  for (int b = 0; b < bus_count_; ++b) {
    const Bus& bus = buses_[static_cast<std::size_t>(b)];
    bus_fault = bus_fault || (bus.count > 0 && bus.diag.fault != BusFault::none);  // sensors-only: its sensors go lost
    if (bus.diag.error_passive) out.degraded_buses |= 1u << b;
  }
  fill_sensors(out);

  if (active_) {
    send_pending();
    last_send_ns_ = monotonic_ns();
  }
  if (bus_fault) return hal::IoStatus::error;
  if (fresh == expected) return hal::IoStatus::ok;
  return fresh == 0 ? hal::IoStatus::timeout : hal::IoStatus::partial;
}

void CanHardware::queue_zero_command(int j) noexcept {
  JointRuntime& jr = joints_[static_cast<std::size_t>(j)];
  if (jr.cfg.protocol == Protocol::mit) {
    (void)mit::encode_command(jr.cfg.drive_id, mit::Command{}, jr.cfg.mit_ranges, jr.pending);
  } else {
    jr.controlword = cia402::controlword::enable_operation;
    cia402::encode_rpdo1(jr.cfg.drive_id, cia402::Rpdo1{jr.controlword, 0}, jr.pending);
  }
  jr.has_pending = true;
}

void CanHardware::queue_command(int j, const hal::JointCommands& cmd) noexcept {
  JointRuntime& jr = joints_[static_cast<std::size_t>(j)];
  if (cmd.mode != hal::CommandMode::enabled) {
    queue_zero_command(j);
    return;
  }
  if (jr.cfg.protocol == Protocol::mit) {
    const mit::Command c{cmd.q_des_rad[j], cmd.qd_des_rad_s[j], cmd.kp_nm_per_rad[j], cmd.kd_nms_per_rad[j],
                         cmd.tau_ff_nm[j]};
    if (mit::encode_command(jr.cfg.drive_id, c, jr.cfg.mit_ranges, jr.pending) != FrameStatus::ok) {
      ++rejected_commands_;
      queue_zero_command(j);
      return;
    }
    jr.has_pending = true;
    return;
  }
  // CiA 402 in CST: the impedance law runs on the host from the last measured state.
  const double tau_nm = hal::drive_torque_nm(cmd, j, jr.q_rad, jr.qd_rad_s);
  if (!std::isfinite(tau_nm)) {
    ++rejected_commands_;
    queue_zero_command(j);
    return;
  }
  jr.controlword = cia402::controlword::enable_operation;
  const std::int16_t permille = cia402::torque_to_permille(tau_nm, jr.torque_scale);
  cia402::encode_rpdo1(jr.cfg.drive_id, cia402::Rpdo1{jr.controlword, permille}, jr.pending);
  jr.has_pending = true;
}

hal::IoStatus CanHardware::write(const hal::JointCommands& cmd) noexcept {
  if (!active_) return hal::IoStatus::error;
  const std::uint64_t rejected_before = rejected_commands_;
  for (int j = 0; j < kNj; ++j) {
    if (joints_[static_cast<std::size_t>(j)].bus >= 0) queue_command(j, cmd);
  }
  return rejected_commands_ == rejected_before ? hal::IoStatus::ok : hal::IoStatus::error;
}

std::string bus_diagnostics_line(const BusConfig& bus, const BusDiagnostics& d) {
  const auto counter = [&](std::uint8_t c) { return d.have_error_counters ? std::to_string(c) : std::string("-"); };
  const auto n = [](std::uint64_t v) { return static_cast<unsigned long long>(v); };
  char foreign_drive[8] = "-", foreign_id[16] = "-";  // the first frame naming a drive of another bus
  if (d.foreign_frames > 0) {
    std::snprintf(foreign_drive, sizeof foreign_drive, "%u", static_cast<unsigned>(d.foreign_drive_id));
    std::snprintf(foreign_id, sizeof foreign_id, "0x%03X", static_cast<unsigned>(d.foreign_can_id));
  }
  char line[896];
  std::snprintf(line, sizeof line,
                "can bus %s: fault=%s%s sent=%llu received=%llu tx_dropped=%llu short_writes=%llu tx_errors=%llu "
                "rx_budget_exhausted=%llu bad_frames=%llu unexpected=%llu foreign=%llu foreign_drive=%s "
                "foreign_id=%s duplicates=%llu "
                "sensor_frames=%llu error_frames=%llu warnings=%llu overflows=%llu error_passive=%d "
                "error_passive_events=%llu tx_error_counter=%s rx_error_counter=%s\n",
                (bus.name + " (" + bus.interface + ")").c_str(), to_string(d.fault),
                d.controller_restarted && d.fault == BusFault::bus_off ? " (the controller restarted since)" : "",
                n(d.frames_sent),
                n(d.frames_received), n(d.tx_dropped), n(d.short_writes), n(d.tx_errors), n(d.rx_budget_exhausted),
                n(d.bad_frames), n(d.unexpected_frames), n(d.foreign_frames),
                foreign_drive, foreign_id, n(d.duplicates),
                n(d.sensor_frames),
                n(d.error_frames), n(d.warnings), n(d.overflows), d.error_passive ? 1 : 0, n(d.error_passive_events),
                counter(d.tx_error_counter).c_str(), counter(d.rx_error_counter).c_str());
  return line;
}

std::string CanHardware::diagnostics_report() const {
  std::string out = startup_notes_;
  char line[512];
  for (int b = 0; b < bus_count_; ++b) {
    out += bus_diagnostics_line(config_.buses[static_cast<std::size_t>(b)], diagnostics(b));
    // Per MIT drive, what its replies said beyond the joint state: its bus voltage (7-byte
    // replies), the replies of a length CAN.md 1.4 does not allow.
    const Bus& bus = buses_[static_cast<std::size_t>(b)];
    for (int k = 0; k < bus.count; ++k) {
      const JointRuntime& jr = joints_[static_cast<std::size_t>(bus.joints[k])];
      if (jr.cfg.protocol != Protocol::mit || (jr.status.bus_voltage_v <= 0.0 && jr.wrong_dlc_replies == 0)) continue;
      std::snprintf(line, sizeof line, "can drive %u (%s): bus_voltage_v=%.2f bus_voltage_low=%d wrong_dlc_replies=%llu%s\n",
                    static_cast<unsigned>(jr.cfg.drive_id),
                    std::string(robot::kJoints[static_cast<std::size_t>(bus.joints[k])].name).c_str(),
                    jr.status.bus_voltage_v, jr.status.bus_voltage_low ? 1 : 0,
                    static_cast<unsigned long long>(jr.wrong_dlc_replies),
                    jr.wrong_dlc_replies > 0 ? (" last_dlc=" + std::to_string(jr.wrong_dlc_len)).c_str() : "");
      out += line;
    }
  }
  const auto sensor = [&](const char* name, bool enabled, const SensorDiagnostics& d) {
    if (!enabled) return;
    std::snprintf(line, sizeof line,
                  "can sensor %s: frames=%llu accepted=%llu wrong_dlc=%llu reserved_bits=%llu status_invalid=%llu "
                  "bad_quaternion=%llu counter_jumps=%llu stale_counters=%llu late_frames=%llu "
                  "incomplete_dropped=%llu clipped=%llu clip_streak_max=%u\n",
                  name, static_cast<unsigned long long>(d.frames), static_cast<unsigned long long>(d.samples_accepted),
                  static_cast<unsigned long long>(d.wrong_dlc), static_cast<unsigned long long>(d.reserved_bits),
                  static_cast<unsigned long long>(d.status_invalid), static_cast<unsigned long long>(d.bad_quaternion),
                  static_cast<unsigned long long>(d.counter_jumps), static_cast<unsigned long long>(d.stale_counters),
                  static_cast<unsigned long long>(d.late_frames), static_cast<unsigned long long>(d.incomplete_dropped),
                  static_cast<unsigned long long>(d.clipped), d.clip_streak_max);
    out += line;
  };
  sensor("imu", config_.sensors.imu.enabled, imu_diagnostics());
  sensor("wrist_ft", config_.sensors.wrist_ft.enabled, wrist_diagnostics());
  return out;
}

}  // namespace springbok::can
