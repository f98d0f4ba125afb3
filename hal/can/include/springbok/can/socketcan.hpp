// One raw SocketCAN socket bound to one interface, non-blocking (CAN.md section 4),
// and the classification of the controller's error frames. Linux only.
#pragma once

#include <cstdint>
#include <span>
#include <string>

#include "springbok/can/frame.hpp"

namespace springbok::can {

enum class TxStatus : std::uint8_t {
  ok = 0,
  queue_full = 1,   // ENOBUFS (device queue): drop, never retry in a loop; ticks in a row: bus fault
  net_down = 2,     // ENETDOWN: bus fault at once
  short_write = 3,  // the kernel took fewer bytes than a frame
  error = 4,        // any other errno
  buffer_full = 5,  // EAGAIN (the socket's buffer): drop, never retry in a loop; never a bus fault by itself
};
// What a failed write()'s errno means. rt: no alloc
TxStatus tx_status_of(int err) noexcept;

enum class RxStatus : std::uint8_t { frame = 0, empty = 1, error = 2 };

class SocketCanBus {
 public:
  SocketCanBus() = default;
  ~SocketCanBus();
  SocketCanBus(const SocketCanBus&) = delete;
  SocketCanBus& operator=(const SocketCanBus&) = delete;
  SocketCanBus(SocketCanBus&& other) noexcept;
  SocketCanBus& operator=(SocketCanBus&& other) noexcept;

  // Opens and binds; rx_ids (11-bit, exact match) become CAN_RAW_FILTER, empty = receive
  // everything. want_errors subscribes to every error class. Returns "" or why it failed.
  std::string open(const std::string& interface, bool fd, std::span<const std::uint32_t> rx_ids, bool want_errors);
  void close() noexcept;
  bool is_open() const noexcept { return fd_ >= 0; }
  int native_handle() const noexcept { return fd_; }
  const std::string& interface() const noexcept { return interface_; }

  // rt: no alloc, no block
  TxStatus send(const Frame& f) noexcept;
  // rt: no alloc, no block. `frame` when one was read, `empty` at EAGAIN.
  RxStatus receive(Frame& f) noexcept;
  int last_errno() const noexcept { return last_errno_; }

 private:
  int fd_ = -1;
  bool fd_frames_ = false;
  int last_errno_ = 0;
  std::string interface_;
};

// Waits until one of the sockets is readable or timeout_us passes (poll).
// Returns false on timeout. Bounded: used with the tick's receive deadline.
bool wait_readable(std::span<const int> handles, std::int64_t timeout_us) noexcept;

std::int64_t monotonic_ns() noexcept;

// What an error frame (Frame::error) says, <linux/can/error.h>.
struct ErrorFrameInfo {
  bool bus_off = false;
  bool error_passive = false;   // RX or TX passive
  bool warning = false;         // RX or TX warning level
  bool back_to_active = false;  // CAN_ERR_CRTL_ACTIVE
  bool overflow = false;        // RX or TX buffer overflow: frames lost
  bool no_ack = false;          // CAN_ERR_ACK: nobody acknowledged
  bool tx_timeout = false;
  bool transceiver = false;
  bool protocol = false;        // CAN_ERR_PROT / CAN_ERR_BUSERROR
  bool restarted = false;       // controller restarted after bus-off
  bool has_counters = false;    // CAN_ERR_CNT
  std::uint8_t tx_errors = 0;
  std::uint8_t rx_errors = 0;
};
// rt: no alloc
ErrorFrameInfo classify_error_frame(const Frame& f) noexcept;
// The fake bus-off the emulator writes (CAN.md section 5).
void make_bus_off_frame(Frame& f) noexcept;
void make_restarted_frame(Frame& f) noexcept;
// An error-passive controller report (CAN_ERR_CRTL, TX passive).
void make_error_passive_frame(Frame& f) noexcept;
// A controller report of its return to error active (CAN_ERR_CRTL, ACTIVE).
void make_error_active_frame(Frame& f) noexcept;

}  // namespace springbok::can
