// The real loop (executive + ControlLoop + supervisor + posture controllers)
// on the stepped clock, around a small in-test HAL backend.
#pragma once

#include <memory>

#include "springbok/app/config.hpp"
#include "springbok/app/control_loop.hpp"
#include "springbok/app/mode_controller.hpp"
#include "springbok/hal/hardware.hpp"
#include "springbok/rt/clock.hpp"
#include "springbok/rt/executive.hpp"

namespace springbok::app::test {

// An in-test HAL backend for the executive tests, not a robot model: its
// joints go exactly where the last command's q_des / qd_des put them (an
// ideal position servo), a read can be made to take time on the stepped
// clock, and it can fall silent.
class KinematicTestHardware final : public hal::Hardware {
 public:
  explicit KinematicTestHardware(rt::SteppedClock& clock) : clock_(clock) {
    for (auto& d : state_.drives) d.state = hal::DriveState::enabled;
    for (int leg = 0; leg < kFeet; ++leg) {  // a crouch inside the joint limits
      const double side = leg < 2 ? 1.0 : -1.0;
      state_.q_rad[leg * kLegJoints + 1] = 1.0 * side;
      state_.q_rad[leg * kLegJoints + 2] = -2.0 * side;
    }
  }
  std::string_view name() const noexcept override { return "kinematic test hardware"; }
  hal::LifecycleResult configure() override { return hal::LifecycleResult::success(); }
  hal::LifecycleResult activate() override { return hal::LifecycleResult::success(); }
  hal::IoStatus read(hal::Measurements& out) noexcept override {
    clock_.advance_ns(read_time_ns);
    if (silent) return hal::IoStatus::timeout;
    ++state_.sequence;
    state_.stamp_ns = clock_.now_ns();
    out = state_;
    return hal::IoStatus::ok;
  }
  hal::IoStatus write(const hal::JointCommands& cmd) noexcept override {
    last = cmd;
    ++writes;
    if (cmd.mode == hal::CommandMode::enabled && cmd.kp_nm_per_rad.maxCoeff() > 0.0) {
      state_.q_rad = cmd.q_des_rad;
      state_.qd_rad_s = cmd.qd_des_rad_s;
    } else {
      state_.qd_rad_s.setZero();
    }
    return hal::IoStatus::ok;
  }
  void deactivate() noexcept override {}

  hal::Measurements& state() { return state_; }

  std::int64_t read_time_ns = 100'000;
  bool silent = false;
  hal::JointCommands last;
  std::uint64_t writes = 0;

 private:
  rt::SteppedClock& clock_;
  hal::Measurements state_;
};

inline AppConfig test_config() {
  AppConfig c;
  c.stand_up_duration_s = 0.5;
  c.stand_gains.kp_nm_per_rad.setConstant(100.0);
  c.stand_gains.kd_nms_per_rad.setConstant(2.0);
  c.control_gains = c.stand_gains;
  for (int leg = 0; leg < kFeet; ++leg) {
    const double s = leg < 2 ? 1.0 : -1.0;
    c.stand_posture_rad[leg * 3 + 1] = 0.7 * s;
    c.stand_posture_rad[leg * 3 + 2] = -1.4 * s;
  }
  return c;
}

// Everything the deployed binary wires, with the stepped clock.
template <class Hardware, class Control = JointPdHold>
struct LoopRig {
  using Modes = ModeController<Control>;
  using Loop = ControlLoop<Modes>;

  LoopRig(rt::SteppedClock& c, Hardware& h, const AppConfig& cfg = test_config())
      : config(cfg),
        clock(c),
        hardware(h),
        supervisor(config.safety),
        control(config),
        modes(config, control),
        loop(hardware, modes, supervisor, mailbox, status, &log),
        executive(std::make_unique<rt::Executive<rt::SteppedClock, Loop>>(clock, loop, 1'000'000, &log)) {
    executive->start();
  }

  AppConfig config;
  rt::SteppedClock& clock;
  Hardware& hardware;
  safety::Supervisor supervisor;
  Control control;
  Modes modes;
  OperatorMailbox mailbox;
  LoopStatus status;
  rt::LogRing log;
  Loop loop;
  std::unique_ptr<rt::Executive<rt::SteppedClock, Loop>> executive;

  // An operator command through the mailbox, applied in the next tick.
  safety::Verdict command(safety::OperatorCommand c) {
    OperatorRequest r;
    r.command = c;
    return exchange(r).verdict;
  }
  // A request for the controller: nullptr (accepted) or why not.
  const char* request(const ControllerRequest& c) {
    OperatorRequest r;
    r.for_controller = true;
    r.request = c;
    return exchange(r).refusal;
  }
  OperatorReply exchange(OperatorRequest r) {
    r.id = ++last_id;
    mailbox.requests.push(r);
    executive->run_tick();
    OperatorReply reply;
    while (mailbox.replies.pop(reply)) {
      if (reply.id == last_id) return reply;
    }
    ADD_FAILURE() << "no reply";
    reply.verdict = safety::Verdict::not_idle;
    reply.refusal = "no reply";
    return reply;
  }
  std::uint64_t last_id = 0;
};

}  // namespace springbok::app::test
