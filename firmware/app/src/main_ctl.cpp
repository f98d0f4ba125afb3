// springbokctl: the operator socket's command-line client (README "The operator socket").
//
//   springbokctl [--socket PATH] [--field KEY] [--timeout-ms N] COMMAND [ARG...]
//
// Sends "COMMAND ARG..." as one line and prints the reply: on stdout and exit 0 when
// it is "ok ...", on stderr and exit 1 when it is "error: ...", exit 2 when the
// socket cannot be reached or does not answer in time. --field KEY prints only the
// value of KEY=value in the reply (e.g. `springbokctl --field mode status` -> control),
// exit 1 when the reply has no such key. The socket: --socket, else
// $SPRINGBOK_OPERATOR_SOCKET, else /run/springbok/operator.sock (the shipped config's).
#include <poll.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

namespace {

struct Reply {
  bool reached = false;
  std::string line;
  std::string error;  // why not reached
};

Reply exchange(const std::string& path, const std::string& line, int timeout_ms) {
  Reply r;
  sockaddr_un addr{};
  addr.sun_family = AF_UNIX;
  if (path.size() >= sizeof addr.sun_path) {
    r.error = "socket path too long: " + path;
    return r;
  }
  std::memcpy(addr.sun_path, path.c_str(), path.size() + 1);
  const int fd = ::socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0);
  if (fd < 0) {
    r.error = std::string("socket: ") + std::strerror(errno);
    return r;
  }
  if (::connect(fd, reinterpret_cast<const sockaddr*>(&addr), sizeof addr) != 0) {
    r.error = "cannot connect to " + path + ": " + std::strerror(errno);
    ::close(fd);
    return r;
  }
  const std::string out = line + "\n";
  if (::send(fd, out.data(), out.size(), MSG_NOSIGNAL) != static_cast<ssize_t>(out.size())) {
    r.error = "cannot send to " + path + ": " + std::strerror(errno);
    ::close(fd);
    return r;
  }
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::milliseconds(timeout_ms);
  char buf[4096];
  while (r.line.find('\n') == std::string::npos) {
    const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - std::chrono::steady_clock::now());
    pollfd p{fd, POLLIN, 0};
    if (left.count() <= 0 || ::poll(&p, 1, static_cast<int>(left.count())) != 1) {
      r.error = "no reply from " + path + " within " + std::to_string(timeout_ms) + " ms";
      ::close(fd);
      return r;
    }
    const ssize_t n = ::recv(fd, buf, sizeof buf, 0);
    if (n <= 0) {
      r.error = "the server at " + path + " closed the connection";
      ::close(fd);
      return r;
    }
    r.line.append(buf, static_cast<std::size_t>(n));
  }
  ::close(fd);
  r.line.erase(r.line.find('\n'));
  r.reached = true;
  return r;
}

// The value of `key=value` among the reply's words, or nullptr.
bool field(const std::string& reply, const std::string& key, std::string& value) {
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

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"springbokctl: send one command to the springbok operator socket and print the reply"};
  const char* env = std::getenv("SPRINGBOK_OPERATOR_SOCKET");
  std::string socket_path = env != nullptr && *env != '\0' ? env : "/run/springbok/operator.sock";
  std::string key;
  int timeout_ms = 2000;
  std::vector<std::string> words;
  app.add_option("--socket", socket_path, "the operator socket (default: $SPRINGBOK_OPERATOR_SOCKET, else "
                                          "/run/springbok/operator.sock)");
  app.add_option("--field", key, "print only the value of KEY=value in the reply");
  app.add_option("--timeout-ms", timeout_ms, "how long to wait for the reply")->check(CLI::Range(1, 600000));
  app.add_option("command", words,
                 "the command and its arguments: start | stop | reset | mode stand | mode control | status | "
                 "gait stand | gait trot [key=value ...] | walk VX VY YAW_RATE | tare | controller")
      ->required();
  app.footer("Exit status: 0 the reply is ok, 1 it is an error (or --field's key is missing), 2 no reply.");
  CLI11_PARSE(app, argc, argv);

  std::string line;
  for (const std::string& w : words) line += (line.empty() ? "" : " ") + w;
  const Reply r = exchange(socket_path, line, timeout_ms);
  if (!r.reached) {
    std::fprintf(stderr, "springbokctl: %s\n", r.error.c_str());
    return 2;
  }
  if (r.line.rfind("ok", 0) != 0) {
    std::fprintf(stderr, "%s\n", r.line.c_str());
    return 1;
  }
  if (!key.empty()) {
    std::string value;
    if (!field(r.line, key, value)) {
      std::fprintf(stderr, "springbokctl: no %s= in the reply: %s\n", key.c_str(), r.line.c_str());
      return 1;
    }
    std::printf("%s\n", value.c_str());
    return 0;
  }
  std::printf("%s\n", r.line.c_str());
  return 0;
}
