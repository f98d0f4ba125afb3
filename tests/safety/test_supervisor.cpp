// The safety supervisor, tick by tick: every mode transition, every fault
// (latched, damping in the same tick), rejected commands change nothing,
// damping and clamping against the model's limits.
#include <gtest/gtest.h>

#include <bit>
#include <cmath>
#include <limits>
#include <numbers>
#include <utility>

#include "alloc_trap.hpp"
#include "hyq_actuator_oracle.hpp"
#include "springbok/safety/supervisor.hpp"

namespace springbok::safety {
namespace {

using hal::IoStatus;

// The stand posture of PARAMS.md: legs (0, 0.7, -1.4) front, (0, -0.7, 1.4) hind, arm at 0.
VecNj stand_posture() {
  VecNj q = VecNj::Zero();
  for (int leg = 0; leg < kFeet; ++leg) {
    const double s = leg < 2 ? 1.0 : -1.0;
    q[leg * 3 + 1] = 0.7 * s;
    q[leg * 3 + 2] = -1.4 * s;
  }
  return q;
}

struct SupervisorTest : ::testing::Test {
  SupervisorConfig config;
  Supervisor sup{config};
  hal::Measurements meas;
  hal::JointCommands cmd;

  SupervisorTest() {
    meas.q_rad = stand_posture();
    for (auto& d : meas.drives) d.state = hal::DriveState::enabled;
  }
  // One tick with fresh data and a controller command `proposal`.
  void tick(ControllerReport report = {}, IoStatus io = IoStatus::ok, std::uint32_t streak = 0,
            std::uint32_t window = 0, bool fresh = true) {
    if (fresh) ++meas.sequence;
    sup.observe(meas, io, streak, window);
    cmd = proposal;
    sup.finish(meas, report, cmd);
  }
  Verdict ask(OperatorCommand c) { return sup.request(c); }
  // idle -> stand_up -> stand -> control
  void go_to_control() {
    tick();
    ASSERT_EQ(ask(OperatorCommand::start), Verdict::accepted);
    tick({true, true});
    ASSERT_EQ(sup.mode(), Mode::stand);
    ASSERT_EQ(ask(OperatorCommand::mode_control), Verdict::accepted);
    tick();
    ASSERT_EQ(sup.mode(), Mode::control);
  }
  void expect_damping() {
    EXPECT_EQ(sup.mode(), Mode::damping);
    EXPECT_EQ(cmd.mode, hal::CommandMode::enabled);
    for (int j = 0; j < kNj; ++j) {
      const double qd = meas.qd_rad_s[j];
      const double lim = torque_limit_nm(j, meas.q_rad[j]);
      // CAN.md 4.4: the drive damps (kd = D, no target); the torque it applies at the measured
      // speed is -D qd within the limits.
      EXPECT_EQ(cmd.kp_nm_per_rad[j], 0.0);
      EXPECT_EQ(cmd.kd_nms_per_rad[j], config.damping_nms_per_rad[j]) << j;
      EXPECT_EQ(cmd.q_des_rad[j], 0.0);
      EXPECT_EQ(cmd.qd_des_rad_s[j], 0.0);
      if (!std::isfinite(qd)) {
        EXPECT_EQ(cmd.tau_ff_nm[j], 0.0) << j;
        continue;
      }
      const double want = std::clamp(-config.damping_nms_per_rad[j] * qd, -lim, lim);
      EXPECT_NEAR(hal::drive_torque_nm(cmd, j, meas.q_rad[j], qd), want, 1e-12 * (1.0 + std::abs(want))) << j;
      if (std::abs(want) < lim) {
        EXPECT_EQ(cmd.tau_ff_nm[j], 0.0) << j;
      }
    }
  }
  hal::JointCommands proposal = [] {
    hal::JointCommands c;
    c.mode = hal::CommandMode::enabled;
    c.q_des_rad = stand_posture();
    c.kp_nm_per_rad.setConstant(100.0);
    c.kd_nms_per_rad.setConstant(2.0);
    return c;
  }();
};

// CAN.md 4.2 step 5: the loop starts with damping commands, kp = 0, kd = D_start.
TEST_F(SupervisorTest, IdleDampsThroughTheDrivesWithDStart) {
  config.idle_damping_nms_per_rad.head<kFirstArmJoint>().setConstant(4.0);
  config.idle_damping_nms_per_rad.tail<kArmJoints>().setConstant(1.5);
  sup = Supervisor(config);
  meas.qd_rad_s.setLinSpaced(-0.9, 0.9);
  for (int t = 0; t < 3; ++t) {
    tick();
    EXPECT_EQ(sup.mode(), Mode::idle);
    EXPECT_EQ(cmd.mode, hal::CommandMode::enabled);
    for (int j = 0; j < kNj; ++j) {
      EXPECT_EQ(cmd.kp_nm_per_rad[j], 0.0) << j;
      EXPECT_EQ(cmd.kd_nms_per_rad[j], j < kFirstArmJoint ? 4.0 : 1.5) << j;
      EXPECT_EQ(cmd.qd_des_rad_s[j], 0.0) << j;
      EXPECT_EQ(cmd.tau_ff_nm[j], 0.0) << j;
      // What the drive applies: tau = -D_start qd.
      EXPECT_DOUBLE_EQ(hal::drive_torque_nm(cmd, j, meas.q_rad[j], meas.qd_rad_s[j]),
                       -config.idle_damping_nms_per_rad[j] * meas.qd_rad_s[j]) << j;
    }
  }
  // Back in idle after a reset: damping again, not the last controller command.
  ASSERT_EQ(ask(OperatorCommand::start), Verdict::accepted);
  tick();
  ASSERT_EQ(ask(OperatorCommand::stop), Verdict::accepted);
  meas.qd_rad_s.setZero();
  tick();
  ASSERT_EQ(ask(OperatorCommand::reset), Verdict::accepted);
  tick();
  EXPECT_EQ(cmd.kd_nms_per_rad, config.idle_damping_nms_per_rad);
  EXPECT_TRUE(cmd.kp_nm_per_rad.isZero());
  EXPECT_TRUE(cmd.tau_ff_nm.isZero());
}

// A joint pushed past its limit while the robot is passive (idle): the fault is
// not hidden. It latches (naming the joint), the robot damps, `start` is refused,
// and reset only succeeds once the joint is back within its limit + margin.
TEST_F(SupervisorTest, JointLimitWhileIdleLatchesNamesTheJointAndBlocksStart) {
  tick();
  EXPECT_EQ(sup.limit_joint(), -1);
  const int knee = 5;  // rf_kfe
  const double lower = robot::kJoints[knee].limits.lower_rad;
  meas.q_rad[knee] = lower - config.limit_margin_rad - 0.02;
  tick();
  EXPECT_EQ(sup.faults(), fault::kJointLimit);
  EXPECT_EQ(sup.limit_joint(), knee);
  EXPECT_EQ(sup.limit_joint_position_rad(), lower - config.limit_margin_rad - 0.02);
  expect_damping();
  EXPECT_EQ(ask(OperatorCommand::start), Verdict::not_idle);
  tick();
  EXPECT_EQ(ask(OperatorCommand::reset), Verdict::unsafe_joint_limit);
  EXPECT_EQ(sup.mode(), Mode::damping);
  meas.q_rad[knee] = lower - config.limit_margin_rad + 0.01;  // moved back by hand, at rest
  tick();
  EXPECT_EQ(ask(OperatorCommand::reset), Verdict::accepted);
  EXPECT_EQ(sup.limit_joint(), -1);
  tick();
  EXPECT_EQ(sup.mode(), Mode::idle);
  EXPECT_EQ(ask(OperatorCommand::start), Verdict::accepted);
}

TEST_F(SupervisorTest, EveryModeTransition) {
  tick();
  EXPECT_EQ(ask(OperatorCommand::start), Verdict::accepted);  // idle -> stand_up
  EXPECT_EQ(sup.mode(), Mode::stand_up);
  EXPECT_EQ(sup.ticks_in_mode(), 0u);
  tick({true, false});
  EXPECT_EQ(sup.mode(), Mode::stand_up);
  EXPECT_EQ(sup.ticks_in_mode(), 1u);
  EXPECT_EQ(cmd.mode, hal::CommandMode::enabled);
  tick({true, true});  // posture reached: stand_up -> stand
  EXPECT_EQ(sup.mode(), Mode::stand);
  EXPECT_EQ(sup.ticks_in_mode(), 0u);
  EXPECT_EQ(ask(OperatorCommand::mode_control), Verdict::accepted);  // stand -> control
  EXPECT_EQ(sup.mode(), Mode::control);
  tick();
  EXPECT_EQ(ask(OperatorCommand::mode_stand), Verdict::accepted);  // control -> stand
  EXPECT_EQ(sup.mode(), Mode::stand);
  EXPECT_EQ(ask(OperatorCommand::mode_control), Verdict::accepted);
  tick();
  EXPECT_EQ(ask(OperatorCommand::stop), Verdict::accepted);  // control -> damping
  EXPECT_EQ(sup.mode(), Mode::damping);
  EXPECT_EQ(sup.faults(), fault::kOperatorStop);
  meas.qd_rad_s.setZero();
  tick();
  EXPECT_EQ(ask(OperatorCommand::reset), Verdict::accepted);  // damping -> idle
  EXPECT_EQ(sup.mode(), Mode::idle);
  EXPECT_EQ(sup.faults(), 0u);
}

// CAN.md 6.4: a sensor the controller needs, lost in the control mode, is a latched
// fault that names it (damping); lost in another mode only a warning, and it blocks
// `mode control`.
// A clipping streak (clipping on clip_streak samples in a row, CAN.md 6.4: "a streak is a
// fault") is handled the same way, with its own bit.
TEST_F(SupervisorTest, ANeededSensorLostInControlLatchesElsewhereWarns) {
  const auto set = [this](FaultMask which) {
    meas.imu.lost = which == fault::kImuLost;
    meas.wrist.lost = which == fault::kWristFtLost;
    meas.imu.clip_streak = which == fault::kImuClipping;
    meas.wrist.clip_streak = which == fault::kWristFtClipping;
  };
  const std::pair<FaultMask, const char*> cases[] = {{fault::kImuLost, "imu_lost"},
                                                    {fault::kWristFtLost, "wrist_ft_lost"},
                                                    {fault::kImuClipping, "imu_clipping_streak"},
                                                    {fault::kWristFtClipping, "wrist_ft_clipping_streak"}};
  for (const auto& [which, name] : cases) {
    SupervisorConfig c = config;
    c.control_needs_imu = true;
    c.control_needs_wrist_ft = true;
    sup = Supervisor(c);
    set(which);
    tick();
    EXPECT_EQ(sup.sensors_lost(), which);  // idle: a warning
    EXPECT_EQ(sup.faults(), 0u);
    ASSERT_EQ(ask(OperatorCommand::start), Verdict::accepted);
    tick({true, true});
    ASSERT_EQ(sup.mode(), Mode::stand);
    EXPECT_EQ(sup.faults(), 0u);
    EXPECT_EQ(ask(OperatorCommand::mode_control), Verdict::sensor_lost);  // refused while lost
    set(0);
    tick();
    EXPECT_EQ(sup.sensors_lost(), 0u);
    ASSERT_EQ(ask(OperatorCommand::mode_control), Verdict::accepted);
    tick();
    set(which);
    tick();
    expect_damping();
    EXPECT_EQ(sup.faults(), which);
    EXPECT_STREQ(fault_name(std::countr_zero(which)), name);
  }
  set(0);
  // Not needed (joint-PD control mode): never a fault.
  sup = Supervisor(config);
  meas.imu.lost = meas.wrist.lost = true;
  go_to_control();
  tick();
  EXPECT_EQ(sup.mode(), Mode::control);
  EXPECT_EQ(sup.sensors_lost(), 0u);
}

// CAN.md 4: a bus whose controller is error passive is degraded: a warning to safety in every
// mode (degraded_buses()), never a latched fault, and it refuses nothing: the robot keeps going.
TEST_F(SupervisorTest, DegradedBusesAreAWarningNeverAFault) {
  meas.degraded_buses = 1u << 6;
  tick();
  EXPECT_EQ(sup.degraded_buses(), 1u << 6);  // idle
  EXPECT_EQ(sup.faults(), 0u);
  go_to_control();
  meas.degraded_buses = (1u << 6) | 1u;
  tick();
  EXPECT_EQ(sup.mode(), Mode::control);
  EXPECT_EQ(sup.degraded_buses(), (1u << 6) | 1u);
  EXPECT_EQ(sup.faults(), 0u);
  EXPECT_EQ(ask(OperatorCommand::mode_stand), Verdict::accepted);
  tick();
  EXPECT_EQ(ask(OperatorCommand::mode_control), Verdict::accepted);
  meas.degraded_buses = 0;  // back to error active
  tick();
  EXPECT_EQ(sup.degraded_buses(), 0u);
  EXPECT_EQ(sup.mode(), Mode::control);
  EXPECT_EQ(sup.faults(), 0u);
}

// A standing tick whose controller says it cannot take over yet (the wrist F/T's tare being
// taken) makes `mode control` wait: refused, nothing latched, accepted once a standing tick says ready.
TEST_F(SupervisorTest, ControlWaitsForTheControllerToBeReady) {
  tick();
  ASSERT_EQ(ask(OperatorCommand::start), Verdict::accepted);
  tick({true, true});
  ASSERT_EQ(sup.mode(), Mode::stand);
  ControllerReport taring;
  taring.control_ready = false;
  tick(taring);
  EXPECT_EQ(ask(OperatorCommand::mode_control), Verdict::controller_not_ready);
  EXPECT_EQ(sup.mode(), Mode::stand);
  EXPECT_EQ(sup.faults(), 0u);
  EXPECT_STREQ(to_string(Verdict::controller_not_ready), "the controller is not ready (the wrist f/t's tare is being taken)");
  tick();
  EXPECT_EQ(ask(OperatorCommand::mode_control), Verdict::accepted);
  EXPECT_EQ(sup.mode(), Mode::control);
}

// CAN.md 6.1: while the IMU says its orientation has not converged the estimator must not
// start: `mode control` (the WBC, which needs the IMU) is refused, nothing latches; once it
// has converged the mode starts. A controller that does not need the IMU ignores the bit.
TEST_F(SupervisorTest, ControlWaitsForTheImuOrientationToConverge) {
  SupervisorConfig c = config;
  c.control_needs_imu = true;
  sup = Supervisor(c);
  meas.imu.converged = false;
  tick();
  ASSERT_EQ(ask(OperatorCommand::start), Verdict::accepted);
  tick({true, true});
  ASSERT_EQ(sup.mode(), Mode::stand);
  EXPECT_EQ(ask(OperatorCommand::mode_control), Verdict::sensor_not_ready);
  EXPECT_EQ(sup.mode(), Mode::stand);
  EXPECT_EQ(sup.faults(), 0u);
  EXPECT_STREQ(to_string(Verdict::sensor_not_ready), "the imu's orientation has not converged");
  meas.imu.converged = true;
  tick();
  EXPECT_EQ(ask(OperatorCommand::mode_control), Verdict::accepted);
  EXPECT_EQ(sup.mode(), Mode::control);

  sup = Supervisor(config);  // joint-PD control: the IMU is not needed
  meas.imu.converged = false;
  go_to_control();
  EXPECT_EQ(sup.mode(), Mode::control);
}

TEST_F(SupervisorTest, StopFromEveryModeGoesToDamping) {
  for (Mode target : {Mode::idle, Mode::stand_up, Mode::stand, Mode::control}) {
    Supervisor s(config);
    sup = s;
    tick();
    if (target != Mode::idle) {
      ASSERT_EQ(ask(OperatorCommand::start), Verdict::accepted);
    }
    if (target == Mode::stand || target == Mode::control) tick({true, true});
    if (target == Mode::control) {
      ASSERT_EQ(ask(OperatorCommand::mode_control), Verdict::accepted);
    }
    ASSERT_EQ(sup.mode(), target);
    EXPECT_EQ(ask(OperatorCommand::stop), Verdict::accepted);
    tick();
    expect_damping();
  }
}

TEST_F(SupervisorTest, RejectedCommandsChangeNothing) {
  tick();
  EXPECT_EQ(ask(OperatorCommand::mode_control), Verdict::not_standing);
  EXPECT_EQ(ask(OperatorCommand::mode_stand), Verdict::not_in_control);
  EXPECT_EQ(ask(OperatorCommand::reset), Verdict::not_in_damping);
  EXPECT_EQ(sup.mode(), Mode::idle);
  ASSERT_EQ(ask(OperatorCommand::start), Verdict::accepted);
  EXPECT_EQ(ask(OperatorCommand::start), Verdict::not_idle);
  EXPECT_EQ(ask(OperatorCommand::mode_control), Verdict::not_standing);  // still standing up
  EXPECT_EQ(sup.mode(), Mode::stand_up);
  ASSERT_EQ(ask(OperatorCommand::stop), Verdict::accepted);
  EXPECT_EQ(ask(OperatorCommand::start), Verdict::not_idle);
  EXPECT_EQ(ask(OperatorCommand::mode_stand), Verdict::not_in_control);
  EXPECT_EQ(sup.mode(), Mode::damping);
  EXPECT_EQ(sup.faults(), fault::kOperatorStop);
}

TEST_F(SupervisorTest, ResetOnlyInASafeState) {
  go_to_control();
  ASSERT_EQ(ask(OperatorCommand::stop), Verdict::accepted);
  meas.qd_rad_s[4] = 0.2;  // still moving
  tick();
  EXPECT_EQ(ask(OperatorCommand::reset), Verdict::unsafe_moving);
  meas.qd_rad_s[4] = 0.04;  // below reset_max_speed (0.05)
  tick({}, IoStatus::timeout, 0, 0, false);
  EXPECT_EQ(ask(OperatorCommand::reset), Verdict::unsafe_measurement);  // stale data
  tick({}, IoStatus::ok, 1);
  EXPECT_EQ(ask(OperatorCommand::reset), Verdict::unsafe_timing);
  meas.drives[3].state = hal::DriveState::lost;
  tick();
  EXPECT_EQ(ask(OperatorCommand::reset), Verdict::unsafe_drive);
  meas.drives[3].state = hal::DriveState::enabled;
  meas.q_rad[2] = 0.0;  // lf knee past its upper limit (-0.349) + margin
  tick();
  EXPECT_EQ(ask(OperatorCommand::reset), Verdict::unsafe_joint_limit);
  meas.q_rad = stand_posture();
  tick();
  EXPECT_EQ(sup.mode(), Mode::damping);
  EXPECT_EQ(ask(OperatorCommand::reset), Verdict::accepted);
  EXPECT_EQ(sup.mode(), Mode::idle);
}

TEST_F(SupervisorTest, OverrunStreakTripsAtTheLimit) {
  go_to_control();
  tick({}, IoStatus::ok, config.overrun_streak_limit - 1);
  EXPECT_EQ(sup.mode(), Mode::control);
  meas.qd_rad_s.setConstant(0.3);
  tick({}, IoStatus::ok, config.overrun_streak_limit);
  EXPECT_EQ(sup.faults(), fault::kOverrunStreak);
  expect_damping();
}

TEST_F(SupervisorTest, OverrunRateTripsAboveTheLimit) {
  go_to_control();
  tick({}, IoStatus::ok, 0, config.overrun_rate_limit);
  EXPECT_EQ(sup.mode(), Mode::control);
  tick({}, IoStatus::ok, 0, config.overrun_rate_limit + 1);
  EXPECT_EQ(sup.faults(), fault::kOverrunRate);
  expect_damping();
}

TEST_F(SupervisorTest, NonFiniteMeasurementTrips) {
  go_to_control();
  meas.qd_rad_s.setConstant(1.0);
  meas.qd_rad_s[7] = std::numeric_limits<double>::quiet_NaN();
  tick();
  EXPECT_EQ(sup.faults(), fault::kNonFinite);
  expect_damping();
  EXPECT_EQ(cmd.tau_ff_nm[7], 0.0);  // the drive damps with its own velocity
  EXPECT_EQ(hal::drive_torque_nm(cmd, 6, meas.q_rad[6], meas.qd_rad_s[6]), -10.0);
}

TEST_F(SupervisorTest, NonFiniteImuOnlyCountsWhenValid) {
  go_to_control();
  meas.imu.angular_rate_rad_s.x() = std::numeric_limits<double>::infinity();
  tick();
  EXPECT_EQ(sup.mode(), Mode::control);
  meas.imu.valid = true;
  tick();
  EXPECT_EQ(sup.faults(), fault::kNonFinite);
}

TEST_F(SupervisorTest, JointLimitWithMarginFromTheModel) {
  go_to_control();
  const double upper = robot::kJoints[1].limits.upper_rad;  // lf_hfe
  meas.q_rad[1] = upper + config.limit_margin_rad - 1e-6;
  tick();
  EXPECT_EQ(sup.mode(), Mode::control);
  meas.q_rad[kFirstArmJoint] = 40.0;  // arm_joint_1 is continuous: no limit
  tick();
  EXPECT_EQ(sup.mode(), Mode::control);
  meas.q_rad[1] = upper + config.limit_margin_rad + 1e-6;
  tick();
  EXPECT_EQ(sup.faults(), fault::kJointLimit);
  EXPECT_EQ(sup.limit_joint(), 1);
  expect_damping();
}

TEST_F(SupervisorTest, ControllerFailureStreakHoldsTheLastGoodCommandThenTrips) {
  go_to_control();
  proposal.tau_ff_nm.setConstant(1.5);
  tick();
  const hal::JointCommands good = cmd;
  proposal.tau_ff_nm.setConstant(99.0);  // a failed tick's output must not be sent
  for (std::uint32_t i = 1; i < config.qp_failure_streak_limit; ++i) {
    tick({false, false});
    EXPECT_EQ(sup.mode(), Mode::control);
    EXPECT_EQ(cmd.tau_ff_nm, good.tau_ff_nm);
    EXPECT_EQ(cmd.q_des_rad, good.q_des_rad);
  }
  tick({false, false});
  EXPECT_EQ(sup.faults(), fault::kQpFailureStreak);
  expect_damping();
}

TEST_F(SupervisorTest, ANonFiniteCommandCountsAsAFailure) {
  go_to_control();
  tick();
  proposal.tau_ff_nm[0] = std::numeric_limits<double>::quiet_NaN();
  for (std::uint32_t i = 0; i < config.qp_failure_streak_limit; ++i) tick();
  EXPECT_EQ(sup.faults(), fault::kQpFailureStreak);
}

TEST_F(SupervisorTest, LostOrFaultedDriveTrips) {
  for (auto state : {hal::DriveState::lost, hal::DriveState::fault}) {
    Supervisor s(config);
    sup = s;
    meas.drives[11].state = hal::DriveState::enabled;
    go_to_control();
    meas.drives[11].state = state;
    tick();
    EXPECT_EQ(sup.faults(), fault::kDriveLost);
    expect_damping();
  }
}

TEST_F(SupervisorTest, SilentHalTripsTheWatchdogAfterNTicks) {
  go_to_control();
  // the sequence does not advance (the HAL returns old data), then it times out
  for (std::uint32_t i = 1; i < config.hal_watchdog_ticks; ++i) {
    tick({}, i % 2 ? IoStatus::ok : IoStatus::timeout, 0, 0, false);
    EXPECT_EQ(sup.stale_ticks(), i);
    EXPECT_EQ(sup.mode(), Mode::control) << i;
  }
  tick({}, IoStatus::timeout, 0, 0, false);
  EXPECT_EQ(sup.faults(), fault::kHalWatchdog);
  expect_damping();
}

TEST_F(SupervisorTest, DampingIsBoundedByTheTorqueLimits) {
  go_to_control();
  meas.qd_rad_s.setConstant(-100.0);  // -D qd = +1000 N m
  ASSERT_EQ(ask(OperatorCommand::stop), Verdict::accepted);
  tick();
  expect_damping();
  const auto torque_nm = [&](int j) { return hal::drive_torque_nm(cmd, j, meas.q_rad[j], meas.qd_rad_s[j]); };
  EXPECT_EQ(torque_nm(0), 150.0);              // HAA: flat
  EXPECT_EQ(torque_nm(kFirstArmJoint), 39.0);  // arm joints 1-4
  EXPECT_EQ(torque_nm(kNj - 1), 9.0);          // arm joints 5-7
  // HFE / KFE: the cylinder's limit at the measured angle (ACTUATORS.md).
  for (int j : {1, 2, 4, 5, 7, 8, 10, 11}) {
    EXPECT_NEAR(torque_nm(j), test::hyq_leg_limit_nm(j, meas.q_rad[j]), 1e-9) << j;
  }
}

TEST_F(SupervisorTest, DampingAtAKneeNearItsStopHasTheCylindersSmallerLimit) {
  go_to_control();
  meas.q_rad[robot::kJoint_lh_kfe_joint] = 2.4;  // 137.5 deg: the lever is short (~88 N m)
  meas.q_rad[robot::kJoint_lf_kfe_joint] = std::numeric_limits<double>::quiet_NaN();  // unknown
  meas.qd_rad_s.setConstant(-100.0);
  ASSERT_EQ(ask(OperatorCommand::stop), Verdict::accepted);
  tick();
  const double lh = hal::drive_torque_nm(cmd, robot::kJoint_lh_kfe_joint, 2.4, -100.0);
  EXPECT_NEAR(lh, test::hyq_kfe_limit_nm(2.4), 1e-9);
  EXPECT_LT(lh, 90.0);
  // A knee whose angle is unknown: the smallest limit over its range (the 140 deg end).
  const double lf = hal::drive_torque_nm(cmd, robot::kJoint_lf_kfe_joint, 0.0, -100.0);
  EXPECT_NEAR(lf, test::hyq_kfe_limit_nm(140.0 * std::numbers::pi / 180.0), 1e-9);
}

TEST_F(SupervisorTest, CommandsAreClampedToTheLimitsAtTheMeasuredState) {
  go_to_control();
  proposal.kp_nm_per_rad.setConstant(5000.0);
  proposal.q_des_rad = stand_posture();
  proposal.q_des_rad[0] = 3.0;   // beyond lf_haa upper 0.436: clamped
  proposal.q_des_rad[12] = 3.0;  // continuous: kept
  meas.q_rad[5] += 0.1;          // rf knee off target: kp error 0.1 rad * 5000 = 500 N m
  tick();
  EXPECT_EQ(sup.mode(), Mode::control);
  EXPECT_DOUBLE_EQ(cmd.q_des_rad[0], robot::kJoints[0].limits.upper_rad);
  EXPECT_EQ(cmd.q_des_rad[12], 3.0);
  for (int j = 0; j < kNj; ++j) {
    const double tau = hal::drive_torque_nm(cmd, j, meas.q_rad[j], meas.qd_rad_s[j]);
    const double limit = j < kFirstArmJoint ? test::hyq_leg_limit_nm(j, meas.q_rad[j]) : robot::kJoints[j].limits.effort_nm;
    EXPECT_LE(std::abs(tau), limit + 1e-9) << j;
  }
  // The knee's limit at its measured angle (-1.3 rad: 74.5 deg in the hind legs' convention).
  EXPECT_NEAR(hal::drive_torque_nm(cmd, 5, meas.q_rad[5], 0.0), -test::hyq_kfe_limit_nm(-meas.q_rad[5]), 1e-9);
  EXPECT_NEAR(hal::drive_torque_nm(cmd, 0, meas.q_rad[0], 0.0), 150.0, 1e-9);
}

TEST_F(SupervisorTest, ATickAllocatesNothing) {
  go_to_control();
  test::AllocationTrap trap;
  for (int i = 0; i < 100; ++i) {
    ++meas.sequence;
    sup.observe(meas, IoStatus::ok, 0, 0);
    sup.request(OperatorCommand::mode_stand);
    cmd = proposal;
    sup.finish(meas, {}, cmd);
  }
  meas.q_rad[0] = std::numeric_limits<double>::quiet_NaN();
  sup.observe(meas, IoStatus::ok, 0, 0);
  sup.finish(meas, {}, cmd);
  EXPECT_EQ(trap.disarm(), 0u);
  EXPECT_EQ(sup.mode(), Mode::damping);
}

}  // namespace
}  // namespace springbok::safety
