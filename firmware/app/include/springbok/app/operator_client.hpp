// A client of the operator socket (operator.hpp's text protocol): one connection, a line out,
// its reply line back within a timeout. springbokctl sends one line per run; springbok-teleop
// keeps the connection and sends a line per command (reconnecting when the server went away).
// Not real-time code: it allocates and blocks.
#pragma once

#include <string>

namespace springbok::app {

class OperatorClient {
 public:
  explicit OperatorClient(std::string socket_path) : path_(std::move(socket_path)) {}
  ~OperatorClient() { disconnect(); }
  OperatorClient(const OperatorClient&) = delete;
  OperatorClient& operator=(const OperatorClient&) = delete;

  // Sends `line` (connecting first when not connected) and waits up to timeout_ms for the
  // reply. True with `reply` set (without its newline); false with `error` saying why (the
  // connection is then closed: the next exchange connects again).
  bool exchange(const std::string& line, int timeout_ms, std::string& reply, std::string& error);
  void disconnect() noexcept;
  const std::string& path() const noexcept { return path_; }

 private:
  bool connect(std::string& error);

  std::string path_;
  int fd_ = -1;
  std::string pending_;  // bytes received after the last reply's newline
};

// The value of `key=value` among a reply's words; false when there is none.
bool reply_field(const std::string& reply, const std::string& key, std::string& value);

}  // namespace springbok::app
