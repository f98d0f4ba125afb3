// HIL: bus faults (bus-off, a full transmit queue, heartbeat loss, transient errors, frames naming
// another bus's drive) and the shut-down after them.
#include "hil_rig.hpp"

namespace springbok::can {
namespace {

using namespace hil;

// A run of `ticks` ticks: the first whose read() reported an error (-1: none), and the last
// tick's measurements and status.
struct ErrorWatch {
  int error_at = -1;
  hal::Measurements last;
  hal::IoStatus last_status{};
};
ErrorWatch run_watching_for_error(CanHardware& hw, int ticks) {
  ErrorWatch w;
  run_ticks(hw, ticks, [&](int k, const hal::Measurements& m, hal::IoStatus s) {
    if (w.error_at < 0 && s == hal::IoStatus::error) w.error_at = k;
    w.last = m;
    w.last_status = s;
  });
  return w;
}

// 80 ticks with the emulator's bus-off of bus lf (vcan0, drive 1's) at tick 30: the bus faults,
// its drives are lost, the others run on.
void run_through_a_bus_off_at_30(CanHardware& hw) {
  const ErrorWatch w = run_watching_for_error(hw, 80);
  EXPECT_GE(w.error_at, 30);
  EXPECT_LE(w.error_at, 32);
  EXPECT_EQ(hw.diagnostics(0).fault, BusFault::bus_off);
  EXPECT_EQ(w.last_status, hal::IoStatus::error);
  for (int j = 0; j < 3; ++j) EXPECT_EQ(w.last.drives[static_cast<std::size_t>(j)].state, hal::DriveState::lost) << j;
  for (int j = 3; j < kNj; ++j) EXPECT_EQ(w.last.drives[static_cast<std::size_t>(j)].state, hal::DriveState::enabled) << j;
}

TEST(Hil, BusOffFaultsTheBusAndNeedsAnOperatorRecovery) {
  REQUIRE_VCAN(7);
  const CanConfig cfg = load("mit_classic7.yaml");
  HilRig rig("mit_classic7.yaml", cfg, "faults: [{kind: bus_off, drive: 1, at: 30}]\n");
  ASSERT_TRUE(rig.emu.ready());
  ASSERT_TRUE(rig.start().ok);
  run_through_a_bus_off_at_30(rig.hw);
  // Nothing resumes by itself (the emulated drives still answer): recovery is an operator action.
  const hal::LifecycleResult r = rig.hw.recover_bus(0);
  ASSERT_TRUE(r.ok) << r.message;
  int ok_ticks = 0;
  hal::Measurements after;
  run_ticks(rig.hw, 50, [&](int, const hal::Measurements& m, hal::IoStatus s) {
    ok_ticks += s == hal::IoStatus::ok ? 1 : 0;
    after = m;
  });
  EXPECT_GE(ok_ticks, 45);
  EXPECT_EQ(rig.hw.diagnostics(0).fault, BusFault::none);
  for (int j = 0; j < kNj; ++j) EXPECT_EQ(after.drives[static_cast<std::size_t>(j)].state, hal::DriveState::enabled) << j;
}

// A full transmit queue, made by the kernel: a pfifo qdisc of length 0 on vcan0 drops every
// frame, and the raw socket's write() fails with ENOBUFS, as on a real controller whose queue is
// full. One tick of it is counted (the rest of that bus's frames dropped, never retried); on
// tx_fault_ticks ticks in a row it faults the bus.
TEST(Hil, TransmitQueueFullIsCountedThenFaultsTheBus) {
  REQUIRE_VCAN(7);
  const CanConfig cfg = load("mit_classic7.yaml");
  HilRig rig("mit_classic7.yaml", cfg, "");
  ASSERT_TRUE(rig.emu.ready());
  ASSERT_TRUE(rig.start().ok);
  const auto no_op = [](int, const hal::Measurements&, hal::IoStatus) {};
  run_ticks(rig.hw, 20, no_op);
  EXPECT_EQ(rig.hw.diagnostics(0).tx_dropped, 0u);
  const auto queue = [](bool full) {
    return std::system(full ? "tc qdisc add dev vcan0 root pfifo limit 0" : "tc qdisc del dev vcan0 root");
  };
  if (queue(true) != 0) GTEST_SKIP() << "needs tc and the pfifo qdisc";
  run_ticks(rig.hw, 1, no_op);  // one tick: 3 frames not sent
  ASSERT_EQ(queue(false), 0);
  hal::Measurements last;
  run_ticks(rig.hw, 20, [&](int, const hal::Measurements& m, hal::IoStatus) { last = m; });
  EXPECT_EQ(rig.hw.diagnostics(0).tx_dropped, 3u);  // the ENOBUFS frame and the rest of the tick
  EXPECT_EQ(rig.hw.diagnostics(0).fault, BusFault::none);
  for (int j = 0; j < kNj; ++j) EXPECT_EQ(last.drives[static_cast<std::size_t>(j)].state, hal::DriveState::enabled) << j;
  for (int b = 1; b < rig.hw.bus_count(); ++b) EXPECT_EQ(rig.hw.diagnostics(b).tx_dropped, 0u) << b;

  ASSERT_EQ(queue(true), 0);
  hal::IoStatus last_status{};
  run_ticks(rig.hw, static_cast<int>(cfg.timing.tx_fault_ticks) + 2, [&](int, const hal::Measurements& m, hal::IoStatus s) {
    last = m;
    last_status = s;
  });
  ASSERT_EQ(queue(false), 0);
  EXPECT_EQ(rig.hw.diagnostics(0).fault, BusFault::tx_queue_full);
  EXPECT_GE(rig.hw.diagnostics(0).tx_dropped, 3u + 3u * cfg.timing.tx_fault_ticks);
  EXPECT_EQ(last_status, hal::IoStatus::error);
  for (int j = 0; j < 3; ++j) EXPECT_EQ(last.drives[static_cast<std::size_t>(j)].state, hal::DriveState::lost) << j;
  for (int j = 3; j < kNj; ++j) EXPECT_EQ(last.drives[static_cast<std::size_t>(j)].state, hal::DriveState::enabled) << j;
}

// CAN.md 4.1: a heartbeat missing for heartbeat_lost_periods marks the drive lost even while its
// PDOs still flow (the supervisor then damps: tests/safety).
TEST(Hil, Cia402HeartbeatLossMarksTheDriveLostWhilePdosFlow) {
  REQUIRE_VCAN(7);
  CanConfig cfg = load("cia402_classic7.yaml");
  cfg.timing.heartbeat_lost_periods = 3;  // 300 ms at the 100 ms producer heartbeat time
  HilRig rig("cia402_classic7.yaml", cfg, "faults: [{kind: no_heartbeat, drive: 5, at: 120}]\n",
             kCia402DrivesUp);
  ASSERT_TRUE(rig.emu.ready());
  const hal::LifecycleResult c = rig.hw.configure();
  ASSERT_TRUE(c.ok) << c.message;
  ASSERT_TRUE(rig.hw.activate().ok);
  int lost_at = -1;
  std::uint64_t missed_when_lost = 0;
  hal::Measurements last;
  run_ticks(rig.hw, 500, [&](int k, const hal::Measurements& m, hal::IoStatus) {
    if (lost_at < 0 && m.drives[4].state == hal::DriveState::lost) {
      lost_at = k;
      missed_when_lost = m.drives[4].missed_total;
    }
    last = m;
  });
  // The drive's tick 120 (its SYNCs, the keep-alive's while later buses were enabled among them:
  // at most 100 here) came on the run's tick 20..120; the last heartbeat at most one period
  // (100 ticks) before it, lost 300 ticks after that.
  EXPECT_GE(lost_at, 20 - 100 + 300);
  EXPECT_LE(lost_at, 120 + 300 + 10);
  EXPECT_LE(missed_when_lost, 10u) << "its TPDOs kept coming";
  for (int j = 0; j < kNj; ++j) {
    if (j != 4) {
      EXPECT_EQ(last.drives[static_cast<std::size_t>(j)].state, hal::DriveState::enabled) << j;
    }
  }
}

TEST(Hil, TransientFaultsAreCountedNotFatal) {
  REQUIRE_VCAN(7);
  const CanConfig cfg = load("mit_classic7.yaml");
  HilRig rig("mit_classic7.yaml", cfg, "faults:\n"
             "  - {kind: drop, drive: 2, at: 20, count: 2}\n"
             "  - {kind: duplicate, drive: 4, at: 20, count: 3}\n"
             "  - {kind: corrupt, drive: 8, at: 30, count: 1}\n"
             "  - {kind: wrong_dlc, drive: 10, at: 30, count: 2}\n"
             "  - {kind: unexpected_id, drive: 13, at: 30, count: 2, param: 100}\n"
             "  - {kind: delay, drive: 16, at: 40, count: 1, param: 2}\n"
             "  - {kind: error_passive, drive: 19, at: 25}\n"
             "  - {kind: error_active, drive: 19, at: 60}\n");
  ASSERT_TRUE(rig.emu.ready());
  ASSERT_TRUE(rig.start().ok);
  hal::Measurements last;
  // Bus arm2 (vcan6, bus 6) degraded from its error-passive report to its error-active one.
  int degraded_from = -1, degraded_until = -1;
  std::uint32_t other_degraded = 0;
  run_ticks(rig.hw, 80, [&](int k, const hal::Measurements& m, hal::IoStatus) {
    const bool degraded = (m.degraded_buses & (1u << 6)) != 0;
    if (degraded && degraded_from < 0) degraded_from = k;
    if (!degraded && degraded_from >= 0 && degraded_until < 0) degraded_until = k;
    other_degraded |= m.degraded_buses & ~(1u << 6);
    last = m;
  });
  EXPECT_GE(degraded_from, 25);
  EXPECT_LE(degraded_from, 28);
  EXPECT_GE(degraded_until, 60);
  EXPECT_LE(degraded_until, 63);
  EXPECT_EQ(other_degraded, 0u);
  EXPECT_EQ(last.degraded_buses, 0u);
  EXPECT_FALSE(rig.hw.diagnostics(6).error_passive);             // back to normal
  EXPECT_EQ(rig.hw.diagnostics(6).error_passive_events, 1u);
  for (int j = 0; j < kNj; ++j) EXPECT_EQ(last.drives[static_cast<std::size_t>(j)].state, hal::DriveState::enabled) << j;
  EXPECT_GE(last.drives[1].missed_total, 2u);                // dropped
  EXPECT_GE(rig.hw.diagnostics(1).duplicates, 3u);               // drive 4 on bus rf
  EXPECT_GE(rig.hw.diagnostics(2).bad_frames, 1u);               // drive 8: implausible position jump
  EXPECT_GE(last.drives[7].missed_total, 1u);
  EXPECT_GE(rig.hw.diagnostics(3).bad_frames, 2u);               // drive 10: DLC 5
  EXPECT_GE(rig.hw.diagnostics(4).unexpected_frames, 2u);        // drive 13 answering as drive 100: no drive of the robot
  EXPECT_EQ(rig.hw.diagnostics(4).foreign_frames, 0u);
  EXPECT_GE(last.drives[15].missed_total, 1u);               // drive 16 delayed by 2 ticks
  EXPECT_EQ(rig.hw.diagnostics(6).fault, BusFault::none);        // bus arm2 was only degraded
}

// CAN.md 4.1: "a valid frame with an id of another bus is a configuration fault". From its cyclic
// tick 30 drive 13 (bus arm0, vcan4) answers naming drive 5 (bus rf) in byte 0: the frame passes
// arm0's CAN_RAW_FILTER (its CAN id is drive 13's reply id, 0x10D) and would be taken for a reply.
// The bus faults: its drives are lost (the supervisor's drive-lost fault, damping), read()
// reports an error, the diagnostics name the bus, the drive and the id; the other buses go on.
// The bus still carries frames: deactivate() disables its drives too.
TEST(Hil, AFrameNamingADriveOfAnotherBusFaultsItsBus) {
  REQUIRE_VCAN(7);
  const CanConfig cfg = load("mit_classic7.yaml");
  HilRig rig("mit_classic7.yaml", cfg, "faults: [{kind: unexpected_id, drive: 13, at: 30, count: 5, param: 5}]\n");
  ASSERT_TRUE(rig.emu.ready());
  ASSERT_TRUE(rig.start().ok);
  const ErrorWatch w = run_watching_for_error(rig.hw, 80);
  EXPECT_GE(w.error_at, 30);
  EXPECT_LE(w.error_at, 32);
  EXPECT_EQ(w.last_status, hal::IoStatus::error);
  const BusDiagnostics& d = rig.hw.diagnostics(4);
  EXPECT_EQ(d.fault, BusFault::foreign_drive);
  EXPECT_GE(d.foreign_frames, 1u);
  EXPECT_EQ(d.foreign_drive_id, 5);
  EXPECT_EQ(d.foreign_can_id, 0x10Du);
  for (int j = 12; j < 15; ++j) EXPECT_EQ(w.last.drives[static_cast<std::size_t>(j)].state, hal::DriveState::lost) << j;
  for (int j = 0; j < kNj; ++j) {
    if (j < 12 || j >= 15) {
      EXPECT_EQ(w.last.drives[static_cast<std::size_t>(j)].state, hal::DriveState::enabled) << j;
    }
  }
  for (int b = 0; b < rig.hw.bus_count(); ++b) {
    if (b != 4) {
      EXPECT_EQ(rig.hw.diagnostics(b).fault, BusFault::none) << b;
    }
  }
  const std::string report = rig.hw.diagnostics_report();
  EXPECT_NE(report.find("can bus arm0 (vcan4): fault=configuration fault: a frame of a drive configured on another bus"),
            std::string::npos)
      << report;
  EXPECT_NE(report.find(" foreign_drive=5 foreign_id=0x10D "), std::string::npos) << report;
  rig.hw.deactivate();
  const std::map<int, EmulatedDrive> drives = emulated_drives(rig.emu.stop());
  ASSERT_EQ(drives.size(), static_cast<std::size_t>(kNj));
  for (const auto& [id, dr] : drives) EXPECT_EQ(dr.enabled, 0) << "drive " << id;
  // The bus's drives are usable (CAN.md 4.4: "a fault that leaves drives usable"): they were
  // commanded through the 50 ticks after the fault and the shut-down's damping, as those of a
  // healthy bus (drive 1, bus lf), not left to hold their last command until CAN_TIMEOUT.
  for (const int id : {13, 14, 15}) {
    EXPECT_GE(drives.at(id).frames_in + 3, drives.at(1).frames_in) << "drive " << id;
  }
}

// CAN.md 4: after a bus-off, CAN_ERR_RESTARTED says the controller is back on the bus; its drives
// "must be re-enabled through start-up, never silently resumed". So the bus stays faulted and is
// not commanded, but a shut-down reaches it again and takes its drives out of motor mode (4.4
// step 2) instead of leaving them in motor mode at a zero command (CAN_TIMEOUT). Without the
// restart the bus is not reached.
TEST(Hil, AShutDownDisablesTheDrivesOfABusWhoseControllerRestartedAfterBusOff) {
  REQUIRE_VCAN(7);
  const CanConfig cfg = load("mit_classic7.yaml");
  for (const bool restart : {true, false}) {
    SCOPED_TRACE(restart ? "restarted" : "no restart");
    // The restart right after the bus-off (restart-ms short): an MIT drive's ticks are the
    // commands it takes, and none come after the bus-off.
    HilRig rig("mit_classic7.yaml", cfg,
               restart ? "faults: [{kind: bus_off, drive: 1, at: 30}, {kind: restarted, drive: 1, at: 30}]\n"
                       : "faults: [{kind: bus_off, drive: 1, at: 30}]\n");
    ASSERT_TRUE(rig.emu.ready());
    ASSERT_TRUE(rig.hw.configure().ok);
    ASSERT_TRUE(rig.hw.activate().ok);
    run_through_a_bus_off_at_30(rig.hw);
    EXPECT_EQ(rig.hw.diagnostics(0).controller_restarted, restart);
    rig.hw.deactivate();
    const std::map<int, EmulatedDrive> drives = emulated_drives(rig.emu.stop());
    ASSERT_EQ(drives.size(), static_cast<std::size_t>(kNj));
    for (const auto& [id, dr] : drives) {
      EXPECT_EQ(dr.enabled, id <= 3 && !restart ? 1 : 0) << "drive " << id;
      // Not commanded after the bus-off: the restarted bus gets only the shut-down's frame.
      if (id <= 3) {
        EXPECT_LE(dr.frames_in, drives.at(4).frames_in - 40) << "drive " << id;
      }
    }
  }
}

// The same fault met during start-up stops it: a reply naming drive 5 (bus rf) arrives on bus arm0
// between configure() and activate() (sent here, in drive 13's reply id). activate() fails naming
// the bus, the id and the drive, and leaves no drive enabled.
TEST(Hil, AFrameNamingADriveOfAnotherBusFailsStartUp) {
  REQUIRE_VCAN(7);
  const CanConfig cfg = load("mit_classic7.yaml");
  HilRig rig("mit_classic7.yaml", cfg, "");
  ASSERT_TRUE(rig.emu.ready());
  const hal::LifecycleResult c = rig.hw.configure();
  ASSERT_TRUE(c.ok) << c.message;
  SocketCanBus arm0;
  ASSERT_EQ(arm0.open("vcan4", false, {}, false), "");
  mit::Reply reply;
  reply.drive_id = 5;
  Frame f;
  mit::encode_reply(0x10D, reply, cfg.buses[1].drives[1].mit_ranges, mit::kReplyLen, f);
  ASSERT_EQ(arm0.send(f), TxStatus::ok);
  const hal::LifecycleResult a = rig.hw.activate();
  EXPECT_FALSE(a.ok);
  EXPECT_NE(a.message.find("bus 'arm0' (vcan4): configuration fault: a frame of a drive configured on another bus "
                           "(CAN.md 4.1): CAN id 0x10D naming drive 5 (joint rf_hfe_joint, mit) on bus 'rf' (vcan1)"),
            std::string::npos)
      << a.message;
  EXPECT_NE(a.message.find("'arm0' (vcan4) disabled again"), std::string::npos) << a.message;
  for (int j = 0; j < kNj; ++j) EXPECT_NE(rig.hw.joint(j).status.state, hal::DriveState::enabled) << j;
  const std::map<int, EmulatedDrive> drives = emulated_drives(rig.emu.stop());
  ASSERT_EQ(drives.size(), static_cast<std::size_t>(kNj));
  for (const auto& [id, dr] : drives) EXPECT_EQ(dr.enabled, 0) << "drive " << id;
}

}  // namespace
}  // namespace springbok::can
