// The loop against the simulated robot (sim_hal, Bullet) on the stepped
// clock: left idle, the crouched robot settles under the drives' damping
// without a joint-limit fault; it stands up from a crouch without a fault, and a whole tick
// (read -> controller -> safety -> write + physics step) allocates nothing;
// in control mode the whole-body controller on the estimated base state
// renders a push at the hand, and the operator's requests switch it between
// stand and trot and re-tare the wrist F/T.
#include <gtest/gtest.h>

#include <algorithm>

#include "../../../firmware/app/sim/stepped_bullet_robot.hpp"
#include "alloc_trap.hpp"
#include "springbok/app/control_mode.hpp"
#include "springbok/app/operator_server.hpp"
#include "loop_fixture.hpp"

namespace springbok::app::test {
namespace {

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
// folds onto its knee stops either way, but with D_start it arrives slowly and stays there
// (Bullet's stop yields ~0.035 rad under the resting load, inside the 0.05 rad margin).
// With zero torque (the old idle) the fall breaks through the front knee stops and
// latches joint_limit while idle.
TEST(LoopOnSim, IdleDampsSoTheCrouchedRobotSettlesWithoutAJointLimitFault) {
  VecNj d_start;  // the shipped D_start: legs 20, arm 0.4 Nms/rad
  d_start << VecNj::Constant(20.0).head<kFirstArmJoint>(), VecNj::Constant(0.4).tail<kArmJoints>();
  const IdleRun damped = leave_idle(d_start, 5000);
  EXPECT_EQ(damped.faults, 0u) << fault_list(damped.faults);
  EXPECT_EQ(damped.mode, safety::Mode::idle);
  EXPECT_LT(damped.worst_leg_excursion_rad, safety::SupervisorConfig{}.limit_margin_rad);
  EXPECT_LT(damped.final_max_speed_rad_s, 1.0) << "settled";

  const IdleRun limp = leave_idle(VecNj::Zero(), 5000);
  EXPECT_NE(limp.faults & safety::fault::kJointLimit, 0u) << fault_list(limp.faults);
  EXPECT_GT(limp.worst_leg_excursion_rad, 0.5);
  EXPECT_GT(limp.peak_leg_speed_rad_s, 2.0 * damped.peak_leg_speed_rad_s);
}

TEST(LoopOnSim, StandsUpFromACrouchAndHolds) {
  rt::SteppedClock clock(0);
  SteppedBulletRobot robot(crouched_sim_config(1000));
  ASSERT_TRUE(robot.configure().ok);
  ASSERT_TRUE(robot.activate().ok);
  AppConfig config = test_config();
  config.stand_up_duration_s = 1.0;
  config.stand_tolerance_rad = 0.15;  // joint PD without gravity compensation sags under 95 kg
  config.stand_gains.kp_nm_per_rad.head<kFirstArmJoint>().setConstant(1000.0);
  config.stand_gains.kd_nms_per_rad.head<kFirstArmJoint>().setConstant(20.0);
  config.control_gains = config.stand_gains;
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
  ASSERT_TRUE(robot.configure().ok);
  ASSERT_TRUE(robot.activate().ok);
  AppConfig config = test_config();
  config.stand_up_duration_s = 1.0;
  config.stand_tolerance_rad = 0.15;
  config.stand_gains.kp_nm_per_rad.head<kFirstArmJoint>().setConstant(1000.0);
  config.stand_gains.kd_nms_per_rad.head<kFirstArmJoint>().setConstant(20.0);
  config.control_gains = config.stand_gains;
  config.stand_posture_rad.tail<kArmJoints>() << 0.0, 0.6, 0.0, 1.9, 0.0, 0.9, 0.0;  // arm bent, off singularity
  config.control_mode = ControlModeKind::wbc;
  config.wbc.template_params.mass_base_kg.setConstant(4.0);  // fast: settles within a second
  config.wbc.template_params.damping_base_ns_per_m.setConstant(126.5);
  auto rig = std::make_unique<LoopRig<SteppedBulletRobot, ControlMode>>(clock, robot, config);
  rig->executive->run_ticks(10);
  ASSERT_EQ(rig->command(safety::OperatorCommand::start), safety::Verdict::accepted);
  rig->executive->run_ticks(3000);
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
  AppConfig config = loaded.config;
  config.stand_up_duration_s = 1.0;
  config.stand_tolerance_rad = 0.15;
  config.wrist_tare_samples = 300;
  return config;
}

// The operator's controller requests through the mailbox, as the socket sends them:
// gait changes only in the control mode, stand -> trot -> stand on the simulated robot
// (every foot lifts, all four down after the stop, no fault), a tare in stand; and
// `controller` reports it.
TEST(LoopOnSim, TheOperatorSwitchesStandTrotStandAndRetares) {
  rt::SteppedClock clock(0);
  SteppedBulletRobot robot(crouched_sim_config(1000));
  ASSERT_TRUE(robot.configure().ok);
  ASSERT_TRUE(robot.activate().ok);
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
  rig->executive->run_ticks(2500);
  ASSERT_EQ(rig->supervisor.mode(), safety::Mode::stand);
  EXPECT_STREQ(rig->request(trot), "gait changes need mode control");
  EXPECT_EQ(rig->control.controller().tare().completed, 1u) << "tared in stand";
  EXPECT_EQ(rig->request(tare), nullptr);  // a second tare, in stand: collected now
  EXPECT_TRUE(rig->control.controller().tare().running);
  rig->executive->run_ticks(config.wrist_tare_samples + 10);
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

  EXPECT_EQ(rig->request(stand), nullptr);
  rig->executive->run_ticks(1000);  // the swinging feet land within a swing time (0.25 s)
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
  EXPECT_EQ(rig->supervisor.mode(), safety::Mode::control);
  EXPECT_EQ(rig->supervisor.faults(), 0u) << fault_list(rig->supervisor.faults());
  EXPECT_GT(robot.robot().ground_truth().q[2], 0.5);
  EXPECT_FALSE(robot.robot().ground_truth().non_foot_ground_contact);

  // Leaving the control mode ends the operator's gait: the next engagement stands.
  ASSERT_EQ(rig->command(safety::OperatorCommand::mode_stand), safety::Verdict::accepted);
  rig->executive->run_ticks(config.wrist_tare_samples + 10);
  EXPECT_EQ(rig->control.controller().tare().completed, 3u);
  EXPECT_STREQ(rig->request(trot), "gait changes need mode control");
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
