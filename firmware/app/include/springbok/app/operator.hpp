// Operator commands: the text protocol of the local UNIX socket and the
// lock-free mailbox that carries checked commands to the RT thread and its
// verdicts back. One line per command, one line per reply:
//
//   start | stop | reset | mode stand | mode control | status
//   -> "ok ..." or "error: ..."  (a malformed line changes nothing)
#pragma once

#include <atomic>
#include <cstdint>
#include <string>
#include <string_view>

#include "springbok/rt/spsc_ring.hpp"
#include "springbok/safety/supervisor.hpp"

namespace springbok::app {

inline constexpr std::size_t kMaxOperatorLine = 255;  // bytes, without the newline

struct ParsedLine {
  enum class Kind : std::uint8_t { command, status, error } kind = Kind::error;
  safety::OperatorCommand command = safety::OperatorCommand::stop;
  std::string error;  // for Kind::error: the reply, "error: ..."
};

// Checks one line (without its newline). Never throws.
ParsedLine parse_operator_line(std::string_view line);

struct OperatorRequest {
  std::uint64_t id = 0;
  safety::OperatorCommand command = safety::OperatorCommand::stop;
};

struct OperatorReply {
  std::uint64_t id = 0;
  safety::Verdict verdict = safety::Verdict::accepted;
  safety::Mode mode = safety::Mode::idle;  // after the command
  safety::FaultMask faults = 0;
};

struct OperatorMailbox {
  rt::SpscRing<OperatorRequest, 16> requests;  // server thread -> RT thread
  rt::SpscRing<OperatorReply, 16> replies;     // RT thread -> server thread
  // Requests with a smaller id timed out on the server side: never applied.
  std::atomic<std::uint64_t> first_valid_id{0};

  // RT side: the next request still wanted. rt: no alloc, no block
  bool take(OperatorRequest& out) noexcept {
    while (requests.pop(out)) {
      if (out.id >= first_valid_id.load(std::memory_order_acquire)) return true;
    }
    return false;
  }
};

// What the loop publishes every tick for `status` (read by the server thread).
struct LoopStatus {
  std::atomic<std::uint8_t> mode{0};
  std::atomic<std::uint32_t> faults{0};
  std::atomic<std::uint32_t> stale_ticks{0};
  std::atomic<std::uint64_t> hal_errors{0};  // ticks whose HAL read or write was not ok
  std::atomic<std::int32_t> limit_joint{-1};  // the joint that latched joint_limit, -1: none
  std::atomic<double> limit_joint_position_rad{0.0};
};

// "overrun_streak,hal_watchdog" or "none".
std::string fault_list(safety::FaultMask faults);

}  // namespace springbok::app
