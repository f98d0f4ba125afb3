#include "springbok/can/socketcan.hpp"

#include <fcntl.h>
#include <linux/can.h>
#include <linux/can/error.h>
#include <linux/can/raw.h>
#include <net/if.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <ctime>
#include <utility>
#include <vector>

namespace springbok::can {

SocketCanBus::~SocketCanBus() { close(); }

SocketCanBus::SocketCanBus(SocketCanBus&& o) noexcept
    : fd_(std::exchange(o.fd_, -1)), fd_frames_(o.fd_frames_), last_errno_(o.last_errno_), interface_(std::move(o.interface_)) {}

SocketCanBus& SocketCanBus::operator=(SocketCanBus&& o) noexcept {
  if (this != &o) {
    close();
    fd_ = std::exchange(o.fd_, -1);
    fd_frames_ = o.fd_frames_;
    last_errno_ = o.last_errno_;
    interface_ = std::move(o.interface_);
  }
  return *this;
}

void SocketCanBus::close() noexcept {
  if (fd_ >= 0) ::close(fd_);
  fd_ = -1;
}

std::string SocketCanBus::open(const std::string& interface, bool fd, std::span<const std::uint32_t> rx_ids,
                               bool want_errors) {
  close();
  interface_ = interface;
  const auto fail = [&](const char* what) {
    const std::string msg = interface + ": " + what + ": " + std::strerror(errno);
    close();
    return msg;
  };
  fd_ = ::socket(PF_CAN, SOCK_RAW | SOCK_NONBLOCK | SOCK_CLOEXEC, CAN_RAW);
  if (fd_ < 0) return fail("socket(PF_CAN, SOCK_RAW, CAN_RAW)");
  if (interface.size() >= IFNAMSIZ) {
    close();
    return interface + ": interface name too long";
  }
  const unsigned index = ::if_nametoindex(interface.c_str());
  if (index == 0) return fail("no such CAN interface");
  if (fd) {
    const int on = 1;
    if (::setsockopt(fd_, SOL_CAN_RAW, CAN_RAW_FD_FRAMES, &on, sizeof on) != 0) return fail("CAN_RAW_FD_FRAMES");
  }
  fd_frames_ = fd;
  if (!rx_ids.empty()) {
    std::vector<can_filter> filters;
    for (std::uint32_t id : rx_ids) filters.push_back(can_filter{id, CAN_SFF_MASK | CAN_EFF_FLAG | CAN_RTR_FLAG});
    if (::setsockopt(fd_, SOL_CAN_RAW, CAN_RAW_FILTER, filters.data(),
                     static_cast<socklen_t>(filters.size() * sizeof(can_filter))) != 0) {
      return fail("CAN_RAW_FILTER");
    }
  }
  const can_err_mask_t err_mask = want_errors ? CAN_ERR_MASK : 0;
  if (::setsockopt(fd_, SOL_CAN_RAW, CAN_RAW_ERR_FILTER, &err_mask, sizeof err_mask) != 0) {
    return fail("CAN_RAW_ERR_FILTER");
  }
  sockaddr_can addr{};
  addr.can_family = AF_CAN;
  addr.can_ifindex = static_cast<int>(index);
  if (::bind(fd_, reinterpret_cast<sockaddr*>(&addr), sizeof addr) != 0) return fail("bind");
  return {};
}

TxStatus SocketCanBus::send(const Frame& f) noexcept {
  canfd_frame raw{};
  raw.can_id = f.error ? ((f.id & CAN_ERR_MASK) | CAN_ERR_FLAG) : (f.id & CAN_SFF_MASK);
  raw.len = f.len;
  if (f.fd) raw.flags = CANFD_BRS;
  std::memcpy(raw.data, f.data.data(), f.len <= CANFD_MAX_DLEN ? f.len : CANFD_MAX_DLEN);
  const std::size_t size = f.fd ? CANFD_MTU : CAN_MTU;
  const ssize_t n = ::write(fd_, &raw, size);
  if (n == static_cast<ssize_t>(size)) return TxStatus::ok;
  if (n >= 0) return TxStatus::short_write;
  last_errno_ = errno;
  return tx_status_of(errno);
}

TxStatus tx_status_of(int err) noexcept {
  if (err == ENOBUFS) return TxStatus::queue_full;
  if (err == EAGAIN || err == EWOULDBLOCK) return TxStatus::buffer_full;
  if (err == ENETDOWN) return TxStatus::net_down;
  return TxStatus::error;
}

RxStatus SocketCanBus::receive(Frame& f) noexcept {
  canfd_frame raw{};
  const ssize_t n = ::read(fd_, &raw, sizeof raw);
  if (n < 0) {
    last_errno_ = errno;
    return (errno == EAGAIN || errno == EWOULDBLOCK) ? RxStatus::empty : RxStatus::error;
  }
  if (n != static_cast<ssize_t>(CAN_MTU) && n != static_cast<ssize_t>(CANFD_MTU)) {
    last_errno_ = EPROTO;
    return RxStatus::error;
  }
  f.fd = n == static_cast<ssize_t>(CANFD_MTU);
  f.error = (raw.can_id & CAN_ERR_FLAG) != 0;
  f.id = f.error ? (raw.can_id & CAN_ERR_MASK) : (raw.can_id & CAN_EFF_MASK);
  f.len = raw.len <= (f.fd ? CANFD_MAX_DLEN : CAN_MAX_DLEN) ? raw.len : static_cast<std::uint8_t>(f.fd ? CANFD_MAX_DLEN : CAN_MAX_DLEN);
  std::memcpy(f.data.data(), raw.data, f.len);
  return RxStatus::frame;
}

bool wait_readable(std::span<const int> handles, std::int64_t timeout_us) noexcept {
  constexpr std::size_t kMax = 16;
  pollfd fds[kMax];
  std::size_t n = 0;
  for (int h : handles) {
    if (h >= 0 && n < kMax) fds[n++] = pollfd{h, POLLIN, 0};
  }
  if (n == 0 || timeout_us <= 0) return false;
  const timespec ts{static_cast<time_t>(timeout_us / 1000000), static_cast<long>((timeout_us % 1000000) * 1000)};
  return ::ppoll(fds, n, &ts, nullptr) > 0;
}

std::int64_t monotonic_ns() noexcept {
  timespec ts{};
  ::clock_gettime(CLOCK_MONOTONIC, &ts);
  return static_cast<std::int64_t>(ts.tv_sec) * 1000000000LL + ts.tv_nsec;
}

ErrorFrameInfo classify_error_frame(const Frame& f) noexcept {
  ErrorFrameInfo e;
  if (!f.error) return e;
  const std::uint32_t cls = f.id;
  e.bus_off = (cls & CAN_ERR_BUSOFF) != 0;
  e.no_ack = (cls & CAN_ERR_ACK) != 0;
  e.tx_timeout = (cls & CAN_ERR_TX_TIMEOUT) != 0;
  e.transceiver = (cls & CAN_ERR_TRX) != 0;
  e.protocol = (cls & (CAN_ERR_PROT | CAN_ERR_BUSERROR)) != 0;
  e.restarted = (cls & CAN_ERR_RESTARTED) != 0;
  if ((cls & CAN_ERR_CRTL) != 0 && f.len > 1) {
    const std::uint8_t c = f.data[1];
    e.warning = (c & (CAN_ERR_CRTL_RX_WARNING | CAN_ERR_CRTL_TX_WARNING)) != 0;
    e.error_passive = (c & (CAN_ERR_CRTL_RX_PASSIVE | CAN_ERR_CRTL_TX_PASSIVE)) != 0;
    e.overflow = (c & (CAN_ERR_CRTL_RX_OVERFLOW | CAN_ERR_CRTL_TX_OVERFLOW)) != 0;
    e.back_to_active = (c & CAN_ERR_CRTL_ACTIVE) != 0;
  }
#ifdef CAN_ERR_CNT
  if ((cls & CAN_ERR_CNT) != 0 && f.len >= 8) {
    e.has_counters = true;
    e.tx_errors = f.data[6];
    e.rx_errors = f.data[7];
  }
#endif
  return e;
}

void make_bus_off_frame(Frame& f) noexcept {
  f = Frame{};
  f.error = true;
  f.id = CAN_ERR_BUSOFF;
  f.len = CAN_ERR_DLC;
}

void make_restarted_frame(Frame& f) noexcept {
  f = Frame{};
  f.error = true;
  f.id = CAN_ERR_RESTARTED;
  f.len = CAN_ERR_DLC;
}

namespace {
void make_controller_frame(std::uint8_t status, Frame& f) noexcept {
  f = Frame{};
  f.error = true;
  f.id = CAN_ERR_CRTL;
  f.len = CAN_ERR_DLC;
  f.data[1] = status;
}
}  // namespace

void make_error_passive_frame(Frame& f) noexcept { make_controller_frame(CAN_ERR_CRTL_TX_PASSIVE, f); }

void make_error_active_frame(Frame& f) noexcept { make_controller_frame(CAN_ERR_CRTL_ACTIVE, f); }

}  // namespace springbok::can
