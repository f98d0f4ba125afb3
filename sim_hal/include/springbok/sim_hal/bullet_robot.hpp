// The simulated robot: a `final` HAL backend on a Bullet (3.24, double
// precision) btMultiBody built from the compile-time model springbok::robot.
//
// Lockstep use, one tick per loop:   hw.read(m) -> controller -> hw.write(c) -> hw.step()
// The clock is stepped: step() advances the simulated time by exactly step_s.
// Identical configuration and inputs give bit-identical results.
#pragma once

#include <array>
#include <cstdint>
#include <memory>
#include <string_view>

#include "springbok/hal/hardware.hpp"
#include "springbok/model/model.hpp"
#include "springbok/sim_hal/external_wrench.hpp"
#include "springbok/sim_hal/sensor_models.hpp"

namespace springbok::sim {

// The legacy IMU noise (scenario keys sim.imu.*): white noise as a std per sample at the tick
// rate and a constant turn-on bias drawn once. It maps onto the sensor model (SimConfig::sensors,
// apply_legacy_imu): density = std * sqrt(step_s), turn_on_bias = std, the same random stream
// for the same seed. Setting it (a std > 0) together with a non-ideal sensors.imu is refused.
struct ImuNoise {
  double gyro_noise_rad_s = 0.0;           // white noise std per sample
  double accel_noise_m_s2 = 0.0;
  double gyro_bias_rad_s = 0.0;            // std of a constant bias drawn once
  double accel_bias_m_s2 = 0.0;
  std::uint64_t seed = 1;                  // the IMU's stream while sensors.imu is ideal
  bool active() const noexcept {
    return gyro_noise_rad_s != 0.0 || accel_noise_m_s2 != 0.0 || gyro_bias_rad_s != 0.0 || accel_bias_m_s2 != 0.0;
  }
};

// The deployed CAN path's transport delays (CAN.md 3.3), in ticks. A joint state reaches
// read() `joint_measurement_ticks` ticks after the world was in it (a drive's reply, sampled
// when the command arrives, is read at the next tick's start); the trunk IMU and the wrist
// F/T `sensor_measurement_ticks` after (they push their sample as the world moves); a write()
// acts on the world `command_ticks` steps later (sent at the start of the next tick). All 0:
// the ideal lockstep. The CAN backend against the drive emulator is {1, 0, 1}.
struct Latency {
  static constexpr int kMaxTicks = 4;
  int joint_measurement_ticks = 0;
  int sensor_measurement_ticks = 0;
  int command_ticks = 0;
};

struct SimConfig {
  double step_s = 0.001;                   // one controller tick
  int substeps = 1;                        // physics steps per tick (drive law re-evaluated each)
  int solver_iterations = 10;              // Bullet solver passes; trade-off: tools/scenarios/README.md
  int limit_solver_iterations = 40;       // the passes of a step in which a joint is at a stop
  double gravity_m_s2 = kGravity_m_s2;     // along -z; 0 for weightless tests
  bool ground = true;                      // a flat ground plane at z = 0
  double ground_friction = 0.8;            // the Coulomb coefficient of a foot on the ground
  double ground_restitution = 0.0;
  bool fixed_base = false;                 // trunk welded to the world (tests)
  bool saturate_torques = true;            // clamp drive torques to the joints' limits at their angles
  Rotors rotors = Rotors::included;        // the actuators' rotors (springbok::kRotorInertia_kgm2)
  ImuNoise imu;                            // legacy; see ImuNoise
  SensorModelConfig sensors;               // what the sensors report (sensor_models.hpp); default: ideal
  Latency latency;
  VecNq initial_q = default_q();           // [p_WB, quaternion xyzw, joints]
  VecNv initial_v = VecNv::Zero();         // [v_B, w_B trunk frame, joint rates]

  static VecNq default_q() {
    VecNq q = VecNq::Zero();
    q[6] = 1.0;
    return q;
  }
};

// What a test or a plot may know but a controller on hardware may not.
struct GroundTruth {
  double time_s = 0.0;
  VecNq q = SimConfig::default_q();
  VecNv v = VecNv::Zero();
  std::array<Vec3, kFeet> foot_force_n{};  // force of the ground on each foot, world axes
  std::array<bool, kFeet> foot_contact{};
  Vec3 ground_force_n = Vec3::Zero();      // sum over every robot-ground contact
  bool non_foot_ground_contact = false;    // a link other than a foot touches the ground
  VecNj tau_applied_nm = VecNj::Zero();    // the joint torques of the last step
  VecNj tau_limit_nm = VecNj::Zero();      // the joints' torque limits of the last step (at its angles)
};

class BulletRobot final : public hal::Hardware {
 public:
  static constexpr int kMaxExternalWrenches = 64;  // a 60 s soak of random pushes holds ~30

  explicit BulletRobot(const SimConfig& config);
  ~BulletRobot() override;
  BulletRobot(const BulletRobot&) = delete;
  BulletRobot& operator=(const BulletRobot&) = delete;

  std::string_view name() const noexcept override { return "bullet"; }
  hal::LifecycleResult configure() override;   // builds the world; checks the configuration
  hal::LifecycleResult activate() override;    // drives enabled
  hal::IoStatus read(hal::Measurements& out) noexcept override;        // rt: no alloc
  hal::IoStatus write(const hal::JointCommands& cmd) noexcept override;  // rt: no alloc
  void deactivate() noexcept override;         // drives disabled (no torque)

  // ---- simulation only ----
  // Before activate(); false when the table is full.
  bool add_external_wrench(const ExternalWrench& wrench) noexcept;
  // Advances the world by one tick (step_s, in `substeps` physics steps).
  void step() noexcept;
  // One tick of the robot held where it is: the sensors take their next sample of it, motionless
  // (the IMU its gravity, noise and biases; stamps one tick on); the world, its clock (time_s,
  // the ground truth's) and the wrenches' do not run. A still start-up before the run: the
  // estimator's gyro calibration. rt: no alloc
  void hold_still() noexcept;
  double time_s() const noexcept;
  const GroundTruth& ground_truth() const noexcept;
  // Teleports the robot (after configure); clears the contact report.
  void set_state(const VecNq& q, const VecNv& v) noexcept;
  // World placement of a frame (p = R x + t) for the current state.
  Eigen::Isometry3d frame_placement(const FrameRef& frame) const noexcept;
  // Lowest point of the four foot spheres above the ground [m].
  double lowest_foot_clearance_m() const noexcept;
  const SimConfig& config() const noexcept;
  // The sensor model behind read() (after configure): its per-run draws and its biases now.
  const SensorModel& sensor_model() const noexcept;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace springbok::sim
