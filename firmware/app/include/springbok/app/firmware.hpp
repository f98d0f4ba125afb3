// The firmware around one HAL backend, assembled in one place from the configuration: the
// safety supervisor, the control mode's controller (ControlMode), the mode controller, the
// operator mailbox, the loop's status and the control loop. Every program that runs the robot
// builds this: `springbok` and `springbok-on-sim` (run_firmware, behind the executive and the
// operator socket) and `springbok-sim` (in lockstep with the simulated robot, the scenario as
// its operator). Start-up code; loop().tick() is the real-time path.
#pragma once

#include <memory>

#include "springbok/app/config.hpp"
#include "springbok/app/control_loop.hpp"
#include "springbok/app/control_mode.hpp"
#include "springbok/app/mode_controller.hpp"
#include "springbok/app/operator.hpp"
#include "springbok/hal/hardware.hpp"
#include "springbok/rt/log.hpp"
#include "springbok/safety/supervisor.hpp"

namespace springbok::app {

class Firmware {
 public:
  using Modes = ModeController<ControlMode>;
  using Loop = ControlLoop<Modes>;

  // `log`: the loop's event ring (nullptr: none).
  Firmware(hal::Hardware& hardware, const AppConfig& config, rt::LogRing* log)
      : supervisor_(config.safety),
        control_(std::make_unique<ControlMode>(config)),
        modes_(std::make_unique<Modes>(config, *control_)),
        mailbox_(std::make_unique<OperatorMailbox>()),
        loop_(std::make_unique<Loop>(hardware, *modes_, supervisor_, *mailbox_, status_, log)) {}
  Firmware(const Firmware&) = delete;
  Firmware& operator=(const Firmware&) = delete;

  Loop& loop() noexcept { return *loop_; }
  safety::Supervisor& supervisor() noexcept { return supervisor_; }
  const safety::Supervisor& supervisor() const noexcept { return supervisor_; }
  ControlMode& control() noexcept { return *control_; }
  const ControlMode& control() const noexcept { return *control_; }
  OperatorMailbox& mailbox() noexcept { return *mailbox_; }
  LoopStatus& status() noexcept { return status_; }

 private:
  safety::Supervisor supervisor_;
  std::unique_ptr<ControlMode> control_;
  std::unique_ptr<Modes> modes_;
  std::unique_ptr<OperatorMailbox> mailbox_;
  LoopStatus status_;
  std::unique_ptr<Loop> loop_;
};

}  // namespace springbok::app
