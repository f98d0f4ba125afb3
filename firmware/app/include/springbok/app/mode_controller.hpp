// The mode controller: the one place that reads the supervisor's mode and commands the
// joints for it, every tick (ControlLoop calls it whatever the mode):
//
//   idle, damping: nothing (the supervisor writes those commands in finish()); the control
//             law sees the idle ticks (idle(): its estimator's start-up calibration);
//   stand_up: the desired posture moves from the pose at entry to the stand
//             posture along a smoothstep in stand_up_duration_s, or longer where a
//             joint would move faster than kStandUpSpeedFraction of its velocity
//             limit (from a pose far from the stand's: an arm fallen while idle) (with
//             gains.stand_feed_forward weight, the feed-forward takes over the
//             robot's weight along the same smoothstep); done when the ramp
//             ended and every leg joint is within stand_tolerance_rad;
//   stand:    hold the stand posture (joint PD, plus the weight's feed-forward
//             with stand_feed_forward weight), and report whether the control
//             law could take over (`mode control` waits for it);
//   control:  the control law (a ControlLaw: ControlMode in control_mode.hpp, the
//             whole-body controller or JointPdHold), which also observes the
//             stand-up and stand ticks.
// The weight's feed-forward is wbc::stance_gravity_compensation at the measured joints with
// the trunk level (tau = g_j - J_st,j^T f, the four feet carrying the base): a level-ground
// assumption; the PD then only corrects, and the stand does not sag.
#pragma once

#include <algorithm>
#include <cmath>
#include <concepts>
#include <memory>

#include "springbok/app/config.hpp"
#include "springbok/app/operator.hpp"
#include "springbok/app/telemetry.hpp"
#include "springbok/hal/types.hpp"
#include "springbok/model/model.hpp"
#include "springbok/model/robot_state.hpp"
#include "springbok/safety/supervisor.hpp"
#include "springbok/wbc/stand_controller.hpp"

namespace springbok::app {

// The stand-up's peak joint speed at most this fraction of the joint's velocity limit: the PD
// lags and overshoots its reference, and a joint past its limit reads as an implausible reply
// (CAN.md 4.1).
inline constexpr double kStandUpSpeedFraction = 0.5;

// The stand-up's duration for this span (stand posture - pose at entry): configured_s, or
// longer where the smoothstep's peak speed (1.5 span / T) would pass kStandUpSpeedFraction of
// a joint's velocity limit. rt: no alloc
inline double stand_up_ramp_s(const VecNj& span_rad, double configured_s) noexcept {
  double t_s = configured_s;
  for (int j = 0; j < kNj; ++j) {
    const double limit_rad_s = robot::kJoints[static_cast<std::size_t>(j)].limits.velocity_rad_s;
    if (limit_rad_s > 0.0) t_s = std::max(t_s, 1.5 * std::abs(span_rad[j]) / (kStandUpSpeedFraction * limit_rad_s));
  }
  return t_s;
}

struct ControlInput {
  safety::Mode mode = safety::Mode::idle;
  std::uint64_t ticks_in_mode = 0;  // 0 on the first tick of a mode
  double dt_s = 0.001;              // the tick period
  const hal::Measurements* meas = nullptr;
};

// The control law of the control mode; `in.ticks_in_mode` is 0 on its first tick.
// observe() sees the stand-up and stand ticks (an estimator keeps running);
// request() takes an operator's request in `mode` (nullptr: accepted, else why
// not, a static string); publish() writes its state for `controller` (every tick);
// ready() says whether it could take over from the stand now (ControllerReport::control_ready);
// idle() sees the idle ticks (the estimator's start-up calibration, the robot lying still).
template <class C>
concept ControlLaw = requires(C& c, const ControlInput& in, hal::JointCommands& cmd,
                                         const ControllerRequest& r, rt::LatestValue<ControllerSnapshot>& out) {
  { c.compute(in, cmd) } noexcept -> std::same_as<safety::ControllerReport>;
  { c.observe(in) } noexcept;
  { c.request(r, safety::Mode::control) } noexcept -> std::same_as<const char*>;
  { c.publish(out) } noexcept;
  { c.ready() } noexcept -> std::same_as<bool>;
  { c.idle(in) } noexcept;
};

inline constexpr const char* kNotTheWbc = "the control mode runs joint_pd (control.controller), no whole-body controller";

// rt: no alloc
inline void joint_pd_command(const VecNj& q_des_rad, const VecNj& qd_des_rad_s, const JointGains& gains,
                             hal::JointCommands& cmd) noexcept {
  cmd.mode = hal::CommandMode::enabled;
  cmd.q_des_rad = q_des_rad;
  cmd.qd_des_rad_s = qd_des_rad_s;
  cmd.kp_nm_per_rad = gains.kp_nm_per_rad;
  cmd.kd_nms_per_rad = gains.kd_nms_per_rad;
  cmd.tau_ff_nm.setZero();
}

// Hold the stand posture with the control gains (control.controller joint_pd; the
// whole-body controller's safe command while it cannot run).
class JointPdHold {
 public:
  explicit JointPdHold(const AppConfig& config) noexcept
      : posture_rad_(config.stand_posture_rad), gains_(config.control_gains) {}
  safety::ControllerReport compute(const ControlInput&, hal::JointCommands& cmd) noexcept {  // rt: no alloc
    joint_pd_command(posture_rad_, VecNj::Zero(), gains_, cmd);
    return {};
  }
  void observe(const ControlInput&) noexcept {}
  const char* request(const ControllerRequest&, safety::Mode) noexcept { return kNotTheWbc; }
  void publish(rt::LatestValue<ControllerSnapshot>& out) noexcept { out.publish(ControllerSnapshot{}); }
  bool ready() const noexcept { return true; }
  void idle(const ControlInput&) noexcept {}

 private:
  VecNj posture_rad_;
  JointGains gains_;
};

template <ControlLaw Control>
class ModeController {
 public:
  ModeController(const AppConfig& config, Control& control)
      : control_(control),
        posture_rad_(config.stand_posture_rad),
        gains_(config.stand_gains),
        duration_s_(config.stand_up_duration_s),
        tolerance_rad_(config.stand_tolerance_rad),
        weight_feed_forward_(config.stand_weight_feed_forward) {}

  // rt: no alloc
  safety::ControllerReport compute(const ControlInput& in, hal::JointCommands& cmd) noexcept {
    const hal::Measurements& m = *in.meas;
    switch (in.mode) {
      case safety::Mode::stand_up: {
        control_.observe(in);
        if (in.ticks_in_mode == 0) {
          start_rad_ = m.q_rad;
          ramp_s_ = stand_up_ramp_s(posture_rad_ - start_rad_, duration_s_);
        }
        const double t_s = static_cast<double>(in.ticks_in_mode) * in.dt_s;
        const double s = std::clamp(t_s / ramp_s_, 0.0, 1.0);
        const double blend = s * s * (3.0 - 2.0 * s);                      // smoothstep
        const double blend_rate = s < 1.0 ? 6.0 * s * (1.0 - s) / ramp_s_ : 0.0;
        const VecNj span = posture_rad_ - start_rad_;
        joint_pd_command(start_rad_ + blend * span, blend_rate * span, gains_, cmd);
        if (weight_feed_forward_) cmd.tau_ff_nm = blend * weight_feed_forward(m.q_rad);
        safety::ControllerReport report;
        // Standing is the legs' posture.
        report.posture_reached =
            s >= 1.0 &&
            (m.q_rad - posture_rad_).head<kFirstArmJoint>().cwiseAbs().maxCoeff() <= tolerance_rad_;
        return report;
      }
      case safety::Mode::stand: {
        control_.observe(in);
        joint_pd_command(posture_rad_, VecNj::Zero(), gains_, cmd);
        if (weight_feed_forward_) cmd.tau_ff_nm = weight_feed_forward(m.q_rad);
        safety::ControllerReport report;
        report.control_ready = control_.ready();
        return report;
      }
      case safety::Mode::control:
        return control_.compute(in, cmd);
      case safety::Mode::idle:
        control_.idle(in);
        break;  // the supervisor writes the command
      case safety::Mode::damping:
        break;  // the supervisor writes the command
    }
    return {};
  }

  // The control law's. rt: no alloc
  const char* request(const ControllerRequest& r, safety::Mode mode) noexcept { return control_.request(r, mode); }
  void publish(rt::LatestValue<ControllerSnapshot>& out) noexcept { control_.publish(out); }
  // The control law's part of a telemetry record, where it has one. rt: no alloc
  void telemetry(TelemetryRecord& r) const noexcept {
    if constexpr (requires(const Control& c, TelemetryRecord& t) { c.telemetry(t); }) control_.telemetry(r);
  }

 private:
  // The joint torques that hold the robot up on its four feet at q_rad, the trunk level. rt: no alloc
  const VecNj& weight_feed_forward(const VecNj& q_rad) noexcept {
    q_level_.tail<kNj>() = q_rad;
    wbc::stance_gravity_compensation(model_, *data_, q_level_, forces_);
    return forces_.tau_gravity_nm;
  }

  Control& control_;
  dyn::Model model_;
  std::unique_ptr<dyn::Data> data_ = std::make_unique<dyn::Data>();
  VecNq q_level_ = RobotState{}.q;  // the base at the origin, level
  wbc::StanceForces forces_;
  VecNj posture_rad_;
  VecNj start_rad_ = VecNj::Zero();
  JointGains gains_;
  double duration_s_;
  double ramp_s_ = 0.0;  // this stand-up's (stand_up_ramp_s at its entry)
  double tolerance_rad_;
  bool weight_feed_forward_;
};

}  // namespace springbok::app
