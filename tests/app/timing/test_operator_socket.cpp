// Operator commands through the real UNIX socket (temp dir) while the loop
// ticks on the stepped clock: good ones change the mode, malformed ones get
// an error and change nothing, clients cannot block the server or the loop.
#include <gtest/gtest.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cstdlib>
#include <cstring>
#include <string>
#include <thread>
#include <vector>

#include "loop_fixture.hpp"
#include "springbok/app/operator_server.hpp"

namespace springbok::app::test {
namespace {

using Rig = LoopRig<KinematicTestHardware>;

TEST(OperatorLine, Parsing) {
  using K = ParsedLine::Kind;
  EXPECT_EQ(parse_operator_line("start").kind, K::command);
  EXPECT_EQ(parse_operator_line("  mode   control \r").command, safety::OperatorCommand::mode_control);
  EXPECT_EQ(parse_operator_line("status").kind, K::status);
  EXPECT_EQ(parse_operator_line("").error, "error: empty command (start, stop, mode, reset, status)");
  EXPECT_EQ(parse_operator_line("START").error, "error: unknown command 'START' (start, stop, mode, reset, status)");
  EXPECT_EQ(parse_operator_line("stop now").error, "error: stop takes no argument");
  EXPECT_EQ(parse_operator_line("mode").error, "error: mode needs one argument: stand or control");
  EXPECT_EQ(parse_operator_line("mode idle").error, "error: unknown mode 'idle' (stand or control)");
  EXPECT_EQ(parse_operator_line(std::string("st\0art", 6)).error, "error: non-printable byte in the command");
  EXPECT_EQ(parse_operator_line("reset \xff").error, "error: non-printable byte in the command");
  EXPECT_EQ(parse_operator_line(std::string(300, 'a')).error, "error: line too long (at most 255 bytes)");
}

int connect_to(const std::string& path) {
  const int fd = ::socket(AF_UNIX, SOCK_STREAM, 0);
  sockaddr_un addr{};
  addr.sun_family = AF_UNIX;
  std::strncpy(addr.sun_path, path.c_str(), sizeof addr.sun_path - 1);
  if (::connect(fd, reinterpret_cast<const sockaddr*>(&addr), sizeof addr) != 0) {
    ::close(fd);
    return -1;
  }
  timeval timeout{5, 0};
  ::setsockopt(fd, SOL_SOCKET, SO_RCVTIMEO, &timeout, sizeof timeout);
  return fd;
}

// Sends raw bytes, returns one reply line ("" on close or timeout).
std::string exchange(int fd, const std::string& bytes) {
  ::send(fd, bytes.data(), bytes.size(), MSG_NOSIGNAL);
  std::string reply;
  char c;
  while (::recv(fd, &c, 1, 0) == 1) {
    if (c == '\n') return reply;
    reply += c;
  }
  return reply;
}

struct OperatorSocket : ::testing::Test {
  rt::SteppedClock clock{0};
  KinematicTestHardware hardware{clock};
  std::unique_ptr<Rig> rig = std::make_unique<Rig>(clock, hardware);
  std::string dir;
  std::string path;
  std::unique_ptr<OperatorServer> server;

  void SetUp() override {
    char tmpl[] = "/tmp/springbok-op-XXXXXX";
    ASSERT_NE(::mkdtemp(tmpl), nullptr);
    dir = tmpl;
    path = dir + "/operator.sock";
    server = std::make_unique<OperatorServer>(rig->mailbox, rig->status, rig->executive->published());
    ASSERT_EQ(server->open(path), "");
    server->start();
  }
  void TearDown() override {
    server.reset();
    ::rmdir(dir.c_str());
  }

  // Runs `client` on its own thread while this thread ticks the loop.
  template <class F>
  void with_loop_running(F client) {
    std::atomic<bool> done{false};
    std::thread t([&] {
      client();
      done = true;
    });
    while (!done) {
      rig->executive->run_tick();
      std::this_thread::sleep_for(std::chrono::microseconds(200));
    }
    t.join();
  }
};

TEST_F(OperatorSocket, CommandsAndMalformedLines) {
  std::vector<std::string> replies;
  with_loop_running([&] {
    const int fd = connect_to(path);
    for (const char* line : {"status\n", "mode control\n", "frobnicate\n", "mode\n", "start now\n",
                             "\x01\x02\n", "mode fly\n", "status\n", "start\n", "start\n", "stop\n", "reset\n",
                             "status\n"}) {
      replies.push_back(exchange(fd, line));
    }
    ::close(fd);
  });
  ASSERT_EQ(replies.size(), 13u);
  EXPECT_EQ(replies[0].substr(0, 38), "ok status mode=idle faults=none ticks=");
  EXPECT_EQ(replies[1], "error: mode control: mode control needs mode stand (mode=idle faults=none)");
  EXPECT_EQ(replies[2], "error: unknown command 'frobnicate' (start, stop, mode, reset, status)");
  EXPECT_EQ(replies[3], "error: mode needs one argument: stand or control");
  EXPECT_EQ(replies[4], "error: start takes no argument");
  EXPECT_EQ(replies[5], "error: non-printable byte in the command");
  EXPECT_EQ(replies[6], "error: unknown mode 'fly' (stand or control)");
  EXPECT_EQ(replies[7].substr(0, 31), "ok status mode=idle faults=none");  // nothing changed
  EXPECT_EQ(replies[8], "ok start (mode=stand_up faults=none)");
  EXPECT_EQ(replies[9], "error: start: start needs mode idle (mode=stand_up faults=none)");
  EXPECT_EQ(replies[10], "ok stop (mode=damping faults=operator_stop)");
  EXPECT_EQ(replies[11], "ok reset (mode=idle faults=none)");
  EXPECT_EQ(replies[12].substr(0, 31), "ok status mode=idle faults=none");
}

TEST_F(OperatorSocket, ClientsCannotBlockOrFloodTheServer) {
  std::string after_long, from_second, too_many;
  with_loop_running([&] {
    const int silent = connect_to(path);  // connects, never sends
    const int flooder = connect_to(path);
    const std::string flood(1000, 'x');   // no newline: dropped with an error, connection closed
    after_long = exchange(flooder, flood);
    char c;
    const bool closed = ::recv(flooder, &c, 1, 0) <= 0;  // EOF or reset (unread bytes)
    EXPECT_TRUE(closed);
    const int second = connect_to(path);
    from_second = exchange(second, "status\n");
    std::vector<int> many;
    for (int i = 0; i < OperatorServer::kMaxClients + 2; ++i) many.push_back(connect_to(path));
    too_many = exchange(many.back(), "status\n");
    for (int fd : many) ::close(fd);
    ::close(second);
    ::close(flooder);
    ::close(silent);
  });
  EXPECT_EQ(after_long, "error: line too long (at most 255 bytes)");
  EXPECT_EQ(from_second.substr(0, 20), "ok status mode=idle ");
  EXPECT_EQ(too_many, "error: too many operator clients");
  EXPECT_EQ(rig->supervisor.mode(), safety::Mode::idle);
}

TEST_F(OperatorSocket, ACommandTheLoopNeverTookIsDroppedNotAppliedLater) {
  // The loop is not ticking: the server gives up and the command is cancelled.
  const int fd = connect_to(path);
  EXPECT_EQ(exchange(fd, "start\n"), "error: start: controller not responding, command dropped");
  ::close(fd);
  rig->executive->run_ticks(10);
  EXPECT_EQ(rig->supervisor.mode(), safety::Mode::idle);
}

}  // namespace
}  // namespace springbok::app::test
