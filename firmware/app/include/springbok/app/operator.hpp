// Operator commands: the text protocol of the local UNIX socket and the
// lock-free mailbox that carries checked commands to the RT thread and its
// verdicts back. One line per command, one line per reply:
//
//   the supervisor's:  start | stop | reset | mode stand | mode control | status
//   the controller's:  gait stand | gait trot [key=value ...] | walk VX VY YAW_RATE |
//                      tune key=value ... | hand X Y Z SECONDS | tare | controller
//   the flight recorder's:  dump (its ring to a file now; the reply names the file)
//   -> "ok ..." or "error: ..."  (a malformed line changes nothing)
//
// `gait trot` takes the keys of the scenario's and config's `gait:` map
// (step_frequency, duty_factor, step_height, velocity_gain, touchdown_depth,
// touchdown_force, late_touchdown, force_ramp, velocity_x, velocity_y, yaw_rate),
// checked by the same reader (gait::read_trot_params: the error names the key);
// missing keys keep their defaults. Gait changes are taken in the control mode
// only; `tare` asks for a new wrist F/T tare, collected while the robot stands
// (now in stand, at the next stand otherwise); `controller` reports the
// whole-body controller's state (stepping_for_push=1: the trot under way was started by a push
// standing could not hold, control::PushStepping; a gait request takes it over). `tune`
// (control mode) retunes the template's M, D, K per
// body (base.mass .. ee.stiffness: a number or [x,y,z]; with the rotational template
// rot.base.damping, rot.base.stiffness, rot.ee.inertia, rot.ee.damping, rot.ee.stiffness) and the arm's posture gains
// (posture_kp, posture_kd) over `ramp` seconds (default 1), with the config's ranges
// (control::kTemplateRanges); keys not given keep their values. `hand X Y Z SECONDS`
// (control mode) moves the hand's rest point to that offset from the engaged one (m, the
// rest pose's horizontal frame) along a minimum-jerk path (control::HandTrajectory's limits);
// `hand X Y Z RX RY RZ SECONDS` also turns its rest orientation to that rotation vector
// from the engaged one (rad, same frame; needs the rotational template).
#pragma once

#include <atomic>
#include <array>
#include <cstdint>
#include <string>
#include <string_view>

#include "springbok/control/robot_controller.hpp"
#include "springbok/rt/latest_value.hpp"
#include "springbok/rt/log.hpp"
#include "springbok/rt/spsc_ring.hpp"
#include "springbok/safety/supervisor.hpp"

namespace springbok::app {

inline constexpr std::size_t kMaxOperatorLine = 255;  // bytes, without the newline

// A request for the control mode's controller (taken by the RT thread at a tick).
struct ControllerRequest {
  enum class Kind : std::uint8_t { gait, tare, walk, tune, hand } kind = Kind::tare;
  control::GaitCommand gait;  // with kind == gait
  control::TuningRequest tune;  // with kind == tune
  // With kind == walk: [v_x, v_y, yaw rate], the trunk's horizontal frame (a plain array:
  // requests cross a lock-free ring by value).
  std::array<double, 3> velocity{};
  // With kind == hand: the hand's rest point's offset from the engaged one (m, the rest
  // pose's horizontal frame), its rotation vector from the engaged orientation (rad, the
  // same frame) and the move's duration (s).
  std::array<double, 3> hand_target{};
  std::array<double, 3> hand_rotation{};
  double hand_duration_s = 0.0;
};

struct ParsedLine {
  enum class Kind : std::uint8_t { command, controller_request, status, controller_status, dump, error } kind = Kind::error;
  safety::OperatorCommand command = safety::OperatorCommand::stop;  // Kind::command
  ControllerRequest request;                                        // Kind::controller_request
  std::string name;   // the command as the replies name it ("start", "gait trot")
  std::string error;  // for Kind::error: the reply, "error: ..."
};

// Checks one line (without its newline). Never throws.
ParsedLine parse_operator_line(std::string_view line);

struct OperatorRequest {
  std::uint64_t id = 0;
  safety::OperatorCommand command = safety::OperatorCommand::stop;
  bool for_controller = false;  // request (the controller's) instead of command (the supervisor's)
  ControllerRequest request;
};

struct OperatorReply {
  std::uint64_t id = 0;
  bool accepted = false;
  const char* refusal = nullptr;  // why not (a static string), when !accepted
  safety::Verdict verdict = safety::Verdict::accepted;  // the supervisor's, for its commands
  safety::Mode mode = safety::Mode::idle;  // after the command
  safety::FaultMask faults = 0;
};

struct OperatorMailbox {
  rt::SpscRing<OperatorRequest, 16> requests;  // server thread -> RT thread
  rt::SpscRing<OperatorReply, 16> replies;     // RT thread -> server thread
  // Requests with a smaller id timed out on the server side: never applied.
  std::atomic<std::uint64_t> first_valid_id{0};

  // RT side: the next request still wanted. rt: no alloc, no block
  bool take(OperatorRequest& out) noexcept {
    while (requests.pop(out)) {
      if (out.id >= first_valid_id.load(std::memory_order_acquire)) return true;
    }
    return false;
  }
};

// The control mode's controller as `controller` reports it (published every tick).
struct ControllerSnapshot {
  bool wbc = false;  // control.controller is wbc (joint_pd: nothing else is meaningful)
  control::TickReport report;  // the controller's last tick
};

// What the loop publishes every tick for `status` (read by the server thread).
struct LoopStatus {
  std::atomic<std::uint8_t> mode{0};
  std::atomic<std::uint32_t> faults{0};
  std::atomic<std::uint32_t> stale_ticks{0};
  std::atomic<std::uint64_t> hal_errors{0};  // ticks whose HAL read or write was not ok
  std::atomic<std::int32_t> limit_joint{-1};  // the joint that latched joint_limit, -1: none
  std::atomic<double> limit_joint_position_rad{0.0};
  rt::LatestValue<ControllerSnapshot> controller;
};

// "overrun_streak,hal_watchdog" or "none".
std::string fault_list(safety::FaultMask faults);

// The words of a loop log record (rt::LogDrainer::Describe): modes, fault and
// sensor names, degraded buses, commands and verdicts ("new=imu_lost
// latched=imu_lost", "degraded=bus6 was=none"); "" for records whose numbers say it all.
std::string describe_log_record(const rt::LogRecord& record);

}  // namespace springbok::app
