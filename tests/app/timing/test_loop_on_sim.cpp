// The loop against the simulated robot (sim_hal, Bullet) on the stepped
// clock: left idle, the crouched robot settles under the drives' damping
// without a joint-limit fault; it stands up from a crouch without a fault, and a whole tick
// (read -> controller -> safety -> write + physics step) allocates nothing;
// in control mode the whole-body controller on the estimated base state
// renders a push at the hand, and the operator's requests switch it between
// stand and trot and re-tare the wrist F/T.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>

#include "alloc_trap.hpp"
#include "springbok/app/control_mode.hpp"
#include "springbok/app/operator_server.hpp"
#include "loop_fixture.hpp"
#include "springbok/can/config_yaml.hpp"
#include "springbok/can/mit.hpp"
#include "springbok/can/sensors.hpp"
#include "springbok/sim_hal/stepped_bullet_robot.hpp"
#include "template_oracle.hpp"

namespace springbok::app::test {
namespace {

using sim::SteppedBulletRobot;
using sim::crouched_sim_config;

using Rig = LoopRig<SteppedBulletRobot>;

// The crouched robot left idle for `ticks` (1 kHz) with D_start = `idle_damping`.
struct IdleRun {
  double worst_leg_excursion_rad = 0.0;  // furthest past a leg joint's limit (<= 0: never reached it)
  double peak_leg_speed_rad_s = 0.0;
  double final_max_speed_rad_s = 0.0;
  safety::Mode mode = safety::Mode::idle;
  safety::FaultMask faults = 0;
};
IdleRun leave_idle(const VecNj& idle_damping_nms_per_rad, int ticks) {
  rt::SteppedClock clock(0);
  SteppedBulletRobot robot(crouched_sim_config(1000));
  EXPECT_TRUE(robot.configure().ok);
  EXPECT_TRUE(robot.activate().ok);
  AppConfig config = test_config();
  config.safety.idle_damping_nms_per_rad = idle_damping_nms_per_rad;
  auto rig = std::make_unique<Rig>(clock, robot, config);
  const safety::JointLimits limits = safety::joint_limits_from_model();
  IdleRun run;
  run.worst_leg_excursion_rad = -1.0;
  for (int t = 0; t < ticks; ++t) {
    rig->executive->run_tick();
    const hal::Measurements& m = rig->loop.measurements();
    for (int j = 0; j < kFirstArmJoint; ++j) {
      run.worst_leg_excursion_rad =
          std::max({run.worst_leg_excursion_rad, m.q_rad[j] - limits.upper_rad[j], limits.lower_rad[j] - m.q_rad[j]});
    }
    run.peak_leg_speed_rad_s =
        std::max(run.peak_leg_speed_rad_s, m.qd_rad_s.head<kFirstArmJoint>().cwiseAbs().maxCoeff());
  }
  run.final_max_speed_rad_s = rig->loop.measurements().qd_rad_s.cwiseAbs().maxCoeff();
  run.mode = rig->supervisor.mode();
  run.faults = rig->supervisor.faults();
  return run;
}

// Idle is damping (CAN.md 4.2 step 5). Damping cannot hold 95 kg up: the crouched robot
// folds onto its knee stops either way, but with D_start it arrives at half the speed and
// settles there, within the supervisor's margin of the stops. With zero torque (the old idle)
// the legs hit the stops twice as fast and the limp arm is still swinging 5 s later.
TEST(LoopOnSim, IdleDampsSoTheCrouchedRobotSettlesWithoutAJointLimitFault) {
  VecNj d_start;  // the shipped D_start: legs 20, arm 0.4 Nms/rad
  d_start << VecNj::Constant(20.0).head<kFirstArmJoint>(), VecNj::Constant(0.4).tail<kArmJoints>();
  const IdleRun damped = leave_idle(d_start, 5000);
  EXPECT_EQ(damped.faults, 0u) << fault_list(damped.faults);
  EXPECT_EQ(damped.mode, safety::Mode::idle);
  EXPECT_LT(damped.worst_leg_excursion_rad, safety::SupervisorConfig{}.limit_margin_rad);
  EXPECT_LT(damped.final_max_speed_rad_s, 1.0) << "settled";

  const IdleRun limp = leave_idle(VecNj::Zero(), 5000);
  EXPECT_GT(limp.peak_leg_speed_rad_s, 1.5 * damped.peak_leg_speed_rad_s);
  EXPECT_GT(limp.final_max_speed_rad_s, 2.0) << "not settled";
}

// The simulated robot's drives configured and active.
void power_on(SteppedBulletRobot& robot) {
  ASSERT_TRUE(robot.configure().ok);
  ASSERT_TRUE(robot.activate().ok);
}

// `config` standing up from a crouch in 1 s, within 0.15 rad of the posture (a joint PD without
// gravity compensation sags under 95 kg).
AppConfig quick_stand_up(AppConfig config) {
  config.stand_up_duration_s = 1.0;
  config.stand_tolerance_rad = 0.15;
  return config;
}

// The test config standing up quickly on stiff leg gains (control mode: the same).
AppConfig stand_up_config() {
  AppConfig config = quick_stand_up(test_config());
  config.stand_gains.kp_nm_per_rad.head<kFirstArmJoint>().setConstant(1000.0);
  config.stand_gains.kd_nms_per_rad.head<kFirstArmJoint>().setConstant(20.0);
  config.control_gains = config.stand_gains;
  return config;
}

TEST(LoopOnSim, StandsUpFromACrouchAndHolds) {
  rt::SteppedClock clock(0);
  SteppedBulletRobot robot(crouched_sim_config(1000));
  ASSERT_NO_FATAL_FAILURE(power_on(robot));
  AppConfig config = stand_up_config();
  auto rig = std::make_unique<Rig>(clock, robot, config);
  rig->executive->run_ticks(10);
  ASSERT_EQ(rig->command(safety::OperatorCommand::start), safety::Verdict::accepted);
  rig->executive->run_ticks(3000);
  EXPECT_EQ(rig->supervisor.faults(), 0u) << fault_list(rig->supervisor.faults());
  EXPECT_EQ(rig->supervisor.mode(), safety::Mode::stand)
      << "posture error [rad]: " << (rig->loop.measurements().q_rad - config.stand_posture_rad).transpose();
  // The trunk rose: legs at the stand posture put the feet about 0.61 m below it.
  const double trunk_z_m = robot.robot().ground_truth().q[2];
  EXPECT_GT(trunk_z_m, 0.5);

  ASSERT_EQ(rig->command(safety::OperatorCommand::mode_control), safety::Verdict::accepted);
  springbok::test::AllocationTrap trap;
  rig->executive->run_ticks(200);
  const std::size_t allocations = trap.disarm();
  EXPECT_EQ(allocations, 0u);
  EXPECT_EQ(rig->supervisor.mode(), safety::Mode::control);
}

TEST(LoopOnSim, ControlModeRunsTheWholeBodyControllerOnTheEstimatedState) {
  rt::SteppedClock clock(0);
  SteppedBulletRobot robot(crouched_sim_config(1000));
  ASSERT_NO_FATAL_FAILURE(power_on(robot));
  AppConfig config = stand_up_config();
  config.stand_posture_rad.tail<kArmJoints>() << 0.0, 0.6, 0.0, 1.9, 0.0, 0.9, 0.0;  // arm bent, off singularity
  config.control_mode = ControlModeKind::wbc;
  config.control.wbc.template_params.mass_base_kg.setConstant(4.0);  // fast: settles within a second
  config.control.wbc.template_params.damping_base_ns_per_m.setConstant(126.5);
  auto rig = std::make_unique<LoopRig<SteppedBulletRobot, ControlMode>>(clock, robot, config);
  rig->executive->run_ticks(10);
  ASSERT_EQ(rig->command(safety::OperatorCommand::start), safety::Verdict::accepted);
  // The crouch's straight arm bends to the posture's: the stand-up takes 4.1 s, not 1 s (the
  // elbow's 1.9 rad at half its velocity limit, kStandUpSpeedFraction).
  rig->executive->run_ticks(5500);
  ASSERT_EQ(rig->supervisor.mode(), safety::Mode::stand);
  ASSERT_EQ(rig->command(safety::OperatorCommand::mode_control), safety::Verdict::accepted);
  rig->executive->run_ticks(300);  // hold the reference
  const Eigen::Isometry3d ee_start = robot.robot().frame_placement(*sim::find_frame("arm_end_effector_link"));
  sim::ExternalWrench push;
  push.frame = *sim::find_frame("arm_end_effector_link");
  push.axis_world = Vec3::UnitX();
  push.profile.amplitude = 30.0;
  push.profile.start_s = robot.robot().time_s();
  EXPECT_TRUE(robot.robot().add_external_wrench(push));
  springbok::test::AllocationTrap trap;
  rig->executive->run_ticks(200);
  const std::size_t allocations = trap.disarm();
  EXPECT_EQ(allocations, 0u);
  rig->executive->run_ticks(2300);
  EXPECT_EQ(rig->supervisor.mode(), safety::Mode::control);
  EXPECT_EQ(rig->supervisor.faults(), 0u) << fault_list(rig->supervisor.faults());
  EXPECT_EQ(rig->control.controller().failed_ticks(), 0u);
  EXPECT_EQ(rig->control.controller().estimate().status, est::EstimateStatus::ok);
  // The template's static displacement of the hand for 30 N: F/K_b + F/K_e = 0.03 + 0.06 m.
  // (Bullet's feet creep a little under the push, which the estimator cannot see.)
  const double ee_dx = robot.robot().frame_placement(*sim::find_frame("arm_end_effector_link")).translation().x() -
                       ee_start.translation().x();
  EXPECT_NEAR(ee_dx, 0.09, 0.02);
  EXPECT_GT(robot.robot().ground_truth().q[2], 0.5);
}

// The shipped configuration's controller (control.wbc), standing up as in the HIL config.
AppConfig shipped_wbc_config() {
  const ConfigResult loaded = load_config_file(SPRINGBOK_APP_CONFIG);
  EXPECT_TRUE(loaded.ok);
  AppConfig config = quick_stand_up(loaded.config);
  config.control.tare_samples = 300;
  return config;
}

// The operator's controller requests through the mailbox, as the socket sends them:
// gait changes only in the control mode, stand -> trot -> stand on the simulated robot
// (every foot lifts, all four down after the stop, no fault), a tare in stand; and
// `controller` reports it.
TEST(LoopOnSim, TheOperatorSwitchesStandTrotStandAndRetares) {
  rt::SteppedClock clock(0);
  SteppedBulletRobot robot(crouched_sim_config(1000));
  ASSERT_NO_FATAL_FAILURE(power_on(robot));
  const AppConfig config = shipped_wbc_config();
  ASSERT_EQ(config.control_mode, ControlModeKind::wbc);
  auto rig = std::make_unique<LoopRig<SteppedBulletRobot, ControlMode>>(clock, robot, config);
  OperatorServer server(rig->mailbox, rig->status, rig->executive->published());  // not opened: reports only
  ControllerRequest trot;
  trot.kind = ControllerRequest::Kind::gait;
  trot.gait.kind = control::GaitKind::trot;
  trot.gait.trot.step_frequency_hz = 1.4;
  trot.gait.trot.duty_factor = 0.65;
  ControllerRequest stand;
  stand.kind = ControllerRequest::Kind::gait;
  stand.gait.kind = control::GaitKind::stand;
  const ControllerRequest tare;  // Kind::tare

  rig->executive->run_ticks(10);
  EXPECT_STREQ(rig->request(trot), "gait changes need mode control");
  ASSERT_EQ(rig->command(safety::OperatorCommand::start), safety::Verdict::accepted);
  rig->executive->run_ticks(5000);  // the arm's bend at half its velocity limits: 4.1 s
  ASSERT_EQ(rig->supervisor.mode(), safety::Mode::stand);
  EXPECT_STREQ(rig->request(trot), "gait changes need mode control");
  EXPECT_EQ(rig->control.controller().tare().completed, 1u) << "tared in stand";
  EXPECT_EQ(rig->request(tare), nullptr);  // a second tare, in stand: collected now
  EXPECT_TRUE(rig->control.controller().tare().running);
  // The control mode waits for it: the F/T's bias would be a push there.
  rig->executive->run_ticks(10);
  EXPECT_EQ(rig->command(safety::OperatorCommand::mode_control), safety::Verdict::controller_not_ready);
  EXPECT_EQ(rig->supervisor.mode(), safety::Mode::stand);
  EXPECT_TRUE(rig->control.controller().tare().running) << "still collecting in stand";
  rig->executive->run_ticks(config.control.tare_samples);
  EXPECT_EQ(rig->control.controller().tare().completed, 2u);

  ASSERT_EQ(rig->command(safety::OperatorCommand::mode_control), safety::Verdict::accepted);
  rig->executive->run_ticks(300);
  EXPECT_EQ(rig->request(trot), nullptr);
  std::array<bool, kFeet> lifted{};
  for (int t = 0; t < 3000; ++t) {
    rig->executive->run_tick();
    for (int f = 0; f < kFeet; ++f) lifted[f] = lifted[f] || !rig->control.controller().state().stance[f];
  }
  EXPECT_EQ(rig->control.controller().gait_state(), control::GaitState::trot);
  for (int f = 0; f < kFeet; ++f) EXPECT_TRUE(lifted[f]) << "foot " << f;
  std::string report = server.handle_line("controller");
  EXPECT_NE(report.find("ok controller controller=wbc engaged=1 gait=trot step_frequency=1.4 duty_factor=0.65"),
            std::string::npos)
      << report;

  // A hand move on the operator's command while trotting: the hand's rest point 5 cm forward
  // (the rest pose's horizontal frame) along a minimum-jerk path over 0.5 s.
  ControllerRequest hand;
  hand.kind = ControllerRequest::Kind::hand;
  hand.hand_target = {0.05, 0.0, 0.0};
  hand.hand_duration_s = 0.5;
  const Vec3 rest_before = rig->control.controller().wbc().reference().ee_position_m;
  EXPECT_EQ(rig->request(hand), nullptr);
  rig->executive->run_ticks(600);
  const Mat3& heading = rig->control.controller().wbc().engaged_reference().base_rotation;
  const Vec3 forward = Vec3(heading(0, 0), heading(1, 0), 0.0).normalized();
  EXPECT_NEAR((rig->control.controller().wbc().reference().ee_position_m - rest_before).dot(forward), 0.05, 1e-3);
  hand.hand_target = {0.3, 0.0, 0.0};
  EXPECT_STREQ(rig->request(hand), "target more than 0.25 m from the hand's rest point");

  // Live tuning while trotting: the template's base stiffness to 1500 N/m over 0.5 s.
  ControllerRequest tune;
  tune.kind = ControllerRequest::Kind::tune;
  tune.tune.set[control::TuningRequest::base_stiffness] = true;
  tune.tune.value[control::TuningRequest::base_stiffness] = {1500.0, 1500.0, 1500.0};
  tune.tune.ramp_s = 0.5;
  EXPECT_EQ(rig->request(tune), nullptr);
  rig->executive->run_ticks(250);
  EXPECT_NEAR(rig->control.controller().wbc().params().template_params.stiffness_base_n_per_m.x(),
              0.5 * (config.control.wbc.template_params.stiffness_base_n_per_m.x() + 1500.0), 5.0);
  rig->executive->run_ticks(300);
  EXPECT_EQ(rig->control.controller().wbc().params().template_params.stiffness_base_n_per_m, Vec3::Constant(1500.0));
  tune.tune.value[control::TuningRequest::base_stiffness] = {0.0, 1500.0, 1500.0};
  EXPECT_STREQ(rig->request(tune), "tuning values out of range");

  // Walking on command while trotting: 0.2 m/s forward for 2 s (ramped at 0.5 m/s^2).
  ControllerRequest walk;
  walk.kind = ControllerRequest::Kind::walk;
  walk.velocity = {0.2, 0.0, 0.0};
  const double x_before_m = robot.robot().ground_truth().q[0];
  EXPECT_EQ(rig->request(walk), nullptr);
  rig->executive->run_ticks(2000);
  EXPECT_NEAR(robot.robot().ground_truth().q[0] - x_before_m, 0.2 * (2.0 - 0.2), 0.08);
  walk.velocity = {0.0, 0.0, 0.0};
  EXPECT_EQ(rig->request(walk), nullptr);
  rig->executive->run_ticks(500);

  EXPECT_EQ(rig->request(stand), nullptr);
  rig->executive->run_ticks(1000);  // the swinging feet land within a swing time (0.25 s)
  EXPECT_STREQ(rig->request(walk), "walking needs the trot (mode control, gait trot)");
  EXPECT_EQ(rig->control.controller().gait_state(), control::GaitState::stand);
  EXPECT_EQ(rig->control.controller().state().stance, kAllFeet);
  EXPECT_EQ(rig->request(tare), nullptr);  // in control: taken at the next stand, never during a push
  rig->executive->run_ticks(100);
  EXPECT_TRUE(rig->control.controller().tare().running);
  EXPECT_EQ(rig->control.controller().tare().samples, 0u);
  report = server.handle_line("controller");
  EXPECT_NE(report.find("gait=stand step_frequency=1.4 duty_factor=0.65 stance=lf,rf,lh,rh last_tick=ok failed_ticks=0"),
            std::string::npos)
      << report;
  EXPECT_NE(report.find("tare=collecting tares=2 "), std::string::npos) << report;
  EXPECT_NE(report.find(" stepping_for_push=0"), std::string::npos) << report;
  const control::TickReport& tick = rig->control.controller().report();
  char bias[128];
  std::snprintf(bias, sizeof bias, " gyro_bias_rad_s=%.5f,%.5f,%.5f gyro_calibrated_s=%.1f", tick.gyro_bias_i_rad_s.x(),
                tick.gyro_bias_i_rad_s.y(), tick.gyro_bias_i_rad_s.z(), tick.gyro_calibrated_s);
  EXPECT_NE(report.find(bias), std::string::npos) << report;
  EXPECT_EQ(rig->supervisor.mode(), safety::Mode::control);
  EXPECT_EQ(rig->supervisor.faults(), 0u) << fault_list(rig->supervisor.faults());
  EXPECT_GT(robot.robot().ground_truth().q[2], 0.5);
  EXPECT_FALSE(robot.robot().ground_truth().non_foot_ground_contact);

  // Leaving the control mode ends the operator's gait: the next engagement stands.
  ASSERT_EQ(rig->command(safety::OperatorCommand::mode_stand), safety::Verdict::accepted);
  rig->executive->run_ticks(config.control.tare_samples + 10);
  EXPECT_EQ(rig->control.controller().tare().completed, 3u);
  EXPECT_STREQ(rig->request(trot), "gait changes need mode control");
  EXPECT_STREQ(rig->request(tune), "tuning needs mode control");
  EXPECT_STREQ(rig->request(hand), "hand moves need mode control");
}

// The MIT wire between the loop and the simulated robot, as the CAN backend and the drive
// emulator run it: every command encoded by the host (rounding) and decoded by the drive,
// every reply encoded by the drive (truncating, as bgkatz firmware and the emulator do),
// decoded by the host and its velocity through the backend's observer (the config's
// can.mit_velocity_observer_rad_s), with the ranges of `can`; each joint with the viscous
// friction of the emulator's joints (emu::JointModel: 0.5 N m s/rad) and the emulator's caps on
// what a 1 ms step renders (kd <= I / dt, kp <= I / (4 dt^2), I = joint_own_axis_inertia_kgm2:
// the wrist's last joint damps at 0.24, not 0.5).
// The trunk IMU and the wrist F/T go through CAN.md 6's counts and the backend's assemblers
// (the IMU's q_w reconstructed by the host: OrientationTrack).
class MitWire final : public hal::Hardware {
 public:
  MitWire(hal::Hardware& inner, const can::CanConfig& can) : inner_(inner) {
    for (const can::BusConfig& b : can.buses) {
      for (const can::DriveConfig& d : b.drives) {
        const auto j = static_cast<std::size_t>(d.joint);
        ranges_[j] = d.mit_ranges;
        velocity_[j].configure(can.mit_velocity_observer_rad_s, 3.0 * can::mit::velocity_lsb_rad_s(d.mit_ranges));
      }
    }
    imu_.configure(can.sensors.imu, 0);
    ft_.configure(can.sensors.wrist_ft, 0);
  }
  std::string_view name() const noexcept override { return "mit wire"; }
  hal::LifecycleResult configure() override { return inner_.configure(); }
  hal::LifecycleResult activate() override { return inner_.activate(); }
  void deactivate() noexcept override { inner_.deactivate(); }
  hal::IoStatus read(hal::Measurements& m) noexcept override {
    const hal::IoStatus s = inner_.read(m);
    for (int j = 0; j < kNj; ++j) {
      const auto k = static_cast<std::size_t>(j);
      can::Frame f;
      can::mit::Reply r{static_cast<std::uint8_t>(j + 1), m.q_rad[j], m.qd_rad_s[j], m.tau_nm[j]};
      can::mit::encode_reply(0x101, r, ranges_[k], can::mit::kReplyLen, f);
      (void)can::mit::decode_reply(f, ranges_[k], r);
      m.q_rad[j] = r.p_rad;
      m.qd_rad_s[j] = velocity_[k].update(r.p_rad, r.v_rad_s, started_ ? 0.001 : -1.0);
      m.tau_nm[j] = r.t_nm;
    }
    started_ = true;
    ++tick_;
    // The sensors as CAN.md 6 sends them: counts, q_w left to the host (the backend's assemblers).
    if (m.imu.valid) {
      const can::ImuReading r{m.imu.orientation, m.imu.angular_rate_rad_s, m.imu.linear_accel_m_s2};
      std::array<can::Frame, can::kImuFrames> frames{};
      if (!can::encode_imu_sample(imu_.config(), r, static_cast<std::uint8_t>(tick_), can::sensor_status::valid,
                                  frames)) {
        return hal::IoStatus::error;
      }
      for (const can::Frame& f : frames) (void)imu_.push(f, tick_);
      const can::ImuReading d = imu_.reading();
      m.imu.orientation = d.orientation;
      m.imu.angular_rate_rad_s = d.angular_rate_rad_s;
      m.imu.linear_accel_m_s2 = d.linear_accel_m_s2;
    }
    if (m.wrist.valid) {
      Eigen::Vector3d force_s_n = m.wrist.force_n, torque_s_nm = m.wrist.torque_nm;
      if (ft_.config().has_offset) {
        can::wrench_ee_to_sensor(can::wrench_transform(ft_.config().offset), m.wrist.force_n, m.wrist.torque_nm,
                                 force_s_n, torque_s_nm);
      }
      std::array<can::Frame, can::kFtFrames> frames{};
      if (!can::encode_ft_sample(ft_.config(), force_s_n, torque_s_nm, static_cast<std::uint8_t>(tick_),
                                 can::sensor_status::valid, frames)) {
        return hal::IoStatus::error;
      }
      for (const can::Frame& f : frames) (void)ft_.push(f, tick_);
      const can::FtReading d = ft_.reading();
      m.wrist.force_n = d.force_n;
      m.wrist.torque_nm = d.torque_nm;
    }
    return s;
  }
  hal::IoStatus write(const hal::JointCommands& cmd) noexcept override {
    hal::JointCommands q = cmd;
    if (cmd.mode == hal::CommandMode::enabled) {
      for (int j = 0; j < kNj; ++j) {
        const auto k = static_cast<std::size_t>(j);
        can::Frame f;
        can::mit::Command c{cmd.q_des_rad[j], cmd.qd_des_rad_s[j], cmd.kp_nm_per_rad[j], cmd.kd_nms_per_rad[j],
                            cmd.tau_ff_nm[j]};
        if (can::mit::encode_command(1, c, ranges_[k], f) != can::FrameStatus::ok) return hal::IoStatus::error;
        (void)can::mit::decode_command(f, ranges_[k], c);
        q.q_des_rad[j] = c.p_rad;
        q.qd_des_rad_s[j] = c.v_rad_s;
        q.kp_nm_per_rad[j] = c.kp;
        q.kd_nms_per_rad[j] = c.kd;
        q.tau_ff_nm[j] = c.t_nm;
        // The gearbox's viscous friction, as the emulator's joints have it:
        // kd (v_des - qd) - b qd = (kd + b) (kd v_des / (kd + b) - qd).
        const double inertia_kgm2 = joint_own_axis_inertia_kgm2(j);
        q.qd_des_rad_s[j] = c.kd * c.v_rad_s / (c.kd + kViscous_nms_per_rad);
        q.kd_nms_per_rad[j] = std::min(c.kd + kViscous_nms_per_rad, inertia_kgm2 / kStep_s);
        q.kp_nm_per_rad[j] = std::min(c.kp, inertia_kgm2 / (4.0 * kStep_s * kStep_s));
      }
    }
    return inner_.write(q);
  }

 private:
  static constexpr double kViscous_nms_per_rad = 0.5, kStep_s = 0.001;
  hal::Hardware& inner_;
  std::array<can::mit::Ranges, kNj> ranges_{};
  std::array<can::mit::VelocityObserver, kNj> velocity_{};
  bool started_ = false;
  std::uint64_t tick_ = 0;
  can::ImuAssembler imu_;
  can::FtAssembler ft_;
};

// The HIL case of the deployed whole-body controller (tests/hil: DeployedWholeBodyController
// RendersTheTemplateThenTrots) in process and deterministic: the HIL config's controller, the
// robot standing up from the crouch, the MIT wire (codec, velocity observer, joint friction),
// the CAN path's transport delays (CAN.md 3.3: joint states one tick old, the sensors' newest
// sample, commands acting one tick after they are computed; sim::Latency {1, 0, 1}), a 30 N
// step at the hand from 3.0 s to 6.5 s, then a trot (1.4 Hz, d_f 0.65) from 7.0 s to 11.5 s.
// The operator's steps are the HIL case's: start, then mode control as soon as the robot stands
// and the F/T is tared (1.71 s; the arm is still moving there). The scores and bounds are the
// issue's (NRMSE hand <= 5 %, base <= 10 %, steady state within 2 % of F/K; no fall, every foot
// lifts, no fault). What it found: without the velocity observer NRMSE 14 % (as over CAN
// before it); with WbcParams' old attitude gains the trot falls within a cycle; without the
// joints' friction compensated (control.wbc.joint_friction) the hand 8.2 %, base 7.4 % (as
// in HIL: 7.3 %, 6.0 %; engaged 0.3 s later, with the arm settled, the twin had read 2.5 %);
// with the IMU's q_w tracked by the gyro alone the base ends 4 % past F/K; without the
// estimator's position-aided tilt (control.estimator.tilt_gain 0) the base ends 29.2-30.1 mm
// for pushes starting 3.0-5.0 s (up to 2.7 % off), with it 29.8-30.2 mm. Now: NRMSE base
// 0.72 %, end displacement 30.0 mm (F/K 30).
void render_push_then_trot(double push_start_s, const sim::ImuNoise& imu = {}) {
  sim::SimConfig sim_config = crouched_sim_config(1000);
  sim_config.latency = sim::Latency{1, 0, 1};
  sim_config.imu = imu;
  SteppedBulletRobot robot(sim_config);
  ASSERT_TRUE(robot.configure().ok);
  const double kPushStart_s = push_start_s, kPushEnd_s = kPushStart_s + 3.5, kTrotAt_s = kPushEnd_s + 0.5,
               kTrotUntil_s = kTrotAt_s + 4.5;
  constexpr double kForce_n = 30.0;
  const sim::FrameRef hand = *sim::find_frame("arm_end_effector_link");
  sim::ExternalWrench push;
  push.frame = hand;
  push.axis_world = Vec3::UnitX();
  push.profile.amplitude = kForce_n;
  push.profile.start_s = kPushStart_s;
  push.profile.duration_s = kPushEnd_s - kPushStart_s;
  ASSERT_TRUE(robot.robot().add_external_wrench(push));
  ASSERT_TRUE(robot.activate().ok);
  const ConfigResult loaded = load_config_file(SPRINGBOK_HIL_WBC_CONFIG);
  ASSERT_TRUE(loaded.ok) << (loaded.errors.empty() ? "" : loaded.errors.front());
  AppConfig config = loaded.config;
  config.control.tare_samples = 200;  // the file's can.sensors.wrist_ft.tare_samples (read by the CAN backend)
  ASSERT_EQ(config.control.estimator.filter, est::BaseFilter::ekf);
  ASSERT_EQ(config.control_mode, ControlModeKind::wbc);
  const can::ConfigResult can_config = can::load_can_config_file(SPRINGBOK_HIL_WBC_CONFIG);
  ASSERT_TRUE(can_config.ok) << can_config.error;
  MitWire wire(robot, can_config.config);
  rt::SteppedClock clock(0);
  auto rig = std::make_unique<LoopRig<MitWire, ControlMode>>(clock, wire, config);

  const auto now_s = [&] { return robot.robot().time_s(); };
  const auto run_until = [&](double t_s, auto&& each) {
    while (now_s() < t_s - 1e-9) {
      rig->executive->run_tick();
      each();
    }
  };
  rig->executive->run_ticks(10);
  ASSERT_EQ(rig->command(safety::OperatorCommand::start), safety::Verdict::accepted);
  const auto ready = [&] {
    return rig->supervisor.mode() == safety::Mode::stand && rig->control.controller().tare().completed == 1u;
  };
  while (!ready() && now_s() < 4.4) rig->executive->run_tick();
  ASSERT_TRUE(ready()) << "stand and the tare by 4.4 s (HIL: control before the IMU burst at 4.5 s)";
  const double t_control_s = now_s();
  ASSERT_EQ(rig->command(safety::OperatorCommand::mode_control), safety::Verdict::accepted);

  springbok::test::PushScore score(springbok::test::template_axis_x(config.control.wbc.template_params), kPushStart_s,
                                   kPushEnd_s, 0.5);
  double base0_m = 0.0, hand0_m = 0.0;
  int n0 = 0;
  run_until(kPushStart_s, [&] {
    if (now_s() < kPushStart_s - 0.1) return;
    base0_m += robot.robot().ground_truth().q[0];
    hand0_m += robot.robot().frame_placement(hand).translation().x();
    ++n0;
  });
  ASSERT_GT(n0, 50);
  base0_m /= n0;
  hand0_m /= n0;
  run_until(kPushEnd_s, [&] {
    const double t = now_s();
    const double force = t > kPushStart_s && t <= kPushEnd_s ? kForce_n : 0.0;  // the world's force in the step that ended at t
    score.add(t, force, robot.robot().ground_truth().q[0] - base0_m,
              robot.robot().frame_placement(hand).translation().x() - hand0_m);
  });
  run_until(kTrotAt_s, [] {});
  EXPECT_EQ(rig->supervisor.faults(), 0u) << fault_list(rig->supervisor.faults());
  ControllerRequest trot;
  trot.kind = ControllerRequest::Kind::gait;
  trot.gait.kind = control::GaitKind::trot;
  trot.gait.trot.step_frequency_hz = 1.4;
  trot.gait.trot.duty_factor = 0.65;
  ASSERT_EQ(rig->request(trot), nullptr);
  std::array<bool, kFeet> lifted{};
  bool non_foot = false;
  double z_min_m = 1e9, tilt_max_rad = 0.0;
  run_until(kTrotUntil_s, [&] {
    const sim::GroundTruth& gt = robot.robot().ground_truth();
    for (int f = 0; f < kFeet; ++f) lifted[f] = lifted[f] || !gt.foot_contact[f];
    non_foot = non_foot || gt.non_foot_ground_contact;
    z_min_m = std::min(z_min_m, gt.q[2]);
    const Eigen::Quaterniond q_wb(gt.q[6], gt.q[3], gt.q[4], gt.q[5]);
    tilt_max_rad = std::max(tilt_max_rad, std::acos(std::clamp(q_wb.normalized().toRotationMatrix()(2, 2), -1.0, 1.0)));
  });

  std::printf("in process, CAN delays: control from %.3f s; 30 N push: NRMSE base %.2f %% hand %.2f %%, end "
              "displacement base %.4f m (F/K %.4f) hand %.4f m (%.4f); trot: lifted %d%d%d%d, min trunk z %.3f m, max "
              "tilt %.3f rad\n",
              t_control_s, 100 * score.nrmse_base(), 100 * score.nrmse_hand(), score.end_base_m(), score.static_base_m(kForce_n),
              score.end_hand_m(), score.static_hand_m(kForce_n), lifted[0], lifted[1], lifted[2], lifted[3], z_min_m,
              tilt_max_rad);
  ASSERT_GT(score.samples(), 3000);
  EXPECT_LE(score.nrmse_hand(), 0.05);
  EXPECT_LE(score.nrmse_base(), 0.10);
  EXPECT_NEAR(score.end_base_m(), score.static_base_m(kForce_n), 0.02 * score.static_base_m(kForce_n));
  EXPECT_NEAR(score.end_hand_m(), score.static_hand_m(kForce_n), 0.02 * score.static_hand_m(kForce_n));
  EXPECT_EQ(rig->supervisor.mode(), safety::Mode::control);
  EXPECT_EQ(rig->supervisor.faults(), 0u) << fault_list(rig->supervisor.faults());
  EXPECT_EQ(rig->control.controller().gait_state(), control::GaitState::trot);
  for (int f = 0; f < kFeet; ++f) EXPECT_TRUE(lifted[f]) << "foot " << f;
  EXPECT_FALSE(non_foot) << "only the feet touch the ground";
  EXPECT_GT(z_min_m, 0.45);
  EXPECT_LT(tilt_max_rad, 0.3);
}

TEST(LoopOnSim, TheHilConfigRendersAPushThenTrotsWithTheCanPathsDelays) { render_push_then_trot(5.0); }

// The same 0.5 s later: the steady state must not depend on when the push comes (the
// estimated pitch's drift did that: 29.2 mm here without the tilt aid, 2.7 % off; now 29.8 mm).
TEST(LoopOnSim, TheHilConfigHoldsTheSteadyStateForALaterPush) { render_push_then_trot(5.5); }

// The same with an IMU as a MEMS one is (the simulator's model: white noise 5 mrad/s and
// 0.04 m/s^2 per sample, turn-on biases drawn once with std 10 mrad/s and 0.1 m/s^2), three
// draws, within 2 % of F/K: the config's estimator (filter ekf) has the biases in its state.
// With the complementary filter and its position-aided tilt (the config before), biases of
// 1 mrad/s and 0.02 m/s^2 std were covered, 0.05 m/s^2 not (5 % short).
TEST(LoopOnSim, TheHilConfigRendersThePushWithABiasedImu) {
  for (std::uint64_t seed = 1; seed <= 3; ++seed) {
    SCOPED_TRACE("imu seed " + std::to_string(seed));
    render_push_then_trot(5.0, sim::ImuNoise{0.005, 0.04, 0.01, 0.1, seed});
  }
}

TEST(LoopOnSim, TheJointPdControlModeRefusesControllerRequests) {
  rt::SteppedClock clock(0);
  KinematicTestHardware hardware(clock);
  AppConfig config = test_config();
  config.control_mode = ControlModeKind::joint_pd;
  auto rig = std::make_unique<LoopRig<KinematicTestHardware, ControlMode>>(clock, hardware, config);
  OperatorServer server(rig->mailbox, rig->status, rig->executive->published());
  EXPECT_EQ(server.handle_line("controller"), "error: controller: no state published yet");
  const ControllerRequest tare;
  EXPECT_STREQ(rig->request(tare), kNotTheWbc);
  EXPECT_EQ(server.handle_line("controller"), "ok controller controller=joint_pd");
}

}  // namespace
}  // namespace springbok::app::test
