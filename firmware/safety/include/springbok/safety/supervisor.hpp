// The safety supervisor: the mode machine and the latched faults.
//
//   idle --start--> stand_up --posture reached--> stand <--mode--> control
//   any fault or operator stop --> damping --reset (safe state)--> idle
//
// Idle is passive but powered: the drives damp (kp = 0, kd = D_start,
// CAN.md 4.2 step 5), so the robot settles instead of dropping. Every fault
// latches a bit and moves to damping (tau = -D qd within the torque limits)
// in the tick it is detected, in idle too: a joint pushed past its limit
// while passive is still reported (limit_joint() names it) and blocks
// `start`; leaving damping needs an explicit operator reset while the robot
// is in a safe state (every joint back within its limit + margin). Each tick:
//
//   supervisor.observe(meas, io, overrun_streak, overruns_in_window);
//   supervisor.request(cmd)            // optional: one operator command
//   report = controller(mode(), ticks_in_mode(), meas, cmd);
//   supervisor.finish(meas, report, cmd);   // cmd is now safe to write
//
// Everything here is allocation-free and noexcept.
#pragma once

#include <cstdint>

#include "springbok/hal/hardware.hpp"
#include "springbok/hal/types.hpp"
#include "springbok/safety/limits.hpp"

namespace springbok::safety {

enum class Mode : std::uint8_t { idle = 0, stand_up = 1, stand = 2, control = 3, damping = 4 };
const char* to_string(Mode mode) noexcept;

using FaultMask = std::uint32_t;
namespace fault {
inline constexpr FaultMask kOverrunStreak = 1u << 0;   // N consecutive overruns
inline constexpr FaultMask kOverrunRate = 1u << 1;     // more than R overruns in 1 s
inline constexpr FaultMask kNonFinite = 1u << 2;       // NaN/inf in a measurement
inline constexpr FaultMask kJointLimit = 1u << 3;      // joint beyond its limit + margin
inline constexpr FaultMask kQpFailureStreak = 1u << 4; // N consecutive controller failures
inline constexpr FaultMask kDriveLost = 1u << 5;       // a drive lost or in fault (HAL DriveStatus)
inline constexpr FaultMask kOperatorStop = 1u << 6;    // operator `stop`
inline constexpr FaultMask kHalWatchdog = 1u << 7;     // no fresh HAL data for N ticks
inline constexpr FaultMask kImuLost = 1u << 8;         // the trunk IMU lost in a mode that needs it
inline constexpr FaultMask kWristFtLost = 1u << 9;     // the wrist F/T lost in a mode that needs it
inline constexpr FaultMask kImuClipping = 1u << 10;    // the IMU clipped a streak of samples (CAN.md 6.4)
inline constexpr FaultMask kWristFtClipping = 1u << 11;  // the wrist F/T clipped a streak of samples
inline constexpr int kCount = 12;
}  // namespace fault
// Name of one fault bit (index 0..fault::kCount-1).
const char* fault_name(int bit) noexcept;

enum class OperatorCommand : std::uint8_t { start = 0, stop = 1, mode_stand = 2, mode_control = 3, reset = 4 };
const char* to_string(OperatorCommand command) noexcept;

enum class Verdict : std::uint8_t {
  accepted = 0,
  not_idle,             // start outside idle
  not_standing,         // mode control outside stand
  not_in_control,       // mode stand outside control
  not_in_damping,       // reset outside damping
  unsafe_moving,        // reset while a joint moves faster than the reset speed
  unsafe_measurement,   // reset with non-finite measurements or stale HAL data
  unsafe_joint_limit,   // reset with a joint beyond its limit + margin
  unsafe_drive,         // reset with a drive lost or in fault
  unsafe_timing,        // reset during an overrun streak
  sensor_lost,          // mode control while a sensor the controller needs is lost or clipping
  sensor_not_ready,     // mode control while the IMU's orientation has not converged (CAN.md 6.1)
  controller_not_ready, // mode control while the control law cannot take over (the wrist F/T's tare is being taken)
};
const char* to_string(Verdict verdict) noexcept;

struct SupervisorConfig {
  std::uint32_t overrun_streak_limit = 3;     // N_overrun
  std::uint32_t overrun_rate_limit = 10;      // R_overrun per second
  std::uint32_t hal_watchdog_ticks = 5;       // stale ticks before the watchdog trips
  std::uint32_t qp_failure_streak_limit = 3;
  double limit_margin_rad = 0.05;
  double reset_max_speed_rad_s = 0.05;
  // D: the drives' damping in the damping mode (MIT: kd, in the drive's kd range).
  VecNj damping_nms_per_rad = VecNj::Constant(10.0);
  // D_start: the drives' damping in idle (MIT: kd of the command frame, so it
  // must lie in the drive's kd range; CiA 402: rendered on the host).
  VecNj idle_damping_nms_per_rad = VecNj::Constant(2.0);
  // The sensors the control mode's controller needs (the WBC: both). Lost or in a
  // clipping streak in the control mode (hal::Imu::lost / clip_streak, the same of
  // hal::Wrench): a latched fault; in another mode: a warning (sensors_lost());
  // `mode control` is refused meanwhile, and while the IMU says its orientation has
  // not converged (hal::Imu::converged: the estimator must not start, CAN.md 6.1).
  bool control_needs_imu = false;
  bool control_needs_wrist_ft = false;
};

// What the controller says about its tick.
struct ControllerReport {
  bool ok = true;                // false: failed (QP infeasible, iteration cap, ...)
  bool posture_reached = false;  // stand-up finished
  // Standing: whether the control mode's law could take over now (false while the wrist F/T's
  // tare is being taken: a bias taken as a push otherwise). `mode control` waits for it.
  bool control_ready = true;
};

class Supervisor {
 public:
  explicit Supervisor(const SupervisorConfig& config,
                      const JointLimits& limits = joint_limits_from_model()) noexcept;

  // Checks the tick's inputs; a fault latches and moves to damping. rt: no alloc
  void observe(const hal::Measurements& meas, hal::IoStatus io, std::uint32_t overrun_streak,
               std::uint32_t overruns_in_window) noexcept;
  // One operator command, checked against the mode and the state (call
  // after observe). Anything but `accepted` changes nothing. rt: no alloc
  Verdict request(OperatorCommand command) noexcept;
  // Takes the controller's command and makes it the one to write: disabled
  // in idle, damping in damping, otherwise clamped to the limits (the last
  // good command on a failed tick). rt: no alloc
  void finish(const hal::Measurements& meas, const ControllerReport& report,
              hal::JointCommands& cmd) noexcept;

  Mode mode() const noexcept { return mode_; }
  FaultMask faults() const noexcept { return faults_; }
  // Ticks completed in the current mode (0 in the first tick of a mode).
  std::uint64_t ticks_in_mode() const noexcept { return ticks_in_mode_; }
  std::uint32_t stale_ticks() const noexcept { return stale_ticks_; }
  // The needed sensors lost or clipping at the last observe(), as fault bits (kImuLost,
  // kWristFtLost, kImuClipping, kWristFtClipping), in any mode: the warning outside the
  // control mode.
  FaultMask sensors_lost() const noexcept { return sensors_lost_; }
  // The buses the HAL reported degraded at the last observe() (hal::Measurements::degraded_buses,
  // bit b: the backend's bus b; CAN.md 4: error passive): a warning in every mode, never a fault
  // (the bus still carries every frame; its failures are caught where they happen).
  std::uint32_t degraded_buses() const noexcept { return degraded_buses_; }
  // The joint that latched fault::kJointLimit (-1: none) and its position then.
  int limit_joint() const noexcept { return limit_joint_; }
  double limit_joint_position_rad() const noexcept { return limit_joint_position_rad_; }
  const JointLimits& limits() const noexcept { return limits_; }

  // The drives damp, CAN.md 4.4: kp = 0, kd = D, qd_des = 0; tau_ff takes back
  // what -D qd at the measured speed has beyond the torque limit (0 where the
  // velocity is not finite). rt: no alloc
  void damping_command(const hal::Measurements& meas, hal::JointCommands& cmd) const noexcept;
  // Idle: kp = 0, kd = D_start, qd_des = 0, tau_ff = 0 (the drive damps). rt: no alloc
  void idle_command(hal::JointCommands& cmd) const noexcept;

 private:
  void latch(FaultMask bits) noexcept;
  void enter(Mode mode) noexcept;
  bool measurements_finite(const hal::Measurements& meas) const noexcept;
  // The first bounded joint beyond its limit + margin, -1 when none.
  int joint_beyond_limits(const VecNj& q_rad) const noexcept;
  static bool drives_healthy(const hal::Measurements& meas) noexcept;
  void clamp_to_limits(const hal::Measurements& meas, hal::JointCommands& cmd) const noexcept;

  SupervisorConfig config_;
  JointLimits limits_;
  Mode mode_ = Mode::idle;
  FaultMask faults_ = 0;
  std::uint64_t ticks_in_mode_ = 0;
  std::uint32_t stale_ticks_ = 0;
  std::uint32_t qp_failure_streak_ = 0;
  std::uint32_t overrun_streak_ = 0;
  int limit_joint_ = -1;
  double limit_joint_position_rad_ = 0.0;
  bool have_sequence_ = false;
  std::uint64_t last_sequence_ = 0;
  // The safe-state judgement of the last observe(), for reset.
  bool last_meas_finite_ = false;
  bool last_within_limits_ = false;
  bool last_drives_healthy_ = false;
  double last_max_speed_rad_s_ = 0.0;
  FaultMask sensors_lost_ = 0;
  std::uint32_t degraded_buses_ = 0;
  bool imu_not_converged_ = false;  // the control mode needs the IMU and it says: not converged
  bool control_ready_ = true;       // the last standing tick's ControllerReport::control_ready
  bool have_last_good_ = false;
  hal::JointCommands last_good_;
};

}  // namespace springbok::safety
