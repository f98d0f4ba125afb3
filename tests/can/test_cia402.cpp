// CiA 402 subset codecs against CAN.md section 2 (worked SDO examples, state table).
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "springbok/can/cia402.hpp"

#include "frame_util.hpp"

namespace springbok::can::cia402 {
namespace {

using frame_util::bytes;
using frame_util::frame_of;

TEST(Cia402Sdo, WorkedExampleWriteModesOfOperation) {
  Frame f;
  encode_sdo_request(3, SdoRequest{SdoRequest::Kind::write, object::modes_of_operation, 0, 10, 1}, f);
  EXPECT_EQ(f.id, 0x603u);
  EXPECT_EQ(bytes(f), (std::vector<int>{0x2F, 0x60, 0x60, 0x00, 0x0A, 0x00, 0x00, 0x00}));
  // The drive decodes it, answers; the host decodes the answer.
  SdoRequest req;
  ASSERT_EQ(decode_sdo_request(f, 3, req), FrameStatus::ok);
  EXPECT_EQ(req.kind, SdoRequest::Kind::write);
  EXPECT_EQ(req.index, 0x6060);
  EXPECT_EQ(req.size, 1);
  EXPECT_EQ(req.value, 10u);
  encode_sdo_response(3, SdoResponse{SdoResponse::Kind::write_ok, 0x6060, 0, 0, 0}, f);
  EXPECT_EQ(f.id, 0x583u);
  EXPECT_EQ(bytes(f), (std::vector<int>{0x60, 0x60, 0x60, 0x00, 0x00, 0x00, 0x00, 0x00}));
  SdoResponse res;
  ASSERT_EQ(decode_sdo_response(f, 3, res), FrameStatus::ok);
  EXPECT_EQ(res.kind, SdoResponse::Kind::write_ok);
  EXPECT_EQ(res.index, 0x6060);
}

TEST(Cia402Sdo, WorkedExampleReadStatusword) {
  Frame f;
  encode_sdo_request(3, SdoRequest{SdoRequest::Kind::read, object::statusword, 0, 0, 0}, f);
  EXPECT_EQ(bytes(f), (std::vector<int>{0x40, 0x41, 0x60, 0x00, 0x00, 0x00, 0x00, 0x00}));
  encode_sdo_response(3, SdoResponse{SdoResponse::Kind::read_ok, 0x6041, 0, 0x0237, 2}, f);
  EXPECT_EQ(bytes(f), (std::vector<int>{0x4B, 0x41, 0x60, 0x00, 0x37, 0x02, 0x00, 0x00}));
  SdoResponse res;
  ASSERT_EQ(decode_sdo_response(f, 3, res), FrameStatus::ok);
  EXPECT_EQ(res.kind, SdoResponse::Kind::read_ok);
  EXPECT_EQ(res.size, 2);
  EXPECT_EQ(res.value, 0x0237u);
  EXPECT_EQ(decode_statusword(static_cast<std::uint16_t>(res.value)), State::operation_enabled);
}

TEST(Cia402Sdo, CommandSpecifiersBySize) {
  Frame f;
  const int expected[] = {0, 0x2F, 0x2B, 0x27, 0x23};
  for (std::uint8_t size = 1; size <= 4; ++size) {
    encode_sdo_request(1, SdoRequest{SdoRequest::Kind::write, 0x1017, 0, 0xAABBCCDD, size}, f);
    EXPECT_EQ(f.data[0], expected[size]);
    // Unused bytes are zero.
    for (int i = 4 + size; i < 8; ++i) EXPECT_EQ(f.data[i], 0) << "size " << int(size) << " byte " << i;
  }
  const int read_answer[] = {0, 0x4F, 0x4B, 0x47, 0x43};
  for (std::uint8_t size = 1; size <= 4; ++size) {
    encode_sdo_response(1, SdoResponse{SdoResponse::Kind::read_ok, 0x6076, 0, 1, size}, f);
    EXPECT_EQ(f.data[0], read_answer[size]);
  }
}

TEST(Cia402Sdo, AbortAndBadAnswers) {
  SdoResponse res;
  ASSERT_EQ(decode_sdo_response(frame_of(0x583, {0x80, 0x60, 0x60, 0x00, 0x00, 0x00, 0x02, 0x06}), 3, res),
            FrameStatus::ok);
  EXPECT_EQ(res.kind, SdoResponse::Kind::abort);
  EXPECT_EQ(res.value, abort_code::no_object);
  EXPECT_STREQ(abort_code_name(res.value), "object does not exist");
  // Segmented (0x41) is not in the subset; short frames and other nodes are rejected.
  EXPECT_EQ(decode_sdo_response(frame_of(0x583, {0x41, 0x60, 0x60, 0, 9, 0, 0, 0}), 3, res), FrameStatus::bad_command);
  EXPECT_EQ(decode_sdo_response(frame_of(0x583, {0x60, 0x60, 0x60, 0}), 3, res), FrameStatus::wrong_dlc);
  EXPECT_EQ(decode_sdo_response(frame_of(0x584, {0x60, 0x60, 0x60, 0, 0, 0, 0, 0}), 3, res), FrameStatus::unexpected_id);
  SdoRequest req;
  EXPECT_EQ(decode_sdo_request(frame_of(0x603, {0x21, 0, 0, 0, 0, 0, 0, 0}), 3, req), FrameStatus::bad_command);
}

TEST(Cia402Nmt, FramesAndHeartbeat) {
  Frame f;
  encode_nmt(NmtCommand::reset_communication, 3, f);
  EXPECT_EQ(f.id, 0x000u);
  EXPECT_EQ(bytes(f), (std::vector<int>{0x82, 0x03}));
  encode_nmt(NmtCommand::enter_pre_operational, 0, f);
  EXPECT_EQ(bytes(f), (std::vector<int>{0x80, 0x00}));
  NmtCommand cs{};
  std::uint8_t node = 99;
  ASSERT_EQ(decode_nmt(f, cs, node), FrameStatus::ok);
  EXPECT_EQ(cs, NmtCommand::enter_pre_operational);
  EXPECT_EQ(node, 0);
  EXPECT_EQ(decode_nmt(frame_of(0, {0x03, 1}), cs, node), FrameStatus::bad_command);

  encode_sync(f);
  EXPECT_EQ(f.id, 0x080u);
  EXPECT_EQ(f.len, 0);

  encode_heartbeat(7, NmtState::boot_up, f);
  EXPECT_EQ(f.id, 0x707u);
  EXPECT_EQ(bytes(f), (std::vector<int>{0x00}));
  NmtState s{};
  ASSERT_EQ(decode_heartbeat(frame_of(0x707, {0x05}), 7, s), FrameStatus::ok);
  EXPECT_EQ(s, NmtState::operational);
  ASSERT_EQ(decode_heartbeat(frame_of(0x707, {0x7F}), 7, s), FrameStatus::ok);
  EXPECT_EQ(s, NmtState::pre_operational);
  EXPECT_EQ(decode_heartbeat(frame_of(0x707, {0x06}), 7, s), FrameStatus::bad_value);
  EXPECT_EQ(decode_heartbeat(frame_of(0x707, {0x05, 0}), 7, s), FrameStatus::wrong_dlc);
  EXPECT_EQ(decode_heartbeat(frame_of(0x708, {0x05}), 7, s), FrameStatus::unexpected_id);
}

TEST(Cia402Emcy, LittleEndianCodeAndRegister) {
  Frame f;
  encode_emcy(4, Emcy{0x2310, 0x03, {1, 2, 3, 4, 5}}, f);
  EXPECT_EQ(f.id, 0x084u);
  EXPECT_EQ(bytes(f), (std::vector<int>{0x10, 0x23, 0x03, 1, 2, 3, 4, 5}));
  Emcy e;
  ASSERT_EQ(decode_emcy(f, 4, e), FrameStatus::ok);
  EXPECT_EQ(e.error_code, 0x2310);
  EXPECT_EQ(e.error_register, 3);
  EXPECT_EQ(decode_emcy(frame_of(0x084, {0x10, 0x23}), 4, e), FrameStatus::wrong_dlc);
  EXPECT_EQ(decode_emcy(f, 5, e), FrameStatus::unexpected_id);
}

TEST(Cia402StateMachine, StatuswordTable) {
  EXPECT_EQ(decode_statusword(0x0000), State::not_ready_to_switch_on);
  EXPECT_EQ(decode_statusword(0x0250), State::switch_on_disabled);  // + voltage, remote
  EXPECT_EQ(decode_statusword(0x0231), State::ready_to_switch_on);
  EXPECT_EQ(decode_statusword(0x0233), State::switched_on);
  EXPECT_EQ(decode_statusword(0x0237), State::operation_enabled);
  EXPECT_EQ(decode_statusword(0x0217), State::quick_stop_active);   // bit 5 = 0: quick stop active
  EXPECT_EQ(decode_statusword(0x021F), State::fault_reaction_active);
  EXPECT_EQ(decode_statusword(0x0218), State::fault);
}

TEST(Cia402StateMachine, ControlwordWalkToOperationEnabled) {
  // From Fault: edge on bit 7 (0x0080 after something without it), then 0x0006, 0x0007, 0x000F.
  EXPECT_EQ(controlword_towards_enabled(State::fault, 0x0000), 0x0080);
  EXPECT_EQ(controlword_towards_enabled(State::fault, 0x0080), 0x0000);
  EXPECT_EQ(controlword_towards_enabled(State::switch_on_disabled, 0x0080), 0x0006);
  EXPECT_EQ(controlword_towards_enabled(State::ready_to_switch_on, 0x0006), 0x0007);
  EXPECT_EQ(controlword_towards_enabled(State::switched_on, 0x0007), 0x000F);
  EXPECT_EQ(controlword_towards_enabled(State::operation_enabled, 0x000F), 0x000F);
}

// A step's time is the drive's answered cycles (CAN.md 4.3 step 4, 100 ms at 1 ms per SYNC).
TEST(Cia402StateMachine, AStepsTimeIsTheCyclesTheDriveAnswered) {
  constexpr std::int64_t ms = 1000000;
  StepClock clock(100, 1000);
  clock.restart(500, 0, 0);
  // 90 cycles answered over 90 ms, then a 60 ms stall of the host's (no SYNC, no answer), then
  // 10 more: 100 cycles of the drive's, 160 ms of the host's clock, not overdue.
  std::int64_t t = 0;
  for (std::uint64_t n = 501; n <= 590; ++n) EXPECT_FALSE(clock.overdue(n, t += ms)) << n;
  t += 60 * ms;
  for (std::uint64_t n = 591; n <= 600; ++n) EXPECT_FALSE(clock.overdue(n, t += ms)) << n;
  EXPECT_EQ(clock.cycles(600), 100u);
  // The 101st cycle answered in the same state is one too many.
  EXPECT_TRUE(clock.overdue(601, t += ms));
  // A new state restarts it.
  clock.restart(601, 0, t);
  EXPECT_FALSE(clock.overdue(650, t + 50 * ms));
  // A drive that answers nothing for the limit's time is overdue: after 100 ms of silence, not at 100.
  clock.restart(700, 0, 0);
  EXPECT_FALSE(clock.overdue(700, 100 * ms));
  EXPECT_TRUE(clock.overdue(700, 100 * ms + 1));
  // Silence counts from the last answer, not from the step's start.
  clock.restart(800, 0, 0);
  EXPECT_FALSE(clock.overdue(850, 80 * ms));
  EXPECT_FALSE(clock.overdue(850, 179 * ms));
  EXPECT_TRUE(clock.overdue(850, 181 * ms));
  // At another SYNC period the count scales: 100 ms at 2 ms per SYNC is 50 cycles.
  StepClock slow(100, 2000);
  slow.restart(0, 0, 0);
  EXPECT_FALSE(slow.overdue(50, 100 * ms));
  EXPECT_TRUE(slow.overdue(51, 102 * ms));
  // Default-made: a zero limit, overdue at the first answer.
  StepClock none;
  none.restart(0, 0, 0);
  EXPECT_TRUE(none.overdue(1, 0));
}

// A drive running behind answers, after the step began, SYNCs sent before it: those are not the
// step's cycles. Here 30 SYNCs were unanswered at the start; the drive answers them, then 100 of
// the step's own, and only the 101st of those is one too many.
TEST(Cia402StateMachine, TheSyncsUnansweredWhenAStepBeganAreNotItsCycles) {
  constexpr std::int64_t ms = 1000000;
  StepClock clock(100, 1000);
  clock.restart(1000, 30, 0);
  std::int64_t t = 0;
  for (std::uint64_t n = 1001; n <= 1130; ++n) EXPECT_FALSE(clock.overdue(n, t += ms)) << n;
  EXPECT_EQ(clock.cycles(1030), 0u);
  EXPECT_EQ(clock.cycles(1130), 100u);
  EXPECT_TRUE(clock.overdue(1131, t += ms));
  // SYNCs lost for good count as unanswered too: at most the limit's count of them is taken, so a
  // drive is given at most twice the limit.
  clock.restart(2000, 5000, 0);
  EXPECT_FALSE(clock.overdue(2200, 200 * ms));
  EXPECT_TRUE(clock.overdue(2201, 201 * ms));
  // Silence still counts from the last answer, whatever was unanswered.
  clock.restart(3000, 50, 0);
  EXPECT_TRUE(clock.overdue(3000, 100 * ms + 1));
}

TEST(Cia402Pdo, CompactMappingSequence) {
  std::array<SdoWrite, kMaxMappingWrites> w{};
  const int n = pdo_mapping_sequence(3, Mapping::compact, w);
  ASSERT_EQ(n, 21);
  // RPDO1: invalidate, clear, two entries, count, synchronous, valid COB-ID (CAN.md 2.6).
  EXPECT_EQ(w[0].index, 0x1400);
  EXPECT_EQ(w[0].sub, 1);
  EXPECT_EQ(w[0].value, 0x80000203u);
  EXPECT_EQ(w[1].index, 0x1600);
  EXPECT_EQ(w[1].value, 0u);
  EXPECT_EQ(w[2].value, 0x60400010u);
  EXPECT_EQ(w[3].value, 0x60710010u);
  EXPECT_EQ(w[4].value, 2u);
  EXPECT_EQ(w[5].index, 0x1400);
  EXPECT_EQ(w[5].sub, 2);
  EXPECT_EQ(w[5].value, 1u);
  EXPECT_EQ(w[6].value, 0x203u);
  // TPDO1: statusword, position, torque.
  EXPECT_EQ(w[7].index, 0x1800);
  EXPECT_EQ(w[9].value, 0x60410010u);
  EXPECT_EQ(w[10].value, 0x60640020u);
  EXPECT_EQ(w[11].value, 0x60770010u);
  EXPECT_EQ(w[12].value, 3u);
  EXPECT_EQ(w[14].value, 0x183u);
  // TPDO2 disabled.
  EXPECT_EQ(w[15].index, 0x1801);
  EXPECT_EQ(w[15].value, 0x80000283u);
}

TEST(Cia402Pdo, Rpdo1AndTpdoLayouts) {
  Frame f;
  encode_rpdo1(3, Rpdo1{0x000F, -100}, f);
  EXPECT_EQ(f.id, 0x203u);
  EXPECT_EQ(bytes(f), (std::vector<int>{0x0F, 0x00, 0x9C, 0xFF}));
  Rpdo1 r;
  ASSERT_EQ(decode_rpdo1(f, 3, r), FrameStatus::ok);
  EXPECT_EQ(r.target_torque, -100);

  Feedback fb;
  // compact TPDO1: sw 0x0237, position -2 (FE FF FF FF), torque 0x0102.
  ASSERT_EQ(decode_tpdo1(frame_of(0x183, {0x37, 0x02, 0xFE, 0xFF, 0xFF, 0xFF, 0x02, 0x01}), 3, Mapping::compact, fb),
            FrameStatus::ok);
  EXPECT_EQ(fb.statusword, 0x0237);
  EXPECT_EQ(fb.position, -2);
  EXPECT_EQ(fb.torque, 0x0102);
  EXPECT_EQ(decode_tpdo1(frame_of(0x183, {0x37, 0x02, 0, 0, 0, 0}), 3, Mapping::compact, fb), FrameStatus::wrong_dlc);
  ASSERT_EQ(decode_tpdo1(frame_of(0x183, {0x37, 0x02, 0x10, 0, 0, 0}), 3, Mapping::two_tpdo, fb), FrameStatus::ok);
  EXPECT_EQ(fb.position, 16);
  ASSERT_EQ(decode_tpdo2(frame_of(0x283, {0x18, 0xFC, 0xFF, 0xFF, 0x05, 0x00}), 3, fb), FrameStatus::ok);
  EXPECT_EQ(fb.velocity, -1000);
  EXPECT_EQ(fb.torque, 5);
  EXPECT_EQ(decode_tpdo2(frame_of(0x284, {0, 0, 0, 0, 0, 0}), 3, fb), FrameStatus::unexpected_id);
}

TEST(Cia402Torque, PermilleOfRatedTorque) {
  // 150 Nm joint-side rating: one unit = 0.15 Nm (CAN.md 2.4).
  EXPECT_EQ(torque_to_permille(3.0, 150.0, 1.0, 1000), 20);
  EXPECT_EQ(torque_to_permille(-0.074, 150.0, 1.0, 1000), 0);
  EXPECT_EQ(torque_to_permille(-0.076, 150.0, 1.0, 1000), -1);
  EXPECT_EQ(torque_to_permille(500.0, 150.0, 1.0, 800), 800);   // clamped to 0x6072
  EXPECT_EQ(torque_to_permille(10.0, 2.0, 10.0, 1000), 500);    // motor-side rating, gear 10
  EXPECT_DOUBLE_EQ(permille_to_torque(20, 150.0, 1.0), 3.0);
}

// Start-up scaling from the 0x6076 a drive reports (CAN.md 2.4, 4.3 step 2), not from the config.
TEST(Cia402Torque, ScaleFromTheDrivesRatedTorque) {
  TorqueScale s;
  // The spec's 150 Nm rating on a 39 Nm arm joint: 0.15 Nm per unit, 0x6072 = 39 / 0.15 = 260.
  ASSERT_EQ(make_torque_scale(150000, 1.0, 39.0, 0, s), TorqueScaleStatus::ok);
  EXPECT_DOUBLE_EQ(s.nm_per_permille, 0.15);
  EXPECT_EQ(s.max_permille, 260);
  EXPECT_EQ(torque_to_permille(3.0, s), 20);
  EXPECT_EQ(torque_to_permille(-0.076, s), -1);
  EXPECT_EQ(torque_to_permille(100.0, s), 260);    // clamped to 0x6072: the joint's limit
  EXPECT_EQ(torque_to_permille(-100.0, s), -260);
  EXPECT_EQ(torque_to_permille(std::nan(""), s), 0);
  EXPECT_DOUBLE_EQ(permille_to_torque(20, s), 3.0);
  // The same joint with a 39 Nm rating (the old default): 0x6072 = 1000.
  ASSERT_EQ(make_torque_scale(39000, 1.0, 39.0, 0, s), TorqueScaleStatus::ok);
  EXPECT_EQ(s.max_permille, 1000);
  EXPECT_EQ(torque_to_permille(3.0, s), 77);
  // A configured cap below the joint's limit wins.
  ASSERT_EQ(make_torque_scale(150000, 1.0, 39.0, 100, s), TorqueScaleStatus::ok);
  EXPECT_EQ(s.max_permille, 100);
  EXPECT_EQ(torque_to_permille(100.0, s), 100);
  // Motor-side rating 2 Nm, gear 10: 0.02 Nm per unit; 150 Nm joint -> 7500.
  ASSERT_EQ(make_torque_scale(2000, 10.0, 150.0, 0, s), TorqueScaleStatus::ok);
  EXPECT_EQ(s.max_permille, 7500);
  EXPECT_EQ(torque_to_permille(10.0, s), 500);
  // A drive far weaker than the joint: 0x6072 saturates at the i16 range of 0x6071.
  ASSERT_EQ(make_torque_scale(1000, 1.0, 150.0, 0, s), TorqueScaleStatus::ok);
  EXPECT_EQ(s.max_permille, 32767);
  // Unusable values: 0, and one unit (0.1 %) coarser than the joint's torque limit.
  EXPECT_EQ(make_torque_scale(0, 1.0, 39.0, 0, s), TorqueScaleStatus::zero_rating);
  EXPECT_EQ(s.max_permille, 0);  // and nothing scales through it
  EXPECT_EQ(torque_to_permille(3.0, s), 0);
  EXPECT_EQ(make_torque_scale(39001000, 1.0, 39.0, 0, s), TorqueScaleStatus::too_coarse);
  ASSERT_EQ(make_torque_scale(39000000, 1.0, 39.0, 0, s), TorqueScaleStatus::ok);  // one unit = the limit
  EXPECT_EQ(s.max_permille, 1);
  EXPECT_EQ(make_torque_scale(0xFFFFFFFFu, 1.0, 150.0, 0, s), TorqueScaleStatus::too_coarse);
}

}  // namespace
}  // namespace springbok::can::cia402
