// The SocketCAN joint-drive backend: one raw socket per bus, MIT-mode and
// CiA 402 drives as configured, the fixed-phase tick of CAN.md section 3.3,
// the error handling of section 4.
//
// Tick contract (called by the executive at 1 kHz):
//   read(m)  at the start of tick k: (1) collects the replies to the frames sent
//            at the start of tick k-1 (waiting at most until that send +
//            rx_deadline_us for missing ones), counts missing/stale replies per
//            joint, fills m; (2) sends the commands stored by the last write()
//            (one frame per joint, then SYNC on CiA 402 buses). Sending right
//            after draining, at the tick's start, keeps the phase fixed whatever
//            the compute time.
//   write(c) stores c, encoded, for the next read(). No I/O.
// A drive whose reply is missing more than `missed_replies_lost` ticks in a row
// (age > N_stale, CAN.md 4.1) is DriveState::lost; an EMCY, a fault bit or a vendor error code latches
// DriveState::fault. Bus-off, ENETDOWN, ENOBUFS on tx_fault_ticks ticks in a row, or a
// valid frame naming a drive configured on another bus (a configuration fault, CAN.md 4.1)
// fault the bus: its drives are lost, read() returns IoStatus::error, and
// nothing resumes by itself: recovery is an operator action (restart the
// controller, then recover_bus(), which re-runs that bus's start-up). A bus whose
// controller reports error passive is only degraded (its bit in m.degraded_buses,
// a warning for the safety layer) until the controller reports error active again.
//
// Start-up (not real-time): configure() finds and configures every drive without enabling one:
// MIT exit motor mode (presence, initial position), a zero command, the positions checked against
// the joint limits and can.start_pose (CAN.md 4.2 steps 1-3); CiA 402 each node's boot-up awaited,
// a node heard up (heartbeat) reset first, then its SDO configuration (4.3 steps 1-2). activate()
// enables them bus by bus (4.2 step 4, 4.3 steps 3-4); if it fails anywhere, every drive it enabled
// is disabled again (4.4 step 2). A bus fault latched during either fails it, naming the bus.
//
// Sensors (CAN.md 6): the trunk IMU and the wrist F/T push their frames on their own
// clock. read() feeds every sensor frame it drains to the sensor's assembler and fills
// m.imu / m.wrist from the newest complete sample; it never waits for a sensor. Each bus
// is drained at most kMaxRxFramesPerBusPerTick frames per read(), so a flood on one bus
// cannot starve the drive replies on the others. A sensor whose newest complete sample
// is older than its stale_ticks is lost (m.imu.lost / m.wrist.lost, valid = false); the
// backend only reports it: latching a fault is the firmware's safety layer's decision.
// A fault of a bus without drives (a sensors-only bus) does not make read() return error:
// its sensors go lost instead.
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "springbok/can/config.hpp"
#include "springbok/can/mit.hpp"
#include "springbok/can/sensors.hpp"
#include "springbok/can/socketcan.hpp"
#include "springbok/hal/hardware.hpp"

namespace springbok::can {

// foreign_drive: a valid frame naming a drive configured on another bus arrived on this one (CAN.md
// 4.1): a configuration (or wiring) fault. The bus still carries frames (bus_reachable()).
// restarted: the controller restarted after a bus-off it had not reported (CAN_ERR_RESTARTED alone).
enum class BusFault : std::uint8_t {
  none = 0, bus_off, restarted, net_down, tx_queue_full, socket_error, no_ack, foreign_drive
};
const char* to_string(BusFault f) noexcept;
// Whether the tick's commands still go to a bus with this fault: none, or a configuration fault (its
// drives are usable, so they damp with the others, CAN.md 4.4 step 1; damping, kp = 0, is passive
// whichever joint a drive turns). After a bus-off the drives go through start-up again, never
// silently resumed (CAN.md 4). rt: no alloc
bool bus_commanded(BusFault f) noexcept;

struct BusDiagnostics {
  std::uint64_t frames_sent = 0;
  std::uint64_t frames_received = 0;
  std::uint64_t tx_dropped = 0;          // frames not sent: ENOBUFS / EAGAIN (rest of the tick dropped)
  std::uint64_t short_writes = 0;
  std::uint64_t tx_errors = 0;           // other write errors
  std::uint64_t error_frames = 0;
  std::uint64_t warnings = 0;            // error warning level reached
  std::uint64_t error_passive_events = 0;
  std::uint64_t overflows = 0;           // controller RX/TX overflow: frames lost
  std::uint64_t bad_frames = 0;          // wrong DLC, undecodable, implausible
  std::uint64_t unexpected_frames = 0;   // a frame no drive of this bus sends, naming no drive of another bus
  std::uint64_t foreign_frames = 0;      // a valid frame of a drive on another bus: configuration fault
  std::uint8_t foreign_drive_id = 0;     // the first such frame: the drive it named (0: none yet) ...
  std::uint32_t foreign_can_id = 0;      // ... and its CAN id
  std::uint64_t duplicates = 0;          // more than one reply per command
  std::uint64_t sensor_frames = 0;       // frames of a sensor configured on this bus (see the sensor's diagnostics)
  std::uint64_t rx_budget_exhausted = 0; // ticks on which the per-tick receive budget ran out (frames left queued)
  bool error_passive = false;            // degraded (warning for safety)
  bool controller_restarted = false;     // CAN_ERR_RESTARTED since the last bus-off: the controller is on the bus again
  // The controller's TX / RX error counters of the newest CAN_ERR_CNT report (none on vcan).
  bool have_error_counters = false;
  std::uint8_t tx_error_counter = 0;
  std::uint8_t rx_error_counter = 0;
  BusFault fault = BusFault::none;       // latched until recover_bus()
};

// Whether frames can still be sent on a bus in this state, to disable its drives (CAN.md 4.4 step 2):
// a bus that is commanded, or whose controller restarted after its bus-off. rt: no alloc
bool bus_reachable(const BusDiagnostics& d) noexcept;

// Counts an error frame into its bus's diagnostics (CAN.md 4, "Error frames"); returns the
// bus fault it means (bus-off, controller restarted) or BusFault::none. rt: no alloc
BusFault record_error_frame(const Frame& f, BusDiagnostics& d) noexcept;
// Counts a valid frame naming drive `drive_id`, which is configured on another bus, into its bus's
// diagnostics (the first one's drive and CAN id kept); returns the bus fault it is (CAN.md 4.1: a
// configuration fault). rt: no alloc
BusFault record_foreign_frame(const Frame& f, std::uint8_t drive_id, BusDiagnostics& d) noexcept;
// The bus's line of CanHardware::diagnostics_report(): "can bus lf (vcan0): fault=none ...".
std::string bus_diagnostics_line(const BusConfig& bus, const BusDiagnostics& d);

// CAN.md 4 "TX buffer full", for one bus: after a write fails with ENOBUFS (the device queue)
// or EAGAIN (the socket's buffer) the rest of that bus's frames are dropped for the tick (never
// retried); ENOBUFS on fault_ticks ticks in a row is a bus fault. A tick that stopped at EAGAIN
// says nothing of the device queue: it neither extends nor ends that streak. rt: no alloc
class TxBufferFull {
 public:
  void begin_tick() noexcept { queue_full_ = buffer_full_ = false; }
  void record(TxStatus s) noexcept {
    queue_full_ = queue_full_ || s == TxStatus::queue_full;
    buffer_full_ = buffer_full_ || s == TxStatus::buffer_full;
  }
  // The rest of this tick's frames are to be dropped.
  bool dropping() const noexcept { return queue_full_ || buffer_full_; }
  // Ends the tick; true when it completes fault_ticks ticks in a row with ENOBUFS.
  bool end_tick(std::uint32_t fault_ticks) noexcept {
    if (queue_full_) {
      ++ticks_in_row_;
    } else if (!buffer_full_) {
      ticks_in_row_ = 0;
    }
    return ticks_in_row_ >= fault_ticks;
  }

 private:
  bool queue_full_ = false, buffer_full_ = false;
  std::uint32_t ticks_in_row_ = 0;
};

// Per-joint runtime state of the backend (fixed size).
struct JointRuntime {
  DriveConfig cfg;
  int bus = -1;
  hal::DriveStatus status;
  bool have_state = false;
  double q_rad = 0.0, qd_rad_s = 0.0, tau_nm = 0.0;
  mit::VelocityObserver velocity;  // MIT: qd_rad_s from the replies' velocity and position
  std::uint64_t last_rx_tick = 0;
  bool awaiting = false;          // a command / SYNC went out: a reply is due at the next read
  int replies_this_tick = 0;      // MIT replies / CiA TPDO1 since the last read
  std::uint64_t tpdo1_count = 0;  // CiA 402: TPDO1 frames taken, ever (the drive's answered cycles, cia402::StepClock)
  std::uint64_t syncs_before_walk = 0;  // its bus's syncs_sent less tpdo1_count when its walk began
  bool tpdo2_this_tick = false;
  int implausible_in_row = 0;
  std::uint64_t last_heartbeat_tick = 0;
  std::uint16_t statusword = 0;
  std::uint16_t controlword = 0;
  // CiA 402: the drive's 0x6076 as read at start-up and the scaling built from it (0x6071,
  // 0x6072, 0x6077), set once per start-up and only multiplied by on the tick.
  std::uint32_t rated_torque_mnm = 0;
  cia402::TorqueScale torque_scale;
  // CiA 402 start-up (CAN.md 4.3 step 1), since the bus's socket was opened: its boot-up frame seen;
  // a heartbeat seen (the node was up already).
  bool booted = false;
  bool heartbeat_seen = false;
  // The first non-zero fault code the drive itself sent since this bus's start-up began (CiA 402:
  // EMCY; MIT: the vendor reply's error byte): start-up fails on it (can_startup.cpp).
  std::uint16_t startup_fault_code = 0;
  // MIT: replies naming this drive whose length its type does not allow (CAN.md 1.4: 6, 7 or 8
  // bytes), dropped; the length of the last one.
  std::uint64_t wrong_dlc_replies = 0;
  std::uint8_t wrong_dlc_len = 0;
  bool sdo_answered = false;
  Frame sdo_answer;
  Frame pending;                  // the command frame for the next send
  bool has_pending = false;
};

// DriveStatus::fault_code of an MIT drive whose reported bus voltage fell below
// can.mit_bus_voltage_fault_v: CiA 402's "DC link under-voltage" (CAN.md 2.2's code table).
inline constexpr std::uint16_t kFaultBusUndervoltage = 0x3220;

// Frames read from one bus per read() at most (a flood cannot starve the other buses).
inline constexpr int kMaxRxFramesPerBusPerTick = 256;

class CanHardware final : public hal::Hardware {
 public:
  explicit CanHardware(CanConfig config);
  ~CanHardware() override;
  CanHardware(const CanHardware&) = delete;
  CanHardware& operator=(const CanHardware&) = delete;

  std::string_view name() const noexcept override { return "socketcan"; }
  // Validates the layout (refusing a bus above the load limit), opens the sockets,
  // finds every drive and configures it (CAN.md 4.2 steps 1-3, 4.3 steps 1-2); enables none.
  hal::LifecycleResult configure() override;
  // Enables every drive (MIT enter motor mode; CiA 402 NMT start and the state machine). When it
  // fails on a bus, every drive it enabled (that bus's included) is disabled again as in CAN.md
  // 4.4 step 2 before it returns: a failed activate() leaves no drive enabled.
  hal::LifecycleResult activate() override;
  // rt: no alloc; bounded wait (rx deadline).
  hal::IoStatus read(hal::Measurements& out) noexcept override;
  // rt: no alloc, no I/O.
  hal::IoStatus write(const hal::JointCommands& cmd) noexcept override;
  // Damping (kp = 0, kd = D) for damping_time_ms or until every |qd| is below
  // the stop speed, then disable (CAN.md 4.4). Safe to call more than once.
  void deactivate() noexcept override;
  // "can bus lf (vcan0): fault=none bad_frames=0 ..." per bus, "can sensor imu: ..." per sensor.
  std::string diagnostics_report() const override;

  // Operator recovery after a bus fault: reopen, re-run start-up and enable for that bus (disabled
  // again when its enable fails, as in activate()).
  hal::LifecycleResult recover_bus(int bus);

  const CanConfig& config() const noexcept { return config_; }
  int bus_count() const noexcept { return bus_count_; }
  const BusDiagnostics& diagnostics(int bus) const noexcept { return buses_[static_cast<std::size_t>(bus)].diag; }
  const JointRuntime& joint(int j) const noexcept { return joints_[static_cast<std::size_t>(j)]; }
  std::uint64_t tick() const noexcept { return tick_; }
  // What start-up noticed without failing, one line each (e.g. a drive whose 0x6076 differs
  // from the config's rated_torque_nm); also at the head of diagnostics_report(). Not real-time.
  const std::string& startup_notes() const noexcept { return startup_notes_; }
  // Commands that were not finite (replaced by zero torque).
  std::uint64_t rejected_commands() const noexcept { return rejected_commands_; }

  // ---- sensors (CAN.md 6), as of the last read() ----
  bool has_imu() const noexcept { return config_.sensors.imu.enabled; }
  bool has_wrist_ft() const noexcept { return config_.sensors.wrist_ft.enabled; }
  const SensorDiagnostics& imu_diagnostics() const noexcept { return imu_.diagnostics(); }
  const SensorDiagnostics& wrist_diagnostics() const noexcept { return ft_.diagnostics(); }
  // Configured and no accepted sample within stale_ticks (or none yet).
  bool imu_lost() const noexcept { return has_imu() && imu_.diagnostics().lost; }
  bool wrist_lost() const noexcept { return has_wrist_ft() && ft_.diagnostics().lost; }
  // Status bit 1 of the newest accepted sample: IMU orientation not converged / F/T bias not taken.
  bool imu_not_converged() const noexcept { return has_imu() && imu_.diagnostics().not_ready; }
  bool wrist_bias_not_taken() const noexcept { return has_wrist_ft() && ft_.diagnostics().not_ready; }
  // A clipping streak (clip_streak samples in a row) on the newest samples.
  bool imu_clipping_streak() const noexcept { return has_imu() && imu_.diagnostics().clip_streak_fault; }
  bool wrist_clipping_streak() const noexcept { return has_wrist_ft() && ft_.diagnostics().clip_streak_fault; }
  // The firmware's tare length for the F/T (carried from the config, CAN.md 6.2).
  std::uint32_t wrist_tare_samples() const noexcept { return config_.sensors.wrist_ft.tare_samples; }

 private:
  struct Bus {
    SocketCanBus socket;
    std::array<int, kMaxDrivesPerBus> joints{};
    int count = 0;
    bool any_mit = false;
    bool any_cia = false;
    TxBufferFull tx_full;
    int rx_budget = kMaxRxFramesPerBusPerTick;  // frames this read() may still take from this bus
    bool has_imu = false, has_ft = false;       // sensors on this bus
    // Its CiA 402 nodes are Operation enabled: SYNC goes every tick from then on (CAN.md 4.3
    // step 3), while later buses are enabled too (keep_alive) until read() takes over.
    bool synced = false;
    std::uint64_t syncs_sent = 0;  // ever (CiA 402 step times: unanswered_syncs)
    BusDiagnostics diag;
  };
  struct SdoOutcome {
    enum class Kind : std::uint8_t { ok, abort, timeout, bad_answer } kind = Kind::timeout;
    std::uint32_t value = 0;
    std::uint32_t abort_code = 0;
  };

  hal::LifecycleResult open_bus(int b);
  // While activate() runs: RPDO1 (enable operation, zero torque) to every CiA 402 node of the
  // synced buses and their SYNC, once per tick (called from pump_until).
  void keep_alive() noexcept;
  hal::LifecycleResult start_bus(int b);
  hal::LifecycleResult enable_bus(int b);
  hal::LifecycleResult start_mit(int b);
  hal::LifecycleResult enable_mit(int b);
  hal::LifecycleResult start_cia402(int b);
  hal::LifecycleResult enable_cia402(int b);
  // CAN.md 4.4 step 2 on buses first..last together (not real-time: waits for each CiA 402
  // step, up to state_step_timeout_ms).
  void disable_buses(int first, int last) noexcept;
  // After enable_bus failed on bus `last`: disables buses first..last, returns `failure` saying so.
  hal::LifecycleResult disable_after_failed_enable(int first, int last, hal::LifecycleResult failure);
  hal::LifecycleResult configure_node(int j);
  // A failure naming the first of `drives` that sent a fault code since its start-up began.
  hal::LifecycleResult startup_fault(const std::vector<int>& drives, const char* during);
  SdoOutcome sdo(int j, bool write, std::uint16_t index, std::uint8_t sub, std::uint32_t value, std::uint8_t size);
  std::string drive_name(int j) const;
  std::string unanswered_drive(int j) const;
  template <class Done>
  bool pump_until(std::int64_t deadline_ns, Done&& done);

  void process_frame(int b, const Frame& f) noexcept;
  bool process_sensor_frame(int b, const Frame& f) noexcept;
  void fill_sensors(hal::Measurements& out) noexcept;
  void process_mit_reply(int b, const Frame& f) noexcept;
  // A reported bus voltage against can.mit_bus_voltage_{warning,fault}_v: the warning flag, a
  // latched drive fault (kFaultBusUndervoltage). rt: no alloc
  void check_bus_voltage(int j, double bus_voltage_v) noexcept;
  // A CAN id an MIT reply may come on, on bus b: a configured reply id of one of its MIT drives,
  // or 0, the drives' factory CAN_MASTER (CAN.md 1.4: the host matches on byte 0 either way).
  bool is_mit_reply_id(int b, std::uint32_t id) const noexcept;
  void process_cia402_frame(int b, const Frame& f) noexcept;
  void process_error_frame(int b, const Frame& f) noexcept;
  bool accept_position(int j, double q_rad) noexcept;
  int find_joint(int b, std::uint8_t drive_id, Protocol p) const noexcept;
  // The joint of drive `drive_id` when it is configured on a bus other than `b`, else -1. rt: no alloc
  int find_foreign_joint(int b, std::uint8_t drive_id) const noexcept;
  // A failure naming bus `b` and its latched fault (success when it has none). Not real-time.
  hal::LifecycleResult bus_fault_failure(int b, const char* during) const;
  void latch_fault(int j, std::uint16_t code) noexcept;
  void fault_bus(int b, BusFault why) noexcept;
  bool replies_complete() const noexcept;
  // Reads this bus until EAGAIN or `max_frames` frames; returns false when it stopped at the limit.
  bool drain(int b, int max_frames) noexcept;
  void evaluate_joints() noexcept;
  void send_pending() noexcept;
  void queue_command(int j, const hal::JointCommands& cmd) noexcept;
  void queue_zero_command(int j) noexcept;
  bool send_now(int b, const Frame& f) noexcept;
  // A SYNC on bus `b`, counted in Bus::syncs_sent when sent.
  bool send_sync(int b) noexcept;
  // The SYNCs sent on joint j's bus since its walk began (enable_cia402) that it has not answered:
  // those still on their way, and those it lost.
  std::uint64_t unanswered_syncs(int j) const noexcept;
  int handles(std::array<int, kMaxBuses>& out) const noexcept;

  CanConfig config_;
  int bus_count_ = 0;
  std::uint64_t tick_ = 0;
  std::uint64_t sequence_ = 0;
  std::uint64_t rejected_commands_ = 0;
  std::uint64_t heartbeat_lost_ticks_ = 0;
  bool configured_ = false;
  bool active_ = false;
  std::int64_t last_send_ns_ = 0;
  std::int64_t next_keep_alive_ns_ = 0;
  std::string startup_notes_;
  std::array<JointRuntime, kNj> joints_{};
  std::array<Bus, kMaxBuses> buses_{};
  ImuAssembler imu_;
  FtAssembler ft_;
  std::int64_t imu_stamp_ns_ = 0;   // monotonic time the newest IMU sample completed
  std::int64_t ft_stamp_ns_ = 0;
};

}  // namespace springbok::can
