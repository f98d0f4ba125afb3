// The SocketCAN host's decisions that need no socket (CAN.md 4): what a failed write means
// for its bus, and what the controller's error frames leave in the bus's diagnostics.
#include <gtest/gtest.h>
#include <linux/can/error.h>

#include <cerrno>
#include <string>

#include "springbok/can/can_hardware.hpp"

namespace springbok::can {
namespace {

// CAN.md 4 "TX buffer full": ENOBUFS (the device queue) and EAGAIN (the socket's buffer) both
// drop the rest of the bus's frames for the tick; only ENOBUFS on tx_fault_ticks ticks in a
// row is a bus fault. A tick whose writes stopped at EAGAIN says nothing of the device queue:
// it neither extends nor ends an ENOBUFS streak.
TEST(TxBufferFull, EagainDropsTheRestOfTheTickButNeverFaultsTheBus) {
  EXPECT_EQ(tx_status_of(ENOBUFS), TxStatus::queue_full);
  EXPECT_EQ(tx_status_of(ENETDOWN), TxStatus::net_down);
  EXPECT_EQ(tx_status_of(EIO), TxStatus::error);
  const TxStatus eagain = tx_status_of(EAGAIN);
  EXPECT_EQ(eagain, TxStatus::buffer_full);
  constexpr std::uint32_t kFaultTicks = 3;
  TxBufferFull rule;
  const auto tick = [&](TxStatus first_failure) {
    rule.begin_tick();
    rule.record(TxStatus::ok);
    EXPECT_FALSE(rule.dropping());
    rule.record(first_failure);
    return rule.end_tick(kFaultTicks);
  };
  for (int k = 0; k < 10; ++k) {
    rule.begin_tick();
    rule.record(TxStatus::ok);
    rule.record(eagain);
    EXPECT_TRUE(rule.dropping()) << k;  // the rest of the tick is dropped
    EXPECT_FALSE(rule.end_tick(kFaultTicks)) << "EAGAIN on tick " << k << " faulted the bus";
  }
  EXPECT_FALSE(tick(TxStatus::queue_full));
  EXPECT_FALSE(tick(TxStatus::queue_full));
  EXPECT_FALSE(tick(TxStatus::ok));  // a tick that got through ends the streak
  EXPECT_FALSE(tick(TxStatus::queue_full));
  EXPECT_FALSE(tick(TxStatus::queue_full));
  EXPECT_FALSE(tick(eagain));  // neither extends nor ends it
  EXPECT_TRUE(tick(TxStatus::queue_full));
}

Frame error_frame(std::uint32_t classes, std::uint8_t controller, std::uint8_t tx_errors, std::uint8_t rx_errors) {
  Frame f;
  f.error = true;
  f.id = classes;
  f.len = CAN_ERR_DLC;
  f.data[1] = controller;
  f.data[6] = tx_errors;
  f.data[7] = rx_errors;
  return f;
}

// CAN.md 4: CAN_ERR_CNT carries the controller's TX / RX error counters in data[6] / data[7]
// ("log"): the bus keeps the last ones and its report line shows them; a bus that never
// reported them (vcan, an older kernel) says so. The line also shows what the bus counted of
// warnings, overflows, error-passive reports and failed writes ("count, log").
TEST(ErrorFrames, TheLastErrorCountersAreKeptAndReported) {
  BusConfig bus;
  bus.name = "arm2";
  bus.interface = "vcan6";
  BusDiagnostics d;
  EXPECT_NE(bus_diagnostics_line(bus, d).find("warnings=0 overflows=0 error_passive=0 error_passive_events=0 tx_error_counter=- rx_error_counter=-\n"),
            std::string::npos)
      << bus_diagnostics_line(bus, d);

  const Frame passive = error_frame(CAN_ERR_CRTL | CAN_ERR_CNT, CAN_ERR_CRTL_TX_PASSIVE, 128, 96);
  const ErrorFrameInfo e = classify_error_frame(passive);
  EXPECT_TRUE(e.error_passive);
  ASSERT_TRUE(e.has_counters);
  EXPECT_EQ(e.tx_errors, 128);
  EXPECT_EQ(e.rx_errors, 96);
  EXPECT_EQ(record_error_frame(passive, d), BusFault::none);
  std::string line = bus_diagnostics_line(bus, d);
  EXPECT_EQ(line.rfind("can bus arm2 (vcan6): fault=none ", 0), 0u) << line;
  EXPECT_NE(line.find("error_frames=1 warnings=0 overflows=0 error_passive=1 error_passive_events=1 tx_error_counter=128 "
                      "rx_error_counter=96\n"), std::string::npos)
      << line;

  // Back to error active with lower counters: the newest are kept.
  EXPECT_EQ(record_error_frame(error_frame(CAN_ERR_CRTL | CAN_ERR_CNT, CAN_ERR_CRTL_ACTIVE, 90, 12), d),
            BusFault::none);
  line = bus_diagnostics_line(bus, d);
  EXPECT_NE(line.find("error_frames=2 warnings=0 overflows=0 error_passive=0 error_passive_events=1 tx_error_counter=90 "
                      "rx_error_counter=12\n"), std::string::npos)
      << line;
  // Warning level and a lost frame (CAN.md 4: count, log): counted and in the line. A report
  // without CAN_ERR_CNT leaves the counters as they were.
  EXPECT_EQ(record_error_frame(error_frame(CAN_ERR_CRTL, CAN_ERR_CRTL_RX_WARNING | CAN_ERR_CRTL_RX_OVERFLOW, 0, 0), d),
            BusFault::none);
  EXPECT_EQ(record_error_frame(error_frame(CAN_ERR_BUSOFF, 0, 0, 0), d), BusFault::bus_off);
  line = bus_diagnostics_line(bus, d);
  EXPECT_NE(line.find("error_frames=4 warnings=1 overflows=1 error_passive=0 error_passive_events=1 tx_error_counter=90 "
                      "rx_error_counter=12\n"),
            std::string::npos)
      << line;
  d.short_writes = 2;
  d.tx_errors = 3;
  d.rx_budget_exhausted = 4;
  line = bus_diagnostics_line(bus, d);
  EXPECT_NE(line.find(" short_writes=2 tx_errors=3 rx_budget_exhausted=4 "), std::string::npos) << line;
}

// CAN.md 4.1: "a valid frame with an id of another bus is a configuration fault". Such frames are
// counted, the first one's drive and CAN id kept and shown in the bus's line, and the bus fault it
// means is one that still lets the host disable the bus's drives (unlike bus-off).
TEST(ForeignFrames, AreAConfigurationFaultNamingTheFirstDriveAndId) {
  BusConfig bus;
  bus.name = "arm0";
  bus.interface = "vcan4";
  BusDiagnostics d;
  EXPECT_NE(bus_diagnostics_line(bus, d).find(" foreign=0 foreign_drive=- foreign_id=- "), std::string::npos)
      << bus_diagnostics_line(bus, d);
  Frame f;
  f.id = 0x10D;
  f.len = 6;
  f.data[0] = 5;
  EXPECT_EQ(record_foreign_frame(f, 5, d), BusFault::foreign_drive);
  f.id = 0x10E;
  EXPECT_EQ(record_foreign_frame(f, 7, d), BusFault::foreign_drive);
  EXPECT_EQ(d.foreign_frames, 2u);
  EXPECT_EQ(d.foreign_drive_id, 5);
  EXPECT_EQ(d.foreign_can_id, 0x10Du);
  d.fault = BusFault::foreign_drive;
  const std::string line = bus_diagnostics_line(bus, d);
  EXPECT_EQ(line.rfind("can bus arm0 (vcan4): fault=configuration fault: a frame of a drive configured on another bus "
                       "(CAN.md 4.1) ", 0),
            0u)
      << line;
  EXPECT_NE(line.find(" foreign=2 foreign_drive=5 foreign_id=0x10D "), std::string::npos) << line;
  // Its drives are usable: they are still commanded (and damp with the others), and can be disabled.
  EXPECT_TRUE(bus_commanded(BusFault::none));
  EXPECT_TRUE(bus_commanded(BusFault::foreign_drive));
  EXPECT_TRUE(bus_reachable(d));
  for (const BusFault f : {BusFault::bus_off, BusFault::restarted, BusFault::net_down, BusFault::tx_queue_full,
                           BusFault::socket_error, BusFault::no_ack}) {
    EXPECT_FALSE(bus_commanded(f)) << to_string(f);
    BusDiagnostics other;
    other.fault = f;
    EXPECT_FALSE(bus_reachable(other)) << to_string(f);
  }
}

// CAN.md 4: after CAN_ERR_RESTARTED the drives "must be re-enabled through start-up, never silently
// resumed": a bus whose controller restarted after its bus-off is not commanded, but frames reach
// it again, so a shut-down disables its drives (CAN.md 4.4 step 2). A later bus-off takes that back.
TEST(ErrorFrames, AControllerRestartedAfterBusOffCanDisableItsDrivesButIsNotCommanded) {
  BusDiagnostics d;
  d.fault = record_error_frame(error_frame(CAN_ERR_BUSOFF, 0, 0, 0), d);
  EXPECT_EQ(d.fault, BusFault::bus_off);
  EXPECT_FALSE(bus_reachable(d));
  EXPECT_EQ(record_error_frame(error_frame(CAN_ERR_RESTARTED, 0, 0, 0), d), BusFault::restarted);
  EXPECT_TRUE(d.controller_restarted);
  EXPECT_EQ(d.fault, BusFault::bus_off);  // the first fault stays the bus's
  EXPECT_TRUE(bus_reachable(d));
  EXPECT_FALSE(bus_commanded(d.fault));
  BusConfig bus;
  bus.name = "lf";
  bus.interface = "vcan0";
  EXPECT_EQ(bus_diagnostics_line(bus, d).rfind("can bus lf (vcan0): fault=bus-off (the controller restarted since) sent=", 0), 0u)
      << bus_diagnostics_line(bus, d);
  EXPECT_EQ(record_error_frame(error_frame(CAN_ERR_BUSOFF, 0, 0, 0), d), BusFault::bus_off);
  EXPECT_FALSE(bus_reachable(d));
  EXPECT_EQ(bus_diagnostics_line(bus, d).rfind("can bus lf (vcan0): fault=bus-off sent=", 0), 0u) << bus_diagnostics_line(bus, d);

  // A restart whose bus-off was not seen: the fault is the restart.
  BusDiagnostics e;
  e.fault = record_error_frame(error_frame(CAN_ERR_RESTARTED, 0, 0, 0), e);
  EXPECT_EQ(e.fault, BusFault::restarted);
  EXPECT_TRUE(bus_reachable(e));
  EXPECT_FALSE(bus_commanded(e.fault));
}

}  // namespace
}  // namespace springbok::can
