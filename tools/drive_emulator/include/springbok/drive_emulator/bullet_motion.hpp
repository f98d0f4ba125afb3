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
#include <functional>
#include <limits>
#include <memory>

#include "springbok/drive_emulator/drives.hpp"
#include "springbok/hal/types.hpp"
#include "springbok/model/model.hpp"

namespace springbok::sim {
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
  Eigen::Quaterniond trunk_orientation = Eigen::Quaterniond::Identity();  // now: trunk to world
  Eigen::Quaterniond ee_orientation = Eigen::Quaterniond::Identity();     // now: end-effector frame to world
  Eigen::Vector3d imu_gyro_bias_rad_s = Eigen::Vector3d::Zero();  // now: the IMU's gyro bias (IMU axes)
  Eigen::Vector3d imu_accel_bias_m_s2 = Eigen::Vector3d::Zero();  // now: its accelerometer's
};

// A force scripted on the hand (CAN.md 6.5): a step of `force_n` along `axis_world` from
// `start_s` on (time 0 = the end of the settling), applied at the end-effector frame's
// origin in the Bullet world through sim_hal's external wrench API.
struct HandForce {
  double force_n = 0.0;
  Eigen::Vector3d axis_world = Eigen::Vector3d::UnitX();
  double start_s = 0.0;
  double duration_s = std::numeric_limits<double>::infinity();
};

// What the drives were told to do in a step, as the truth trace names it (one letter):
// every drive disabled (o), zero torque (z: no stiffness, no damping, no torque), damping
// (d: the host's damping command, kd > 0 and no position or velocity target; CAN.md 4.2 step 5,
// 4.4), position PD (p: some stiffness), torque (t: a controller's torques).
enum class CommandClass : char { off = 'o', zero = 'z', damping = 'd', position = 'p', torque = 't' };

// sim_hal's sensor presets (sim_hal/include/springbok/sim_hal/sensor_models.hpp).
enum class SensorsPreset : std::uint8_t { ideal, mems, tactical };

struct BulletOptions {
  double settle_s = 0.0;
  // The IMU and the wrist F/T the emulator publishes through sim_hal's sensor model: a preset's
  // IMU (ideal, a BMI088-class mems, a KVH 1775-class tactical) and, for mems and tactical, its
  // realistic wrist F/T (ATI Mini45 class), seeded. The encoders and joint torques stay exact:
  // the drives' replies quantise them in their own protocol. A preset other than ideal and the
  // legacy imu_* below are refused together (the world's configure fails).
  SensorsPreset sensors_preset = SensorsPreset::ideal;
  std::uint64_t sensors_seed = 1;
  // A known part of the IMU's gyro turn-on bias, added to the preset's draw (IMU axes, rad/s).
  Eigen::Vector3d gyro_bias_offset_rad_s = Eigen::Vector3d::Zero();
  // sim_hal's legacy IMU model (sim::ImuNoise): white noise per sample and a constant bias drawn once.
  double imu_gyro_noise_rad_s = 0.0;
  double imu_accel_noise_m_s2 = 0.0;
  double imu_gyro_bias_rad_s = 0.0;
  double imu_accel_bias_m_s2 = 0.0;
  std::uint64_t imu_seed = 1;
  bool hand_force = false;
  HandForce hand;
};

class BulletMotion final : public Motion {
 public:
  // The robot spawns as the deployed loop's simulation does (app::crouched_sim_config,
  // set down on its feet), then lies unpowered for `settle_s` (the drives off: it comes to
  // rest before the host sees it). `trace` (may be null) gets one line every `trace_every`
  // steps; time 0 is the end of the settling, step 1 its first step (the sensors' sample 1):
  //   t_s trunk_z_m tilt_rad non_foot_contact trunk_x_m trunk_y_m hand_x_m hand_y_m hand_z_m
  //   hand_force_x_n hand_force_y_n hand_force_z_n foot_contacts command step
  // (world axes; the hand is the end-effector frame's origin; hand_force the scripted force;
  // foot_contacts a bit per foot, lf 1, rf 2, lh 4, rh 8; command a CommandClass letter).
  BulletMotion(std::FILE* trace, int trace_every, double settle_s = 0.0);
  BulletMotion(std::FILE* trace, int trace_every, const BulletOptions& options);
  ~BulletMotion() override;
  BulletMotion(const BulletMotion&) = delete;
  BulletMotion& operator=(const BulletMotion&) = delete;

  JointState command(int joint, const DriveLaw& law) override;
  void set_enabled(int joint, bool enabled) override;
  JointState state(int joint) const override;
  bool pending(int joint) const override { return pending_[static_cast<std::size_t>(joint)]; }
  void force_step() override;

  const TruthSummary& truth() const noexcept { return truth_; }
  // Called after every world step (not while settling) with the simulated sensors: the
  // IMU (sim_hal's model through the trunk_imu mounting) and the wrist wrench (EE frame).
  void set_step_callback(std::function<void(const hal::Imu&, const hal::Wrench&)> on_step) {
    on_step_ = std::move(on_step);
  }

 private:
  void step();
  CommandClass command_class() const noexcept;

  std::unique_ptr<sim::SteppedBulletRobot> robot_;
  std::array<DriveLaw, kNj> law_{};
  std::array<bool, kNj> enabled_{};
  std::array<bool, kNj> pending_{};
  std::array<JointState, kNj> state_{};
  std::array<double, kNj> kd_cap_{}, kp_cap_{};  // what one 1 ms step renders stably (see step())
  TruthSummary truth_;
  std::FILE* trace_;
  int trace_every_;
  double time_origin_s_ = 0.0;
  bool settled_ = false;  // the constructor's settling steps are over
  std::uint64_t settled_steps_ = 0;
  HandForce hand_;
  bool hand_force_ = false;
  std::function<void(const hal::Imu&, const hal::Wrench&)> on_step_;
};

}  // namespace springbok::emu
