// CiA 402 subset over CANopen (CiA 301), CAN.md section 2. Pure codecs: no I/O.
// CANopen fields are little-endian, packed byte by byte.
#pragma once

#include <algorithm>
#include <array>
#include <cstdint>

#include "springbok/can/frame.hpp"

namespace springbok::can::cia402 {

// Pre-defined connection set (CAN.md 2.1): function code + node id.
namespace cob {
inline constexpr std::uint32_t nmt = 0x000;
inline constexpr std::uint32_t sync = 0x080;
inline constexpr std::uint32_t emcy = 0x080;
inline constexpr std::uint32_t tpdo1 = 0x180;
inline constexpr std::uint32_t rpdo1 = 0x200;
inline constexpr std::uint32_t tpdo2 = 0x280;
inline constexpr std::uint32_t sdo_response = 0x580;  // server -> client
inline constexpr std::uint32_t sdo_request = 0x600;   // client -> server
inline constexpr std::uint32_t heartbeat = 0x700;
}  // namespace cob

inline constexpr int kMaxNode = 127;

enum class NmtCommand : std::uint8_t {
  start = 0x01,
  stop = 0x02,
  enter_pre_operational = 0x80,
  reset_node = 0x81,
  reset_communication = 0x82,
};

enum class NmtState : std::uint8_t { boot_up = 0x00, stopped = 0x04, operational = 0x05, pre_operational = 0x7F };

void encode_nmt(NmtCommand cs, std::uint8_t node, Frame& out) noexcept;
FrameStatus decode_nmt(const Frame& f, NmtCommand& cs, std::uint8_t& node) noexcept;
void encode_sync(Frame& out) noexcept;
void encode_heartbeat(std::uint8_t node, NmtState state, Frame& out) noexcept;
// rt: no alloc
FrameStatus decode_heartbeat(const Frame& f, std::uint8_t node, NmtState& state) noexcept;

struct Emcy {
  std::uint16_t error_code = 0;      // 0x0000 = error reset / no error
  std::uint8_t error_register = 0;   // object 0x1001
  std::array<std::uint8_t, 5> manufacturer{};
};
void encode_emcy(std::uint8_t node, const Emcy& e, Frame& out) noexcept;
// rt: no alloc
FrameStatus decode_emcy(const Frame& f, std::uint8_t node, Emcy& out) noexcept;

// ---- expedited SDO (CAN.md 2.3) -------------------------------------------------
struct SdoRequest {
  enum class Kind : std::uint8_t { read, write, abort } kind = Kind::read;
  std::uint16_t index = 0;
  std::uint8_t sub = 0;
  std::uint32_t value = 0;    // write: data; abort: abort code
  std::uint8_t size = 4;      // write: 1..4 bytes
};
struct SdoResponse {
  enum class Kind : std::uint8_t { write_ok, read_ok, abort } kind = Kind::write_ok;
  std::uint16_t index = 0;
  std::uint8_t sub = 0;
  std::uint32_t value = 0;    // read_ok: data; abort: abort code
  std::uint8_t size = 0;      // read_ok: 1..4, 0 = size not indicated (0x42)
};

void encode_sdo_request(std::uint8_t node, const SdoRequest& r, Frame& out) noexcept;
FrameStatus decode_sdo_request(const Frame& f, std::uint8_t node, SdoRequest& out) noexcept;
void encode_sdo_response(std::uint8_t node, const SdoResponse& r, Frame& out) noexcept;
FrameStatus decode_sdo_response(const Frame& f, std::uint8_t node, SdoResponse& out) noexcept;

namespace abort_code {
inline constexpr std::uint32_t timed_out = 0x05040000;
inline constexpr std::uint32_t bad_command = 0x05040001;
inline constexpr std::uint32_t unsupported_access = 0x06010000;
inline constexpr std::uint32_t read_only = 0x06010002;
inline constexpr std::uint32_t no_object = 0x06020000;
inline constexpr std::uint32_t not_mappable = 0x06040041;
inline constexpr std::uint32_t pdo_length_exceeded = 0x06040042;
inline constexpr std::uint32_t length_mismatch = 0x06070010;
inline constexpr std::uint32_t no_subindex = 0x06090011;
inline constexpr std::uint32_t value_out_of_range = 0x06090030;
inline constexpr std::uint32_t wrong_state = 0x08000022;
}  // namespace abort_code
const char* abort_code_name(std::uint32_t code) noexcept;

// ---- drive state machine (CAN.md 2.5) -----------------------------------------------
enum class State : std::uint8_t {
  not_ready_to_switch_on,
  switch_on_disabled,
  ready_to_switch_on,
  switched_on,
  operation_enabled,
  quick_stop_active,
  fault_reaction_active,
  fault,
  unknown,
};
State decode_statusword(std::uint16_t sw) noexcept;
const char* to_string(State s) noexcept;

namespace controlword {
inline constexpr std::uint16_t shutdown = 0x0006;
inline constexpr std::uint16_t switch_on = 0x0007;
inline constexpr std::uint16_t enable_operation = 0x000F;
inline constexpr std::uint16_t disable_operation = 0x0007;
inline constexpr std::uint16_t disable_voltage = 0x0000;
inline constexpr std::uint16_t quick_stop = 0x0002;
inline constexpr std::uint16_t fault_reset = 0x0080;
}  // namespace controlword

// The controlword that moves a drive in state `s` one step towards Operation
// enabled; `previous` is the last controlword sent (fault reset needs an edge).
std::uint16_t controlword_towards_enabled(State s, std::uint16_t previous) noexcept;

// How long a drive has spent on a state step (CAN.md 4.3 step 4: each step <= 100 ms), counted
// in the drive's own cycles: the SYNCs it answered with a TPDO1 (2.6), one per tick_us. A stall
// of the host's, of the bus's or of another process's spends none of the drive's time, so a
// drive that takes 90 of its 100 ms is not failed by the host's own delay; a drive that answers
// no SYNC for the whole limit is overdue as well (a silent drive answers no cycle). The host
// sends at most one SYNC per tick (a cycle missed is skipped, not caught up), so the count never
// runs ahead of the drive's clock.
class StepClock {
 public:
  StepClock() noexcept = default;  // a zero limit: overdue at once (assign one made with its limit)
  // `limit_ms`: the step's bound; `tick_us`: the SYNC period.
  StepClock(std::uint32_t limit_ms, std::uint32_t tick_us) noexcept
      : limit_cycles_(1000ULL * limit_ms / (tick_us > 0 ? tick_us : 1)), limit_ns_(1000000LL * limit_ms) {}
  // A step starts (a new state seen, a controlword sent): `tpdo1_count` is the drive's TPDO1
  // count so far, `unanswered_syncs` the SYNCs sent to it before now that it has not answered yet
  // (a drive or bus running behind answers them after the step began: they are not the step's
  // cycles; at most the limit's count of them is taken so, a drive that lost SYNCs for good is
  // given at most twice the limit), `now_ns` the host's clock.
  void restart(std::uint64_t tpdo1_count, std::uint64_t unanswered_syncs, std::int64_t now_ns) noexcept {
    start_count_ = tpdo1_count + std::min(unanswered_syncs, limit_cycles_);
    heard_count_ = tpdo1_count;
    heard_ns_ = now_ns;
  }
  // True once the drive has answered more cycles than the limit in this step, or none for the
  // limit's time.
  bool overdue(std::uint64_t tpdo1_count, std::int64_t now_ns) noexcept {
    if (tpdo1_count != heard_count_) {
      heard_count_ = tpdo1_count;
      heard_ns_ = now_ns;
    }
    return cycles(tpdo1_count) > limit_cycles_ || now_ns - heard_ns_ > limit_ns_;
  }
  // The cycles the drive answered in this step.
  std::uint64_t cycles(std::uint64_t tpdo1_count) const noexcept {
    return tpdo1_count > start_count_ ? tpdo1_count - start_count_ : 0;
  }

 private:
  std::uint64_t limit_cycles_ = 0;
  std::int64_t limit_ns_ = 0;
  std::uint64_t start_count_ = 0, heard_count_ = 0;
  std::int64_t heard_ns_ = 0;
};

// ---- objects and PDO mapping (CAN.md 2.4, 2.6) --------------------------------------------
namespace object {
inline constexpr std::uint16_t error_register = 0x1001;
inline constexpr std::uint16_t cycle_period = 0x1006;
inline constexpr std::uint16_t producer_heartbeat = 0x1017;
inline constexpr std::uint16_t error_behaviour = 0x1029;
inline constexpr std::uint16_t rpdo_comm = 0x1400;
inline constexpr std::uint16_t rpdo_map = 0x1600;
inline constexpr std::uint16_t tpdo_comm = 0x1800;
inline constexpr std::uint16_t tpdo_map = 0x1A00;
inline constexpr std::uint16_t error_code = 0x603F;
inline constexpr std::uint16_t abort_connection = 0x6007;
inline constexpr std::uint16_t controlword = 0x6040;
inline constexpr std::uint16_t statusword = 0x6041;
inline constexpr std::uint16_t quick_stop_option = 0x605A;
inline constexpr std::uint16_t modes_of_operation = 0x6060;
inline constexpr std::uint16_t modes_display = 0x6061;
inline constexpr std::uint16_t position_actual = 0x6064;
inline constexpr std::uint16_t velocity_actual = 0x606C;
inline constexpr std::uint16_t target_torque = 0x6071;
inline constexpr std::uint16_t max_torque = 0x6072;
inline constexpr std::uint16_t rated_torque = 0x6076;
inline constexpr std::uint16_t torque_actual = 0x6077;
inline constexpr std::uint16_t interpolation_period = 0x60C2;
inline constexpr std::uint16_t supported_modes = 0x6502;
}  // namespace object

inline constexpr std::int8_t kModeCst = 10;
inline constexpr std::uint32_t kSupportedModeCstBit = 1u << 9;
inline constexpr std::uint32_t kPdoInvalid = 0x80000000u;

constexpr std::uint32_t mapping_entry(std::uint16_t index, std::uint8_t sub, std::uint8_t bits) noexcept {
  return (std::uint32_t{index} << 16) | (std::uint32_t{sub} << 8) | bits;
}

enum class Mapping : std::uint8_t {
  compact,   // TPDO1 = statusword, position, torque (8 bytes); CAN.md 2.6
  two_tpdo,  // TPDO1 = statusword, position; TPDO2 = velocity, torque (6 + 6 bytes)
};

struct SdoWrite {
  std::uint16_t index = 0;
  std::uint8_t sub = 0;
  std::uint32_t value = 0;
  std::uint8_t size = 4;
  // Where present: a drive without the object does as well (an unused PDO it does not have
  // cannot transmit); CanHardware takes the "no such object" aborts as done.
  bool optional = false;
};

inline constexpr int kMaxMappingWrites = 40;
// The re-mapping sequence of CAN.md 2.6 for RPDO1 and the TPDOs of `m`, with
// the unused PDOs (RPDO2..4, TPDO2..4 as the mapping needs) disabled, where the drive has
// them (CAN.md 2 asks for nothing beyond the PDOs it uses). Returns the count.
int pdo_mapping_sequence(std::uint8_t node, Mapping m, std::array<SdoWrite, kMaxMappingWrites>& out) noexcept;

struct Rpdo1 {
  std::uint16_t controlword = 0;
  std::int16_t target_torque = 0;   // per mille of rated torque
};
// rt: no alloc
void encode_rpdo1(std::uint8_t node, const Rpdo1& r, Frame& out) noexcept;
FrameStatus decode_rpdo1(const Frame& f, std::uint8_t node, Rpdo1& out) noexcept;

// What the host receives in the TPDOs of one SYNC.
struct Feedback {
  std::uint16_t statusword = 0;
  std::int32_t position = 0;    // increments
  std::int32_t velocity = 0;    // velocity units (two_tpdo only)
  std::int16_t torque = 0;      // per mille of rated torque
};
// rt: no alloc. TPDO1: compact 8 bytes (sw, pos, torque) or 6 bytes (sw, pos).
FrameStatus decode_tpdo1(const Frame& f, std::uint8_t node, Mapping m, Feedback& out) noexcept;
// rt: no alloc. TPDO2 (two_tpdo only): velocity, torque.
FrameStatus decode_tpdo2(const Frame& f, std::uint8_t node, Feedback& out) noexcept;

// Joint torque <-> 0x6071 / 0x6077 (CAN.md 2.4), clamped to +-max_permille.
// rt: no alloc
std::int16_t torque_to_permille(double torque_nm, double rated_torque_nm, double gear_ratio,
                                std::uint16_t max_permille) noexcept;
double permille_to_torque(std::int16_t permille, double rated_torque_nm, double gear_ratio) noexcept;

// The torque scaling of one drive, fixed at start-up from the motor rated torque 0x6076 the
// drive reports (CAN.md 2.4, 4.3 step 2): 0x6071, 0x6072 and 0x6077 are per mille of it
// (times the gear ratio when the drive's torque is motor-side). Built once; the tick only
// multiplies.
struct TorqueScale {
  double nm_per_permille = 0.0;    // joint-side torque of one unit: gear_ratio * rated / 1000
  double permille_per_nm = 0.0;    // its inverse
  std::uint16_t max_permille = 0;  // 0x6072 as written: the joint's torque limit (or a lower cap)
};
enum class TorqueScaleStatus : std::uint8_t {
  ok,
  zero_rating,  // 0x6076 reads 0
  too_coarse,   // one unit (0.1 % of the rating) is larger than the joint's torque limit
};
// Start-up (no alloc). rated_mnm: 0x6076 as read; gear_ratio and joint_limit_nm > 0;
// cap_permille: a configured cap on 0x6072 (per mille of the rating), 0 = none. 0x6072 =
// round(1000 joint_limit / (gear_ratio rated)), at most the cap and 32767 (0x6071 is an i16).
TorqueScaleStatus make_torque_scale(std::uint32_t rated_mnm, double gear_ratio, double joint_limit_nm,
                                    std::uint16_t cap_permille, TorqueScale& out) noexcept;
// rt: no alloc. Rounded to the nearest unit, clamped to +-s.max_permille; 0 if not finite.
std::int16_t torque_to_permille(double torque_nm, const TorqueScale& s) noexcept;
// rt: no alloc
double permille_to_torque(std::int16_t permille, const TorqueScale& s) noexcept;

}  // namespace springbok::can::cia402
