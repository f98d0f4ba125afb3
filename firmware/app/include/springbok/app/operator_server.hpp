// The operator's local UNIX stream socket, served by a normal (non-RT)
// thread. Lines are checked here; well-formed commands go to the RT thread
// through the lock-free mailbox and the verdict comes back. A client can
// neither block nor crash the loop: sockets are non-blocking, lines are
// bounded, at most kMaxClients are served, and the RT side only ever pops.
#pragma once

#include <atomic>
#include <string>
#include <thread>

#include "springbok/app/flight_recorder.hpp"
#include "springbok/app/operator.hpp"
#include "springbok/rt/executive.hpp"

namespace springbok::app {

class OperatorServer {
 public:
  static constexpr int kMaxClients = 8;
  static constexpr int kReplyTimeoutMs = 500;

  // `status`: the server thread is the only reader of status.controller.
  OperatorServer(OperatorMailbox& mailbox, LoopStatus& status, const rt::PublishedStats& stats);
  ~OperatorServer();
  OperatorServer(const OperatorServer&) = delete;
  OperatorServer& operator=(const OperatorServer&) = delete;

  // The flight recorder `dump` writes (nullptr: "dump" is refused). Start-up.
  void set_recorder(FlightRecorder* recorder) noexcept { recorder_ = recorder; }

  // Binds and listens (replacing a stale socket file); "" or the error.
  std::string open(const std::string& socket_path);
  void start();
  void stop();

  // The reply to one line (also what the socket sends, without the newline).
  std::string handle_line(std::string_view line);

 private:
  void run();
  std::string status_line() const;
  std::string controller_line();
  std::string exchange(OperatorRequest request, const std::string& name);

  OperatorMailbox& mailbox_;
  LoopStatus& status_;
  const rt::PublishedStats& stats_;
  std::string path_;
  int listen_fd_ = -1;
  std::uint64_t next_id_ = 1;
  FlightRecorder* recorder_ = nullptr;
  std::atomic<bool> stop_{false};
  std::thread thread_;
};

}  // namespace springbok::app
