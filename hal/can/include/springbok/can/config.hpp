// The CAN bus layout and drive parameters the SocketCAN backend is built from.
// Start-up data (may allocate); the backend copies it into fixed arrays.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "springbok/can/cia402.hpp"
#include "springbok/can/mit.hpp"
#include "springbok/can/sensors.hpp"
#include "springbok/model/model.hpp"

namespace springbok::can {

enum class Protocol : std::uint8_t { mit, cia402 };
const char* to_string(Protocol p) noexcept;

inline constexpr int kMaxBuses = 10;
inline constexpr int kMaxDrivesPerBus = 8;

// The MIT drives' factory CAN_MASTER (CAN.md 1.4): the reply id of a drive whose flash setting
// was never changed.
inline constexpr std::uint16_t kMitFactoryMasterId = 0;

struct DriveConfig {
  int joint = -1;                  // index into springbok::robot::kJoints (0..18)
  std::uint8_t drive_id = 0;       // MIT drive id / CANopen node id, 1..127, unique on the robot
  Protocol protocol = Protocol::mit;
  // MIT mode
  // The drive's CAN master id (CAN_MASTER): the CAN id of its replies. Drives may share
  // one (the factory default is 0): replies are matched on byte 0, the drive id. Replies on
  // the factory id are taken too (kMitFactoryMasterId), from a drive never configured.
  std::uint16_t mit_reply_id = 0;
  // CubeMars AK: bytes 6 and 7 of an 8-byte reply are the temperature and an error code
  // (non-zero = fault). Replies of 6 or 8 bytes are accepted either way; bytes 6..7 are
  // read only when this is set (CAN.md 1.4).
  bool mit_vendor_reply = false;
  mit::Ranges mit_ranges;
  // CiA 402
  cia402::Mapping mapping = cia402::Mapping::compact;
  double counts_per_rad = 0.0;             // 0x6064 increments per joint radian
  double velocity_units_per_rad_s = 0.0;   // 0x606C units per joint rad/s
  // Torque scaling (CAN.md 2.4): start-up reads the drive's motor rated torque 0x6076 and
  // scales 0x6071 / 0x6072 / 0x6077 by that value, whatever the config says.
  // rated_torque_nm: optional, what the drive is expected to report (0 = not given). When
  // given and the drive reports a value more than 0.5 % away, start-up goes on with the
  // drive's value and notes the difference (CanHardware::startup_notes, diagnostics_report).
  double rated_torque_nm = 0.0;
  double gear_ratio = 1.0;                 // 1 when the drive's torque is joint-side
  // Optional cap on 0x6072 in per mille of the drive's 0x6076 (0 = none). 0x6072 is the
  // joint's peak torque limit (torque_limit_peak_nm) in per mille of 0x6076, at most this cap.
  std::uint16_t max_torque_permille = 0;
};

struct BusConfig {
  std::string name;                 // for messages: "lf", "arm1", ...
  std::string interface;            // "can0", "vcan3"
  bool fd = false;                  // CAN FD with bit-rate switch
  std::uint32_t bitrate = 1000000;  // nominal bit rate, bit/s
  std::uint32_t data_bitrate = 0;   // FD data phase bit rate, bit/s
  std::vector<DriveConfig> drives;  // may be empty on a bus that carries a sensor (CAN.md 6.3)
};

struct Timing {
  std::uint32_t tick_us = 1000;                // control period (bus load is per tick)
  std::uint32_t missed_replies_lost = 3;       // N_stale: more than N ticks in a row without a fresh reply -> lost
  std::uint32_t rx_deadline_us = 900;          // read() waits this long after the send for missing replies
  std::uint32_t mit_presence_timeout_ms = 50;  // MIT start-up: reply to exit-motor-mode
  std::uint32_t mit_presence_retries = 3;
  std::uint32_t boot_timeout_ms = 5000;        // CiA 402: wait for boot-up
  std::uint32_t sdo_timeout_ms = 100;
  std::uint32_t sdo_retries = 2;
  // CiA 402 state machine, per step, in the drive's answered SYNC cycles (cia402::StepClock); also
  // how long 0x6061 may take to show the mode written to 0x6060
  std::uint32_t state_step_timeout_ms = 100;
  std::uint32_t heartbeat_period_ms = 100;     // 0x1017
  std::uint32_t heartbeat_lost_periods = 3;
  std::uint32_t tx_fault_ticks = 3;            // ENOBUFS on this many ticks in a row -> bus fault
  double damping_kd_nms_per_rad = 2.0;         // shutdown damping
  std::uint32_t damping_time_ms = 2000;
  double damping_stop_speed_rad_s = 0.05;
  double start_limit_margin_rad = 0.05;        // start-up position check against the joint limits
};

// CAN.md 4.2 step 3: where the joints are when the robot is started (the pose it is parked in when
// powered on, e.g. lying on its folded legs). MIT start-up checks the positions its drives report
// against it, and against the joint limits. A robot description cannot know it: the deployment
// gives it (the shipped springbok.yaml does); a config without it (a bench, a drive emulator
// whose joints start anywhere) has the joint limits checked alone. CiA 402 start-up (4.3) has
// no such step.
struct StartPose {
  bool given = false;               // can.start_pose is in the config
  std::array<double, kNj> q_rad{};  // joint order of springbok::robot::kJoints
  // |q - q_rad[j]| above this fails start-up. 0.3 rad: well beyond where an unpowered robot's
  // joints settle around its parking pose, below a turn of a single-turn encoder behind a 6..20:1
  // gear (0.31..1.05 rad), the error it is there to catch with a joint on the wrong drive.
  double tolerance_rad = 0.3;
};
// validate() refuses a start-pose tolerance above this: the check would no longer mean anything.
inline constexpr double kMaxStartPoseToleranceRad = 1.0;

// CAN.md 4.2 step 3: whether joint `joint` found at `q_rad` is at the start pose (false when
// q_rad is not finite). rt: no alloc
bool at_start_pose(const StartPose& pose, int joint, double q_rad) noexcept;

struct CanConfig {
  std::vector<BusConfig> buses;
  Timing timing;
  StartPose start_pose;       // optional (given: checked by MIT start-up)
  double max_bus_load = 0.8;  // worst-case (CAN.md section 3) load a bus may have
  // MIT drives: the bandwidth of the velocity observer on their replies (mit::VelocityObserver)
  // [rad/s]; 0: the replies' velocity as sent.
  double mit_velocity_observer_rad_s = 40.0;
  // MIT drives that report their bus voltage (7-byte replies, CAN.md 1.4): below warning_v a
  // drive is a warning (DriveStatus::bus_voltage_low), below fault_v a drive fault (it is about
  // to brown out), latched with code kFaultBusUndervoltage. 0: that check off (the default: the
  // drives' supply is the deployment's, and a 6- or 8-byte reply carries no voltage). Each in
  // [0, mit::kBusVoltageMaxV] V; fault_v below warning_v when both are on.
  double mit_bus_voltage_warning_v = 0.0;
  double mit_bus_voltage_fault_v = 0.0;
  SensorsConfig sensors;      // trunk IMU and wrist F/T (CAN.md section 6); each optional
};

// The built-in parameters of joint `joint` (0..18): id = joint + 1, MIT reply
// id 0x100 + id, Mini Cheetah ranges with the torque range = the joint's peak torque
// limit, CiA 402 scaling of a 19-bit joint-side encoder, joint-side torque (gear ratio 1),
// rated torque not given (the drive's 0x6076 is used) and no cap on 0x6072.
DriveConfig default_drive(int joint, Protocol p);

// CAN.md 3.3: seven classic 1 Mbit/s buses (one per leg, the arm over three: a 7-joint arm's
// 1-3, 4-5, 6-7, a 6-joint arm's 1-2, 3-4, 5-6), interfaces <prefix>0..6, drive id = joint + 1,
// every drive speaking `p`.
CanConfig classic7_layout(Protocol p, const std::string& interface_prefix = "can");
// Classic legs (MIT) + one CAN FD arm bus (1/5 Mbit/s, MIT-style frames): five buses.
CanConfig fd5_layout(const std::string& interface_prefix = "can");

// Empty when the config is consistent; otherwise the first problem, naming the field.
// start_pose, when given: every q_rad finite and within its joint's limits, tolerance_rad in
// (0, kMaxStartPoseToleranceRad].
// Sensors: each on a configured bus, ids 11-bit and distinct, none colliding with an id of
// a drive on the same bus (MIT command id and reply id; CiA 402: NMT, SYNC and the node's
// EMCY, PDO, SDO and heartbeat COB-IDs), scales finite and positive.
std::string validate(const CanConfig& c);

// The CAN ids a sensor may not use on a bus carrying `bus`'s drives: true and `why` set
// when `id` collides.
bool sensor_id_collides(const BusConfig& bus, std::uint32_t id, std::string& why);

}  // namespace springbok::can
