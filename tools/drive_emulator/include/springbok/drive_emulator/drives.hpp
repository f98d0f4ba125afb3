// The drive side of both protocols (CAN.md section 5), as the emulator runs it:
// an MIT-mode drive and a CiA 402 drive, each moving a per-joint model or a
// joint of a shared world (Motion), each with a scriptable list of injected
// faults. No I/O: frames in, frames out.
#pragma once

#include <array>
#include <cstdint>
#include <deque>
#include <map>
#include <string>
#include <vector>

#include "springbok/can/cia402.hpp"
#include "springbok/can/config.hpp"
#include "springbok/can/frame.hpp"

namespace springbok::emu {

// One joint: J qdd = tau - b qd, velocity capped at the joint's limit, hard
// stops at the position limits. Stepped once per command (MIT) or SYNC (CiA 402).
struct JointModel {
  double q_rad = 0.0;
  double qd_rad_s = 0.0;
  double tau_nm = 0.0;
  double inertia_kgm2 = 0.05;
  double viscous_nms_per_rad = 0.5;
  double v_max_rad_s = 1.0;
  bool bounded = false;
  double lower_rad = 0.0, upper_rad = 0.0;
  void step(double tau_cmd_nm, double dt_s) noexcept;
};
JointModel make_joint_model(int joint, double q0_rad);

// The law a drive applies until its next command: tau = kp (p_des - q) + kd (v_des - qd) + t_ff.
struct DriveLaw {
  double p_des_rad = 0.0, v_des_rad_s = 0.0, kp = 0.0, kd = 0.0, t_ff_nm = 0.0;
};
struct JointState {
  double q_rad = 0.0, qd_rad_s = 0.0, tau_nm = 0.0;
};

// Where the joints move when not each in its own JointModel: one world shared by every
// drive (the Bullet robot, bullet_motion.hpp), stepped in lockstep with the host's ticks.
class Motion {
 public:
  virtual ~Motion() = default;
  // The cyclic command of `joint` for the next step (MIT: a command in motor mode;
  // CiA 402: the SYNC while Operation enabled). Returns the joint's state at reception,
  // i.e. measured before the step this command belongs to (as a real drive replies).
  virtual JointState command(int joint, const DriveLaw& law) = 0;
  // Only enabled drives take part in a step; a disabled one applies no torque.
  virtual void set_enabled(int joint, bool enabled) = 0;
  virtual JointState state(int joint) const = 0;
  // The joint's command for the coming step already arrived: a further one must wait
  // for the step (the emulator holds that frame back, see main.cpp).
  virtual bool pending(int joint) const = 0;
  // Steps now with the stored commands of the joints still missing theirs (a frame was lost).
  virtual void force_step() = 0;
};

enum class FaultKind : std::uint8_t {
  drop,           // no reply for `count` ticks
  delay,          // replies held back `param` ticks, for `count` ticks
  duplicate,      // each reply sent twice, for `count` ticks
  corrupt,        // position bytes inverted, for `count` ticks
  silent,         // never replies again; with `at_frame: k` instead of `at`: unplugged from the k-th frame
                  // addressed to the drive since power-on (1 = the first) on, that one included: it takes,
                  // answers and sends nothing any more (a drive lost between the host's start-up steps)
  emcy,           // CiA 402: EMCY `param` (default 0x2310) + Fault state; MIT (vendor reply): error code `param`.
                  // CiA 402 also `at_sdo: k` instead of `at`: right after answering the k-th SDO
                  // request since power-on (the host's Pre-operational configuration)
  bus_off,        // an error frame with CAN_ERR_BUSOFF on the drive's bus
  restarted,      // an error frame with CAN_ERR_RESTARTED on the drive's bus (its controller back after bus-off)
  error_passive,  // an error frame CAN_ERR_CRTL / TX passive on the drive's bus
  error_active,   // an error frame CAN_ERR_CRTL / ACTIVE on the drive's bus (back from error passive)
  wrong_dlc,      // the reply one byte short, for `count` ticks
  unexpected_id,  // MIT: byte 0 = `param`; CiA 402: TPDO1 with node id `param`; for `count` ticks
  no_heartbeat,   // CiA 402: heartbeats stop for good (the PDOs still flow)
  // Drive properties from power-on (no `at` / `count`, `param` required):
  rated_torque,        // CiA 402: 0x6076 reads `param` mNm instead of the config's rated_torque_nm (or
                       // the joint's effort limit); the drive scales 0x6071 / 0x6072 / 0x6077 by it
  mode_display_delay,  // CiA 402: 0x6061 shows a value written to 0x6060 only `param` ms after the write
  enable_blocked,      // CiA 402 (no `param`): Enable operation is not followed, the drive stays Switched on
                       // (e.g. its safe torque off is engaged); every other transition works
  vendor_error,        // MIT with 8-byte replies: every reply's error byte reads `param` (1..255), from
                       // the first (a drive that boots with a fault: the host sees it during start-up)
  // Sensors (CAN.md 6.5; `sensor:` instead of `drive:`, ticks are the sensor's samples).
  // Also valid for a sensor: silent (never publishes again), drop (no frames for `count`
  // samples, the counter advances), wrong_dlc (every frame one byte short).
  stale_counter,       // the counter stays at the last value for `count` samples
  status_invalid,      // status bit 0 (valid) clear for `count` samples
  corrupt_quaternion,  // IMU only: q_x = q_y = q_z = 0x7FFF (|q_xyz|^2 ~ 3) for `count` samples
  saturate,            // the first field of every frame at +32767 with the clipping bit, for `count` samples
  split,               // the last frame of each of `count` samples sent with the next sample (next tick)
  not_ready,           // status bit 1 (IMU not converged / F/T bias not taken) for `count` samples
};
const char* to_string(FaultKind k) noexcept;

enum class SensorId : std::uint8_t { none = 0, imu = 1, wrist_ft = 2 };
const char* to_string(SensorId s) noexcept;

struct Fault {
  FaultKind kind = FaultKind::drop;
  SensorId sensor = SensorId::none;  // a sensor fault (drive_id is 0), or none: a drive fault
  int drive_id = 0;
  std::uint64_t at_tick = 1;  // the drive's cyclic tick (commands in motor mode / SYNCs while Operational)
  std::uint64_t count = 1;
  std::uint32_t param = 0;
  std::uint64_t at_sdo = 0;  // emcy (CiA 402): fire after answering this SDO request (1 = the first); 0: at `at`
  std::uint64_t at_frame = 0;  // silent: unplugged from this frame addressed to the drive on (1 = the first); 0: at `at`
};
// The drive properties of rated_torque / mode_display_delay / vendor_error / enable_blocked, not timed events.
bool is_property(FaultKind k) noexcept;

struct FaultResult {
  bool ok = false;
  std::vector<Fault> faults;
  std::string error;
};
// A YAML list under `faults:` of {kind, drive | sensor, at, count, param}; errors name the entry.
FaultResult load_faults_file(const std::string& path);
FaultResult load_faults_text(const std::string& text);

class Drive {
 public:
  Drive(const can::DriveConfig& cfg, bool fd_bus, JointModel model, std::vector<Fault> faults);
  virtual ~Drive() = default;
  // A frame seen on the bus; replies (and injected error frames) go to `out`.
  virtual void on_frame(const can::Frame& f, std::int64_t now_ns, std::vector<can::Frame>& out) = 0;
  // Time passes (heartbeats, CAN_TIMEOUT).
  virtual void on_time(std::int64_t now_ns, std::vector<can::Frame>& out) = 0;
  // `f` would be this drive's cyclic command (one world step per host tick).
  virtual bool cyclic(const can::Frame& f) const noexcept = 0;
  // The drive's joint waits for the world to step before it may take another cyclic command.
  bool waits_for_step(const can::Frame& f) const noexcept { return motion_ != nullptr && cyclic(f) && motion_->pending(cfg_.joint); }

  const can::DriveConfig& config() const noexcept { return cfg_; }
  const JointModel& model() const noexcept { return model_; }
  std::uint64_t tick() const noexcept { return tick_; }
  std::uint64_t frames_in() const noexcept { return frames_in_; }
  std::uint64_t replies_out() const noexcept { return replies_out_; }
  bool enabled() const noexcept { return enabled_; }
  // A `silent` fault's at_frame was reached: the drive takes and sends nothing any more.
  bool unplugged() const noexcept { return unplugged_; }
  // Moves this drive's joint in `motion` instead of its own JointModel (nullptr: own model).
  void attach(Motion* motion);

 protected:
  void set_enabled(bool enabled);
  // The joint's state from the shared world (no-op with the own JointModel).
  void sync_from_motion();
  // One cyclic step under `law` with the own model, or the command to the shared world.
  void step_joint(const DriveLaw& law, double tau_nm);
  Motion* motion_ = nullptr;
  // Starts a cyclic tick: releases delayed replies, fires one-shot events.
  void begin_tick(std::vector<can::Frame>& out);
  // Sends a cyclic reply through the active faults.
  void emit_cyclic(can::Frame f, std::vector<can::Frame>& out);
  void emit(const can::Frame& f, std::vector<can::Frame>& out);
  virtual void on_fault_event(const Fault& fault, std::vector<can::Frame>& out) = 0;
  virtual void corrupt(can::Frame& f) const = 0;
  bool active(const Fault& flt) const noexcept;
  // Counts a frame addressed to this drive: false from the frame a `silent` fault's at_frame names
  // on (the drive is unplugged: it takes, answers and sends nothing any more).
  bool take_frame() noexcept;

  can::DriveConfig cfg_;
  bool fd_bus_ = false;
  JointModel model_;
  std::vector<Fault> faults_;
  std::uint64_t tick_ = 0;
  std::uint64_t frames_in_ = 0, replies_out_ = 0;
  std::uint64_t frames_addressed_ = 0;  // frames for this drive since power-on, an unplugged drive's included
  bool unplugged_ = false;
  bool enabled_ = false;
  std::vector<std::pair<std::uint64_t, can::Frame>> delayed_;
};

// The MIT drive's reply as its firmware builds it (CAN.md 1.4).
struct MitReplyOptions {
  // Bytes per reply: 6 (bgkatz before July 2023), 7 (since: + bus voltage), 8 (CubeMars: +
  // temperature, error code); 5 is a malformed reply (a length no firmware sends, for the host's
  // tests). 0: as the config says (8 with vendor_reply, else 6).
  int dlc = 0;
  double bus_voltage_v = 24.0;  // byte 6 of a 7-byte reply
};

// MIT mode, bgkatz motorcontrol behaviour: one reply per received frame, the state
// at reception, truncating float_to_uint; stored command; special frames; CAN_TIMEOUT.
class MitDrive final : public Drive {
 public:
  MitDrive(const can::DriveConfig& cfg, bool fd_bus, JointModel model, std::vector<Fault> faults,
           std::uint32_t can_timeout_ms, const MitReplyOptions& reply = {});
  void on_frame(const can::Frame& f, std::int64_t now_ns, std::vector<can::Frame>& out) override;
  void on_time(std::int64_t now_ns, std::vector<can::Frame>& out) override;
  bool cyclic(const can::Frame& f) const noexcept override;
  std::uint64_t zero_frames() const noexcept { return zero_frames_; }
  // Classic frames to this drive on a CAN FD bus (ignored: that bus speaks FD).
  std::uint64_t classic_frames() const noexcept { return classic_frames_; }

 private:
  void on_fault_event(const Fault& fault, std::vector<can::Frame>& out) override;
  void corrupt(can::Frame& f) const override;
  can::Frame reply() const;
  std::uint32_t can_timeout_ms_;
  MitReplyOptions reply_;
  std::int64_t last_rx_ns_ = 0;
  double p_des_ = 0, v_des_ = 0, kp_ = 0, kd_ = 0, t_ff_ = 0;  // the stored command
  std::uint8_t error_code_ = 0;
  std::uint64_t zero_frames_ = 0;
  std::uint64_t classic_frames_ = 0;
};

// What a CiA 402 drive does that CAN.md allows and the plainest drive does not (the emulator's
// --cia402-* options).
struct Cia402Options {
  // The stored producer heartbeat time, 0x1017 after power-on and after NMT reset communication
  // (0: no heartbeat until the host writes 0x1017).
  std::uint16_t stored_heartbeat_ms = 0;
  // NMT commands take effect this long after they arrive (a CANopen stack runs NMT in its own
  // cycle); frames in between meet the old NMT state.
  std::uint32_t nmt_delay_ms = 0;
  // The drive has only the PDOs CAN.md uses (RPDO1, TPDO1, TPDO2): the others' objects answer
  // "object does not exist".
  bool only_used_pdos = false;
  // Every SDO answer goes out twice (a repeat the host must not take for the next one's).
  bool repeat_sdo_answers = false;
  // Lost communication (0x6007 = 3: quick stop): Operation enabled, and no SYNC for this long
  // (0: never); armed by the first SYNC in Operational.
  std::uint32_t sync_timeout_ms = 0;
  // Answers late while the drive is not Operation enabled (its start-up): the TPDOs of a SYNC
  // and an SDO answer go out this long after the frame that asked for them, in order. Once
  // Operation enabled, the TPDOs of a SYNC go out as soon as the late ones before them have.
  std::uint32_t answer_delay_ms = 0;
  // A state transition of the state machine (CAN.md 2.5) takes effect this long after the SYNC
  // that applied its controlword (0: at that SYNC); the statusword shows the old state until then.
  std::uint32_t state_step_ms = 0;
  // A holding brake: the transition into Operation enabled waits this long for it to release,
  // the one out of it this long for it to engage (at least state_step_ms; 0: no brake).
  std::uint32_t brake_ms = 0;
};

// CiA 402 subset: NMT, heartbeat, SDO (expedited + aborts), PDO mapping by SDO,
// SYNC-driven TPDOs, the state machine, CST, EMCY.
class Cia402Drive final : public Drive {
 public:
  Cia402Drive(const can::DriveConfig& cfg, JointModel model, std::vector<Fault> faults, std::int64_t now_ns,
              const Cia402Options& options = {});
  void on_frame(const can::Frame& f, std::int64_t now_ns, std::vector<can::Frame>& out) override;
  void on_time(std::int64_t now_ns, std::vector<can::Frame>& out) override;
  bool cyclic(const can::Frame& f) const noexcept override;
  // Sends the boot-up frame (power-on).
  void boot(std::int64_t now_ns, std::vector<can::Frame>& out);
  std::uint16_t status_word() const noexcept;
  std::uint8_t nmt_state() const noexcept { return nmt_; }
  bool powered() const noexcept { return nmt_ != 0x00; }  // boot() was called
  // NMT reset node / reset communication commands taken since power-on.
  std::uint64_t nmt_resets() const noexcept { return nmt_resets_; }
  // Quick stops for lost communication (Cia402Options::sync_timeout_ms).
  std::uint64_t sync_timeouts() const noexcept { return sync_timeouts_; }

 private:
  enum class St : std::uint8_t { not_ready, switch_on_disabled, ready, switched_on, enabled, quick_stop, fault };
  struct Pdo {
    std::uint32_t cob_id = 0;
    std::uint8_t transmission = 255;
    std::uint8_t count = 0;
    std::array<std::uint32_t, 8> entries{};
  };
  void reset_communication();
  void take_nmt(can::cia402::NmtCommand cs, std::int64_t now_ns, std::vector<can::Frame>& out);
  bool has_pdo(std::uint16_t index) const noexcept;
  void on_sync(std::vector<can::Frame>& out);
  void handle_sdo(const can::Frame& f, std::vector<can::Frame>& out);
  // SDO access to the object dictionary: returns 0 or an abort code.
  std::uint32_t read_object(std::uint16_t index, std::uint8_t sub, std::uint32_t& value, std::uint8_t& size) const;
  std::uint32_t write_object(std::uint16_t index, std::uint8_t sub, std::uint32_t value, std::uint8_t size);
  std::uint32_t object_value(std::uint32_t mapping_entry) const;
  // The state the applied controlword leads to from `from` (CAN.md 2.5), `from` when none.
  St transition(St from) const noexcept;
  void step_state_machine();
  // The frames appended to `out` from `first` on are answers: held back answer_delay_ms while
  // the drive is not Operation enabled, and behind any answer still held back.
  void hold_answers(std::vector<can::Frame>& out, std::size_t first);
  void release_answers(std::vector<can::Frame>& out);
  std::int8_t mode_shown() const noexcept;  // 0x6061 now
  void on_fault_event(const Fault& fault, std::vector<can::Frame>& out) override;
  void corrupt(can::Frame& f) const override;

  std::uint8_t nmt_ = 0x00;
  St state_ = St::switch_on_disabled;
  bool step_pending_ = false;              // a transition waiting for options_.state_step_ms
  St step_target_ = St::switch_on_disabled;
  std::int64_t step_due_ns_ = 0;
  std::deque<std::pair<std::int64_t, can::Frame>> late_;  // answers held back, due time in order
  std::uint16_t controlword_ = 0, applied_controlword_ = 0;
  std::int16_t target_torque_ = 0, applied_target_torque_ = 0;
  std::uint16_t heartbeat_ms_ = 0;
  Cia402Options options_;
  bool nmt_pending_ = false;               // an NMT command waiting for options_.nmt_delay_ms
  can::cia402::NmtCommand pending_nmt_{};
  std::int64_t nmt_due_ns_ = 0;
  std::int64_t last_sync_ns_ = 0;          // in Operational (0: none yet)
  std::uint64_t nmt_resets_ = 0;
  std::uint64_t sync_timeouts_ = 0;
  std::int64_t next_heartbeat_ns_ = 0;
  std::int8_t mode_ = 0;
  // 0x6061: shows mode_ from mode_display_at_ns_ on, mode_before_ until then (mode_display_delay).
  std::int8_t mode_before_ = 0;
  std::int64_t mode_display_at_ns_ = 0;
  std::uint32_t mode_display_delay_ms_ = 0;
  bool enable_blocked_ = false;         // the enable_blocked property: Switched on is as far as it goes
  std::int64_t now_ns_ = 0;          // time of the frame being handled
  std::uint64_t sdo_requests_ = 0;   // SDO requests answered since power-on (emcy at_sdo)
  std::uint32_t rated_torque_mnm_ = 0;  // 0x6076; in Nm it scales 0x6071 / 0x6077
  double rated_torque_nm() const noexcept { return static_cast<double>(rated_torque_mnm_) / 1000.0; }
  std::uint16_t max_torque_ = 1000;
  std::uint16_t error_code_ = 0;
  std::uint8_t error_register_ = 0;
  std::int16_t abort_connection_ = 1;
  std::uint8_t error_behaviour_ = 1;
  std::uint32_t cycle_period_us_ = 0;
  std::uint8_t ip_value_ = 1;
  std::int8_t ip_index_ = -3;
  std::array<Pdo, 4> rpdo_{}, tpdo_{};
};

}  // namespace springbok::emu
