#include "springbok/app/operator_client.hpp"

#include <poll.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cstring>

namespace springbok::app {

bool OperatorClient::connect(std::string& error) {
  sockaddr_un addr{};
  addr.sun_family = AF_UNIX;
  if (path_.size() >= sizeof addr.sun_path) {
    error = "socket path too long: " + path_;
    return false;
  }
  std::memcpy(addr.sun_path, path_.c_str(), path_.size() + 1);
  fd_ = ::socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0);
  if (fd_ < 0) {
    error = std::string("socket: ") + std::strerror(errno);
    return false;
  }
  if (::connect(fd_, reinterpret_cast<const sockaddr*>(&addr), sizeof addr) != 0) {
    error = "cannot connect to " + path_ + ": " + std::strerror(errno);
    disconnect();
    return false;
  }
  pending_.clear();
  return true;
}

void OperatorClient::disconnect() noexcept {
  if (fd_ >= 0) ::close(fd_);
  fd_ = -1;
}

bool OperatorClient::exchange(const std::string& line, int timeout_ms, std::string& reply, std::string& error) {
  if (fd_ < 0 && !connect(error)) return false;
  const std::string out = line + "\n";
  if (::send(fd_, out.data(), out.size(), MSG_NOSIGNAL) != static_cast<ssize_t>(out.size())) {
    error = "cannot send to " + path_ + ": " + std::strerror(errno);
    disconnect();
    return false;
  }
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::milliseconds(timeout_ms);
  char buf[4096];
  while (pending_.find('\n') == std::string::npos) {
    const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - std::chrono::steady_clock::now());
    pollfd p{fd_, POLLIN, 0};
    if (left.count() <= 0 || ::poll(&p, 1, static_cast<int>(left.count())) != 1) {
      error = "no reply from " + path_ + " within " + std::to_string(timeout_ms) + " ms";
      disconnect();
      return false;
    }
    const ssize_t n = ::recv(fd_, buf, sizeof buf, 0);
    if (n <= 0) {
      error = "the server at " + path_ + " closed the connection";
      disconnect();
      return false;
    }
    pending_.append(buf, static_cast<std::size_t>(n));
  }
  const std::size_t newline = pending_.find('\n');
  reply = pending_.substr(0, newline);
  pending_.erase(0, newline + 1);
  return true;
}

bool reply_field(const std::string& reply, const std::string& key, std::string& value) {
  std::size_t at = 0;
  while (at < reply.size()) {
    const std::size_t end = std::min(reply.find(' ', at), reply.size());
    const std::string word = reply.substr(at, end - at);
    if (word.size() > key.size() && word.compare(0, key.size(), key) == 0 && word[key.size()] == '=') {
      value = word.substr(key.size() + 1);
      return true;
    }
    at = end + 1;
  }
  return false;
}

}  // namespace springbok::app
