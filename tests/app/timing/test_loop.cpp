// The whole loop (HAL read -> controller -> safety -> HAL write) driven by
// the executive on the stepped clock: mode sequence, faults -> damping in
// the tick they are seen, and a whole tick under the allocation trap.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <limits>
#include <string>
#include <utility>
#include <vector>

#include "alloc_trap.hpp"
#include "loop_fixture.hpp"
#include "springbok/app/operator_server.hpp"

namespace springbok::app::test {
namespace {

using safety::Mode;
using safety::OperatorCommand;
using safety::Verdict;
using Rig = LoopRig<KinematicTestHardware>;

struct LoopTest : ::testing::Test {
  rt::SteppedClock clock{0};
  KinematicTestHardware hardware{clock};
  std::unique_ptr<Rig> rig = std::make_unique<Rig>(clock, hardware);

  void to_control() {
    rig->executive->run_ticks(5);
    ASSERT_EQ(rig->command(OperatorCommand::start), Verdict::accepted);
    rig->executive->run_ticks(500);
    ASSERT_EQ(rig->supervisor.mode(), Mode::stand);
    ASSERT_EQ(rig->command(OperatorCommand::mode_control), Verdict::accepted);
  }
  bool wrote_idle_damping() const {
    const hal::JointCommands& c = hardware.last;
    return c.mode == hal::CommandMode::enabled && c.kp_nm_per_rad.isZero() && c.tau_ff_nm.isZero() &&
           c.kd_nms_per_rad == rig->config.safety.idle_damping_nms_per_rad;
  }
  bool wrote_damping() const {
    const hal::JointCommands& c = hardware.last;
    return c.mode == hal::CommandMode::enabled && c.kp_nm_per_rad.isZero() && c.qd_des_rad_s.isZero() &&
           c.kd_nms_per_rad == rig->config.safety.damping_nms_per_rad;
  }
};

TEST_F(LoopTest, ModeSequenceThroughTheLoop) {
  rig->executive->run_ticks(5);
  EXPECT_TRUE(wrote_idle_damping());
  ASSERT_EQ(rig->command(OperatorCommand::start), Verdict::accepted);
  // stand_up lasts stand_up_duration_s = 0.5 s = 500 ticks at 1 kHz (the start tick is tick 0)
  rig->executive->run_ticks(499);
  EXPECT_EQ(rig->supervisor.mode(), Mode::stand_up);
  rig->executive->run_ticks(1);
  EXPECT_EQ(rig->supervisor.mode(), Mode::stand);
  EXPECT_TRUE(hardware.state().q_rad.isApprox(rig->config.stand_posture_rad, 1e-12));
  EXPECT_EQ(rig->command(OperatorCommand::mode_control), Verdict::accepted);
  EXPECT_EQ(rig->supervisor.mode(), Mode::control);
  EXPECT_EQ(hardware.last.kp_nm_per_rad, rig->config.control_gains.kp_nm_per_rad);
  EXPECT_EQ(rig->command(OperatorCommand::mode_stand), Verdict::accepted);
  EXPECT_EQ(rig->command(OperatorCommand::reset), Verdict::not_in_damping);
  EXPECT_EQ(rig->command(OperatorCommand::stop), Verdict::accepted);
  EXPECT_EQ(rig->supervisor.mode(), Mode::damping);
  EXPECT_TRUE(wrote_damping());
  EXPECT_EQ(rig->status.faults.load(), safety::fault::kOperatorStop);
  EXPECT_EQ(rig->command(OperatorCommand::reset), Verdict::accepted);
  EXPECT_EQ(rig->supervisor.mode(), Mode::idle);
  EXPECT_TRUE(wrote_idle_damping());
  EXPECT_EQ(rig->status.mode.load(), static_cast<std::uint8_t>(Mode::idle));
  EXPECT_EQ(rig->executive->stats().overruns, 0u);
}

TEST_F(LoopTest, OverrunStreakGoesToDampingInTheNextTick) {
  to_control();
  hardware.read_time_ns = 1'500'000;  // every tick now ends past its deadline
  rig->executive->run_ticks(3);      // three overruns; each tick still sees a shorter streak
  EXPECT_EQ(rig->supervisor.mode(), Mode::control);
  EXPECT_EQ(rig->executive->stats().overruns, 3u);
  rig->executive->run_ticks(1);  // the streak of 3 is known at this tick's start
  EXPECT_EQ(rig->supervisor.mode(), Mode::damping);
  EXPECT_EQ(rig->supervisor.faults(), safety::fault::kOverrunStreak);
  EXPECT_TRUE(wrote_damping());
  EXPECT_EQ(rig->executive->stats().skipped_ticks, 4u);  // each 1.5 ms read skipped one grid point
}

TEST_F(LoopTest, SilentHalTripsTheWatchdog) {
  to_control();
  hardware.silent = true;
  rig->executive->run_ticks(rig->config.safety.hal_watchdog_ticks - 1);
  EXPECT_EQ(rig->supervisor.mode(), Mode::control);
  EXPECT_EQ(rig->status.stale_ticks.load(), rig->config.safety.hal_watchdog_ticks - 1);
  rig->executive->run_ticks(1);
  EXPECT_EQ(rig->supervisor.mode(), Mode::damping);
  EXPECT_EQ(rig->supervisor.faults(), safety::fault::kHalWatchdog);
  EXPECT_TRUE(wrote_damping());
  // A reset is refused while the HAL stays silent, accepted once it is back.
  EXPECT_EQ(rig->command(OperatorCommand::reset), Verdict::unsafe_measurement);
  hardware.silent = false;
  EXPECT_EQ(rig->command(OperatorCommand::reset), Verdict::accepted);
}

TEST_F(LoopTest, NonFiniteMeasurementDampsInTheSameTick) {
  to_control();
  hardware.state().qd_rad_s[4] = std::numeric_limits<double>::quiet_NaN();
  rig->executive->run_ticks(1);
  EXPECT_EQ(rig->supervisor.faults(), safety::fault::kNonFinite);
  EXPECT_TRUE(wrote_damping());
  EXPECT_EQ(hardware.last.tau_ff_nm[4], 0.0);
}

// A joint pushed past its limit while idle (the robot passive, the drives damping):
// the fault is latched, logged with the joint and its position, shown in `status`,
// and `start` is refused until the joint is back inside and the operator resets.
TEST_F(LoopTest, JointLimitWhileIdleIsLoggedAndShownWithTheJoint) {
  rig->executive->run_ticks(5);
  ASSERT_TRUE(wrote_idle_damping());
  OperatorServer server(rig->mailbox, rig->status, rig->executive->published());  // not opened: `status` only
  EXPECT_EQ(server.handle_line("status").find("limit_joint"), std::string::npos);
  rt::LogRecord r;
  while (rig->log.pop(r)) {
  }
  const int knee = 8;  // lh_kfe: upper limit
  const double beyond_rad = robot::kJoints[knee].limits.upper_rad + 0.2;
  hardware.state().q_rad[knee] = beyond_rad;
  rig->executive->run_ticks(1);
  EXPECT_EQ(rig->supervisor.mode(), Mode::damping);
  EXPECT_EQ(rig->supervisor.faults(), safety::fault::kJointLimit);
  EXPECT_TRUE(wrote_damping());
  bool logged = false;
  while (rig->log.pop(r)) {
    if (r.event != rt::LogEvent::joint_limit) continue;
    logged = true;
    EXPECT_EQ(r.a, knee);
    EXPECT_EQ(r.b, static_cast<std::int64_t>(Mode::idle));
    EXPECT_EQ(r.x, beyond_rad);
  }
  EXPECT_TRUE(logged);
  const std::string status = server.handle_line("status");
  EXPECT_EQ(status.substr(0, 42), "ok status mode=damping faults=joint_limit ");
  char expected[64];
  std::snprintf(expected, sizeof expected, " limit_joint=lh_kfe_joint q_rad=%.4f", beyond_rad);
  EXPECT_NE(status.find(expected), std::string::npos) << status;
  EXPECT_EQ(rig->command(OperatorCommand::start), Verdict::not_idle);
  EXPECT_EQ(rig->command(OperatorCommand::reset), Verdict::unsafe_joint_limit);
  hardware.state().q_rad[knee] = robot::kJoints[knee].limits.upper_rad;  // moved back by hand
  EXPECT_EQ(rig->command(OperatorCommand::reset), Verdict::accepted);
  EXPECT_EQ(server.handle_line("status").find("limit_joint"), std::string::npos);
  EXPECT_EQ(rig->command(OperatorCommand::start), Verdict::accepted);
}

TEST_F(LoopTest, LogRingRecordsModeChangesAndVerdicts) {
  to_control();
  int mode_changes = 0, accepted = 0;
  rt::LogRecord r;
  while (rig->log.pop(r)) {
    mode_changes += r.event == rt::LogEvent::mode_change;
    accepted += r.event == rt::LogEvent::command_accepted;
  }
  EXPECT_EQ(mode_changes, 3);  // idle -> stand_up -> stand -> control
  EXPECT_EQ(accepted, 2);
  EXPECT_EQ(rig->log.dropped(), 0u);
}

// CAN.md 4: a bus in error passive is degraded: logged when the set of degraded buses changes,
// both ways, with the buses' words; a warning, never a fault: the robot keeps going.
TEST_F(LoopTest, DegradedBusesAreLoggedBothWaysAndNeverAFault) {
  to_control();
  rt::LogRecord r;
  while (rig->log.pop(r)) {
  }
  const auto step = [&](std::uint32_t degraded, int ticks) {
    hardware.state().degraded_buses = degraded;
    rig->executive->run_ticks(ticks);
  };
  step(1u << 6, 10);
  step((1u << 6) | 1u, 10);
  step(0, 10);
  EXPECT_EQ(rig->supervisor.mode(), Mode::control);
  EXPECT_EQ(rig->supervisor.faults(), 0u);
  std::vector<std::pair<std::int64_t, std::int64_t>> changes;
  std::vector<std::string> words;
  while (rig->log.pop(r)) {
    if (r.event != rt::LogEvent::buses_degraded) continue;
    changes.emplace_back(r.a, r.b);
    words.push_back(describe_log_record(r));
  }
  const std::vector<std::pair<std::int64_t, std::int64_t>> expected{{64, 0}, {65, 64}, {0, 65}};
  EXPECT_EQ(changes, expected);
  EXPECT_EQ(words, (std::vector<std::string>{"degraded=bus6 was=none", "degraded=bus0,bus6 was=bus6",
                                             "degraded=none was=bus0,bus6"}));
  EXPECT_STREQ(rt::to_string(rt::LogEvent::buses_degraded), "buses_degraded");
}

// CAN.md 1.4: a drive whose reported supply is below the backend's warning threshold
// (DriveStatus::bus_voltage_low) is logged when the set of such drives changes, both ways, with
// the lowest supply; a warning, never a fault.
TEST_F(LoopTest, DrivesWithALowSupplyAreLoggedBothWaysAndNeverAFault) {
  to_control();
  rt::LogRecord r;
  while (rig->log.pop(r)) {
  }
  const auto step = [&](int joint, double volts, bool low, int ticks) {
    hardware.state().drives[static_cast<std::size_t>(joint)].bus_voltage_v = volts;
    hardware.state().drives[static_cast<std::size_t>(joint)].bus_voltage_low = low;
    rig->executive->run_ticks(ticks);
  };
  step(0, 24.0, false, 10);
  step(2, 19.5, true, 10);
  step(2, 23.0, false, 10);
  EXPECT_EQ(rig->supervisor.mode(), Mode::control);
  EXPECT_EQ(rig->supervisor.faults(), 0u);
  std::vector<std::string> words;
  while (rig->log.pop(r)) {
    if (r.event == rt::LogEvent::bus_voltage_low) words.push_back(describe_log_record(r));
  }
  EXPECT_EQ(words, (std::vector<std::string>{"low=lf_kfe_joint was=none lowest=19.50V",
                                             "low=none was=lf_kfe_joint lowest=23.00V"}));
  EXPECT_STREQ(rt::to_string(rt::LogEvent::bus_voltage_low), "bus_voltage_low");
}

TEST_F(LoopTest, WholeTicksAllocateNothing) {
  FlightRecorder recorder(1000, "/nonexistent");  // every tick recorded, a fault's file asked for
  rig->loop.set_recorder(&recorder);
  TelemetryRing telemetry;
  rig->loop.set_telemetry(&telemetry, 10);
  rig->executive->run_ticks(5);
  springbok::test::AllocationTrap trap;
  OperatorRequest request;
  request.id = 100;
  request.command = OperatorCommand::start;
  rig->mailbox.requests.push(request);
  rig->executive->run_ticks(600);  // stand_up -> stand
  request.id = 101;
  request.command = OperatorCommand::mode_control;
  rig->mailbox.requests.push(request);
  rig->executive->run_ticks(100);
  hardware.read_time_ns = 1'200'000;  // overruns, log records
  rig->executive->run_ticks(5);
  const std::size_t allocations = trap.disarm();
  EXPECT_EQ(allocations, 0u);
  EXPECT_EQ(rig->supervisor.mode(), Mode::damping);  // the overrun streak tripped inside the trap
  EXPECT_EQ(recorder.pending(), DumpReason::fault);
  EXPECT_EQ(recorder.recorded(), 710u);  // every tick
}

}  // namespace
}  // namespace springbok::app::test
