// The SocketCAN host's decisions that need no socket (CAN.md 4): what a failed write means
// for its bus.
#include <gtest/gtest.h>

#include <cerrno>

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

}  // namespace
}  // namespace springbok::can
