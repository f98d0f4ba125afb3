// The plain, fixed-size structs that cross the hardware boundary once per
// tick: Measurements in (HAL.read), JointCommands out (HAL.write). Nothing
// here knows which backend (SocketCAN drives, Bullet simulation) is linked.
#pragma once

#include <cstdint>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "springbok/model/model.hpp"

namespace springbok::hal {

// State of one joint drive as the backend sees it.
enum class DriveState : std::uint8_t {
  offline = 0,   // not yet seen (no boot-up / heartbeat)
  ready = 1,     // configured, power stage off
  enabled = 2,   // following commands
  fault = 3,     // the drive reports a fault (EMCY, fault bit)
  lost = 4,      // too many missed replies in a row
};

struct DriveStatus {
  DriveState state = DriveState::offline;
  bool fresh = false;                // a new reply arrived for this tick
  std::uint16_t fault_code = 0;      // drive-specific (e.g. CiA 402 EMCY error code)
  std::uint32_t missed_in_row = 0;   // consecutive ticks without a fresh reply
  std::uint64_t missed_total = 0;
  // The drive's supply as it reports it (MIT drives replying with 7 bytes, CAN.md 1.4); 0: not
  // reported. bus_voltage_low: below the backend's warning threshold (a warning: the drive still
  // follows; below its fault threshold the drive is in fault).
  double bus_voltage_v = 0.0;
  bool bus_voltage_low = false;
};

// The status fields below (lost .. age_ticks) are filled by backends that receive the
// sensor over a bus (the SocketCAN backend, CAN.md 6); their defaults describe a healthy
// sensor, as the simulation reports it.
struct Imu {
  bool valid = false;
  std::int64_t stamp_ns = 0;
  Eigen::Quaterniond orientation = Eigen::Quaterniond::Identity();  // IMU frame in world
  Eigen::Vector3d angular_rate_rad_s = Eigen::Vector3d::Zero();     // IMU frame
  Eigen::Vector3d linear_accel_m_s2 = Eigen::Vector3d::Zero();      // specific force, IMU frame
  bool lost = false;          // configured, but no sample within its stale limit (or none yet); valid is false
  bool converged = true;      // false: the sensor says its orientation has not converged (the estimator must not start)
  bool clipping = false;      // a field of the newest sample saturated
  bool clip_streak = false;   // clipping on the configured number of samples in a row: a sensor fault
  std::uint32_t age_ticks = 0;  // ticks since the newest accepted sample
};

// The wrist 6-axis force/torque sensor (springbok::kWristFtFrame). The wrench
// the environment applies to the end-effector, in the sensor frame, about its origin.
struct Wrench {
  bool valid = false;
  std::int64_t stamp_ns = 0;
  Eigen::Vector3d force_n = Eigen::Vector3d::Zero();
  Eigen::Vector3d torque_nm = Eigen::Vector3d::Zero();
  bool lost = false;          // configured, but no sample within its stale limit (or none yet); valid is false
  bool bias_taken = true;     // false: the sensor says its own bias was not taken
  bool clipping = false;      // a gauge of the newest sample saturated
  bool clip_streak = false;   // clipping on the configured number of samples in a row: a sensor fault
  std::uint32_t age_ticks = 0;  // ticks since the newest accepted sample
};

struct Measurements {
  std::uint64_t sequence = 0;        // increments on every read
  std::int64_t stamp_ns = 0;         // backend clock at the read
  VecNj q_rad = VecNj::Zero();       // joint order of springbok::robot::kJoints
  VecNj qd_rad_s = VecNj::Zero();
  VecNj tau_nm = VecNj::Zero();      // measured joint torque
  std::array<DriveStatus, kNj> drives{};
  // Degraded buses, bit b for the backend's bus b: filled by the SocketCAN backend (the b-th of
  // can.buses whose controller reported error passive, CAN.md 4, until it reports error active
  // again). A warning, not a fault: the bus still carries every frame. Backends without buses
  // (the simulation) leave it 0.
  std::uint32_t degraded_buses = 0;
  Imu imu;
  Wrench wrist;
};

enum class CommandMode : std::uint8_t {
  disabled = 0,  // power stages off: no torque
  enabled = 1,   // each drive applies tau_ff + kp (q_des - q) + kd (qd_des - qd)
};

// One command per joint per tick. With kp = kd = 0 it is a pure torque command;
// damping mode is kp = 0, qd_des = 0, kd = D, tau_ff = 0.
struct JointCommands {
  std::uint64_t sequence = 0;
  CommandMode mode = CommandMode::disabled;
  VecNj tau_ff_nm = VecNj::Zero();
  VecNj q_des_rad = VecNj::Zero();
  VecNj qd_des_rad_s = VecNj::Zero();
  VecNj kp_nm_per_rad = VecNj::Zero();
  VecNj kd_nms_per_rad = VecNj::Zero();
};

// The torque a drive applies for a command and its measured state.
// rt: no alloc, no block
inline double drive_torque_nm(const JointCommands& c, int joint, double q_rad, double qd_rad_s) noexcept {
  if (c.mode != CommandMode::enabled) return 0.0;
  return c.tau_ff_nm[joint] + c.kp_nm_per_rad[joint] * (c.q_des_rad[joint] - q_rad) +
         c.kd_nms_per_rad[joint] * (c.qd_des_rad_s[joint] - qd_rad_s);
}

}  // namespace springbok::hal
