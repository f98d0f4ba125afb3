// The drives' joints as the joints of sim_hal's Bullet robot (HIL: the deployed
// binary against a simulated robot). LOCKSTEP: the world steps once per host tick,
// when every enabled drive has its cyclic command of that tick (MIT: one command
// per drive; CiA 402: the SYNC); each drive replies with the state measured before
// that step. The emulator holds back a drive's next command until the step (so a
// slow emulator never steps early); when frames were lost it forces the step with
// the stored commands of the drives still missing theirs (force_step). Built only
// with Bullet (SPRINGBOK_BUILD_SIM).
#pragma once

#include <array>
#include <cstdint>
#include <cstdio>
#include <memory>

#include "springbok/drive_emulator/drives.hpp"
#include "springbok/model/model.hpp"

namespace springbok::app {
class SteppedBulletRobot;
}

namespace springbok::emu {

// The simulated robot's ground truth over the run (what the HIL test asserts on).
struct TruthSummary {
  std::uint64_t steps = 0;
  double time_s = 0.0;
  double trunk_z_m = 0.0;                 // now
  double trunk_tilt_rad = 0.0;            // now: angle between the trunk z axis and the world z axis
  bool non_foot_ground_contact = false;   // now
  std::uint64_t forced_steps = 0;         // steps without every enabled drive's command (a frame was lost)
};

class BulletMotion final : public Motion {
 public:
  // The robot spawns as the deployed loop's simulation does (app::crouched_sim_config,
  // set down on its feet), then lies unpowered for `settle_s` (the drives off: it comes to
  // rest before the host sees it). `trace` (may be null) gets one line "t_s trunk_z_m
  // tilt_rad non_foot_contact" every `trace_every` steps; time 0 is the end of the settling.
  BulletMotion(std::FILE* trace, int trace_every, double settle_s = 0.0);
  ~BulletMotion() override;
  BulletMotion(const BulletMotion&) = delete;
  BulletMotion& operator=(const BulletMotion&) = delete;

  JointState command(int joint, const DriveLaw& law) override;
  void set_enabled(int joint, bool enabled) override;
  JointState state(int joint) const override;
  bool pending(int joint) const override { return pending_[static_cast<std::size_t>(joint)]; }
  void force_step() override;

  const TruthSummary& truth() const noexcept { return truth_; }

 private:
  void step();

  std::unique_ptr<app::SteppedBulletRobot> robot_;
  std::array<DriveLaw, kNj> law_{};
  std::array<bool, kNj> enabled_{};
  std::array<bool, kNj> pending_{};
  std::array<JointState, kNj> state_{};
  std::array<double, kNj> kd_cap_{}, kp_cap_{};  // what one 1 ms step renders stably (see step())
  TruthSummary truth_;
  std::FILE* trace_;
  int trace_every_;
  double time_origin_s_ = 0.0;
};

}  // namespace springbok::emu
