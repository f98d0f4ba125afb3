// What the joint drives can render of the firmware's joint commands. An MIT
// drive takes kp and kd in its command frame, quantised over the range
// flashed into it (CAN.md 1.2-1.3); the codec clamps a gain beyond the range,
// so the robot would silently run a weaker controller than configured. A
// CiA 402 drive in cyclic synchronous torque gets a torque: the PD runs on
// the host and has no gain range. Start-up code (allocates).
#pragma once

#include <array>
#include <string>
#include <utility>
#include <vector>

#include "springbok/app/config.hpp"

namespace springbok::app {

struct DriveGainRanges {
  std::array<bool, kNj> in_drive{};     // true: the joint's drive renders kp and kd
  VecNj kp_min = VecNj::Zero(), kp_max = VecNj::Zero();
  VecNj kd_min = VecNj::Zero(), kd_max = VecNj::Zero();
  std::array<std::string, kNj> drive;   // names the drive in messages, e.g. "MIT drive id 3 on bus lf"
  // kd values the backend commands on its own, on every joint (field name, value),
  // e.g. the CAN backend's shut-down damping {"can.timing.damping_kd_nms_per_rad", 2}.
  std::vector<std::pair<std::string, double>> backend_kd;
};

// Every gain the firmware commands through the drives' kp and kd: gains.stand
// (stand-up, stand), gains.control (the joint PD hold, also the WBC's fallback)
// safety.damping_nms_per_rad (kd in damping), safety.idle_damping_nms_per_rad (kd in idle) and the backend's own kd values.
// One line per field that a
// drive cannot render, naming the field, its value, the first such joint, its
// drive and the drive's range; empty when all fit.
std::vector<std::string> check_drive_gains(const AppConfig& config, const DriveGainRanges& ranges);

}  // namespace springbok::app
