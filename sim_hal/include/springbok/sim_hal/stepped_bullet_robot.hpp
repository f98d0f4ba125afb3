// The simulated robot (sim_hal's Bullet world) as the HAL of the deployed
// loop: each write applies the command and steps the world by one tick, so
// the loop's clock drives the simulated time. configure() sets the robot
// down with its lowest foot on the ground.
#pragma once

#include "springbok/hal/hardware.hpp"
#include "springbok/sim_hal/bullet_robot.hpp"

namespace springbok::sim {

class SteppedBulletRobot final : public hal::Hardware {
 public:
  explicit SteppedBulletRobot(const SimConfig& config) : robot_(config) {}
  std::string_view name() const noexcept override { return "bullet (simulated robot)"; }
  hal::LifecycleResult configure() override {
    hal::LifecycleResult result = robot_.configure();
    if (!result.ok) return result;
    VecNq q = robot_.config().initial_q;
    q[2] -= robot_.lowest_foot_clearance_m() - 0.001;
    robot_.set_state(q, VecNv::Zero());
    return result;
  }
  hal::LifecycleResult activate() override { return robot_.activate(); }
  hal::IoStatus read(hal::Measurements& out) noexcept override { return robot_.read(out); }  // rt: no alloc
  hal::IoStatus write(const hal::JointCommands& cmd) noexcept override {                   // rt: no alloc
    const hal::IoStatus status = robot_.write(cmd);
    robot_.step();
    return status;
  }
  void deactivate() noexcept override { robot_.deactivate(); }

  BulletRobot& robot() noexcept { return robot_; }

 private:
  BulletRobot robot_;
};

// Lying on the folded legs (the robot file's lying_rad), trunk level (configure() lowers it
// onto the feet).
inline SimConfig crouched_sim_config(int rate_hz) {
  SimConfig sim;
  sim.step_s = 1.0 / rate_hz;
  sim.initial_q[2] = 1.0;
  for (int j = 0; j < kNj; ++j) sim.initial_q[7 + j] = robot::kLying_rad[static_cast<std::size_t>(j)];
  return sim;
}

}  // namespace springbok::sim
