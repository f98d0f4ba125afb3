// springbok-teleop: the pad's mapping (sticks scaled to the trot's limits, the dead zone, the
// rate, the dead-man on release, on a silent pad and on an unplug, the buttons), the recorded
// stream's checks, and the program run against an operator socket that records what it gets,
// the pad unplugged mid-walk.
#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

#include <atomic>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include <gtest/gtest.h>

#include "event_source.hpp"
#include "run_command.hpp"
#include "springbok/app/operator.hpp"
#include "springbok/gait/trot.hpp"
#include "teleop.hpp"

namespace {
using namespace springbok;
using teleop::Teleop;
using teleop::TeleopConfig;
using Lines = std::vector<std::string>;

// The trot's velocity limits, from the table the controller checks walks against.
double limit(const char* key) {
  for (const auto& f : gait::kTrotFields) {
    if (std::string(f.key) == key) return f.hi;
  }
  ADD_FAILURE() << "no trot field " << key;
  return 0.0;
}

std::string walk(double vx, double vy, double yaw) {
  char buf[96];
  std::snprintf(buf, sizeof buf, "walk %.3f %.3f %.3f", vx + 0.0, vy + 0.0, yaw + 0.0);
  return buf;
}

Lines poll(Teleop& pad, double t_s) {
  Lines out;
  pad.poll(t_s, out);
  return out;
}

const Lines kStop = {"walk 0 0 0", "gait stand"};

TEST(Teleop, FullSticksWalkAtTheTrotsLimitsInTheTrunksAxes) {
  Teleop pad(TeleopConfig{});
  pad.event(0.0, EV_KEY, BTN_TL, 1);
  pad.event(0.0, EV_ABS, ABS_Y, -32768);  // left stick up: forward
  EXPECT_EQ(poll(pad, 0.0), Lines{walk(limit("velocity_x"), 0, 0)});
  pad.event(0.1, EV_ABS, ABS_Y, 32767);   // down: backward
  pad.event(0.1, EV_ABS, ABS_X, -32768);  // left: +y
  pad.event(0.1, EV_ABS, ABS_RX, 32767);  // right stick right: turning clockwise, -yaw rate
  EXPECT_EQ(poll(pad, 0.1), Lines{walk(-limit("velocity_x"), limit("velocity_y"), -limit("yaw_rate"))});
}

TEST(Teleop, TheDeadZoneHoldsStillAndTheStickRisesFromItsEdge) {
  TeleopConfig c;
  c.dead_zone = 0.1;
  c.speed_fraction = 0.5;
  Teleop pad(c);
  pad.set_axis_range(ABS_Y, {0, 255});  // a pad reporting 0..255: centre 127.5
  pad.event(0.0, EV_KEY, BTN_TL, 1);
  pad.event(0.0, EV_ABS, ABS_Y, 128);
  EXPECT_EQ(pad.velocity()[0], 0.0);
  pad.event(0.0, EV_ABS, ABS_Y, 127 - 12);  // (127.5 - 115) / 127.5 = 0.098: inside
  EXPECT_EQ(pad.velocity()[0], 0.0);
  pad.event(0.0, EV_ABS, ABS_Y, 0);         // full up
  EXPECT_DOUBLE_EQ(pad.velocity()[0], 0.5 * limit("velocity_x"));
  pad.event(0.0, EV_ABS, ABS_Y, 64);        // x = -63.5 / 127.5, past the zone: (|x| - 0.1) / 0.9
  EXPECT_NEAR(pad.velocity()[0], 0.5 * limit("velocity_x") * (63.5 / 127.5 - 0.1) / 0.9, 1e-12);
}

TEST(Teleop, WalkCommandsGoAtTheRateWhileTheDeadManIsHeld) {
  Teleop pad(TeleopConfig{});  // 20 Hz
  EXPECT_TRUE(poll(pad, 0.0).empty());
  pad.event(0.0, EV_ABS, ABS_Y, -32768);
  EXPECT_TRUE(poll(pad, 0.01).empty()) << "no walking without the dead-man";
  pad.event(0.1, EV_KEY, BTN_TL, 1);
  int walks = 0;
  for (int ms = 100; ms < 1100; ms += 10) {
    pad.event(ms * 1e-3, EV_SYN, SYN_REPORT, 0);  // the pad keeps reporting
    for (const std::string& l : poll(pad, ms * 1e-3)) walks += l.rfind("walk ", 0) == 0 ? 1 : 0;
  }
  EXPECT_EQ(walks, 20);  // 1 s at 20 Hz
}

TEST(Teleop, ReleasingTheDeadManStopsOnceAndWalkingNeedsANewPress) {
  Teleop pad(TeleopConfig{});
  pad.event(0.0, EV_KEY, BTN_TL, 1);
  pad.event(0.0, EV_ABS, ABS_X, 32767);
  EXPECT_EQ(poll(pad, 0.0).size(), 1u);
  pad.event(0.02, EV_KEY, BTN_TL, 0);
  EXPECT_EQ(poll(pad, 0.02), kStop);
  pad.event(0.1, EV_ABS, ABS_X, -32767);
  EXPECT_TRUE(poll(pad, 0.1).empty());
  EXPECT_TRUE(poll(pad, 0.2).empty());
  pad.event(0.3, EV_KEY, BTN_TL, 1);
  EXPECT_EQ(poll(pad, 0.3), Lines{walk(0, limit("velocity_y"), 0)});
}

TEST(Teleop, APadSilentForTheTimeoutStopsTheWalk) {
  TeleopConfig c;
  c.event_timeout_s = 0.5;
  Teleop pad(c);
  pad.event(0.0, EV_KEY, BTN_TL, 1);
  pad.event(0.0, EV_ABS, ABS_Y, -32767);
  Lines all;
  for (int ms = 0; ms <= 500; ms += 10) {
    for (std::string& l : poll(pad, ms * 1e-3)) all.push_back(l);
  }
  EXPECT_EQ(all.back().rfind("walk ", 0), 0u) << "still walking at 0.5 s";
  EXPECT_NE(all.back(), "walk 0 0 0");
  EXPECT_EQ(poll(pad, 0.51), kStop);
  pad.event(0.6, EV_ABS, ABS_Y, -30000);  // events again, the dead-man still down: not without a new press
  EXPECT_TRUE(poll(pad, 0.6).empty());
  pad.event(0.7, EV_KEY, BTN_TL, 0);
  pad.event(0.7, EV_KEY, BTN_TL, 1);
  EXPECT_EQ(poll(pad, 0.7).size(), 1u);
}

TEST(Teleop, AnUnpluggedPadStopsTheWalkAndAReturningOneWaitsForAPress) {
  Teleop pad(TeleopConfig{});
  pad.event(0.0, EV_KEY, BTN_TL, 1);
  pad.event(0.0, EV_ABS, ABS_RX, -32768);
  EXPECT_EQ(poll(pad, 0.0), Lines{walk(0, 0, limit("yaw_rate"))});
  pad.unplugged(0.03);
  EXPECT_FALSE(pad.connected());
  EXPECT_EQ(poll(pad, 0.03), kStop);
  EXPECT_TRUE(poll(pad, 0.2).empty());
  pad.event(1.0, EV_ABS, ABS_RX, -32768);  // back
  EXPECT_TRUE(pad.connected());
  EXPECT_TRUE(poll(pad, 1.0).empty());
  EXPECT_EQ(pad.velocity()[2], limit("yaw_rate"));
}

TEST(Teleop, ButtonsSendTheirCommandOnPressOnly) {
  Teleop pad(TeleopConfig{});
  pad.event(0.0, EV_KEY, BTN_START, 1);
  pad.event(0.0, EV_KEY, BTN_START, 2);
  pad.event(0.0, EV_KEY, BTN_START, 0);
  pad.event(0.0, EV_KEY, BTN_SOUTH, 1);
  pad.event(0.0, EV_KEY, BTN_WEST, 1);
  pad.event(0.0, EV_KEY, BTN_NORTH, 1);
  pad.event(0.0, EV_KEY, BTN_EAST, 1);
  pad.event(0.0, EV_KEY, BTN_SELECT, 1);
  pad.event(0.0, EV_KEY, BTN_THUMBL, 1);  // not mapped
  EXPECT_EQ(poll(pad, 0.0), (Lines{"start", "mode control", "gait trot", "gait stand", "mode stand", "stop"}));
  EXPECT_TRUE(poll(pad, 0.1).empty());
}

struct TempDir {
  std::filesystem::path path =
      std::filesystem::temp_directory_path() / ("springbok_teleop_" + std::to_string(::getpid()));
  TempDir() { std::filesystem::create_directories(path); }
  ~TempDir() { std::filesystem::remove_all(path); }
};

std::string stream_error(const std::string& text) {
  TempDir dir;
  const auto file = dir.path / "events.txt";
  std::ofstream(file) << text;
  std::string error;
  EXPECT_EQ(teleop::open_recording(file.string(), error), nullptr) << text;
  return error.substr(error.find(':', error.find("events.txt")) + 1);
}

TEST(Teleop, ABadRecordedStreamIsRefusedNamingItsLine) {
  const std::pair<const char*, const char*> cases[] = {
      {"0.1 EV_KEY BTN_NOPE 1\n", "1: unknown EV_KEY code 'BTN_NOPE'"},
      {"# pad\n0.1 EV_KEY BTN_TL\n", "2: expected 'TYPE CODE VALUE'"},
      {"0.2 EV_SYN SYN_REPORT 0\n0.1 EV_SYN SYN_REPORT 0\n", "2: times must not decrease"},
      {"nan EV_SYN SYN_REPORT 0\n", "1: expected a time in seconds (0 to 1e6), got 'nan'"},
      {"axis ABS_Q 0 1\n", "1: unknown axis 'ABS_Q'"},
      {"axis ABS_X 5 5\n", "1: the axis's MIN must be below its MAX"},
      {"1.0 unplug now\n", "1: nothing may follow 'unplug'"},
      {"0.1 EV_BOGUS X 1\n", "1: unknown event type 'EV_BOGUS'"},
  };
  for (const auto& [text, error] : cases) EXPECT_EQ(stream_error(text), error) << text;
}

// An operator socket that keeps every line, answering "ok" to what the firmware's parser takes.
class RecordingServer {
 public:
  explicit RecordingServer(const std::string& path) : path_(path) {
    fd_ = ::socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0);
    sockaddr_un addr{};
    addr.sun_family = AF_UNIX;
    std::strncpy(addr.sun_path, path.c_str(), sizeof addr.sun_path - 1);
    EXPECT_EQ(::bind(fd_, reinterpret_cast<const sockaddr*>(&addr), sizeof addr), 0) << std::strerror(errno);
    EXPECT_EQ(::listen(fd_, 4), 0);
    thread_ = std::thread([this] { serve(); });
  }
  ~RecordingServer() {
    ::shutdown(fd_, SHUT_RDWR);
    ::close(fd_);
    thread_.join();
    ::unlink(path_.c_str());
  }
  Lines lines() {
    std::lock_guard<std::mutex> lock(mutex_);
    return lines_;
  }

 private:
  void serve() {
    for (;;) {
      const int client = ::accept(fd_, nullptr, nullptr);
      if (client < 0) return;
      std::string buffer;
      char chunk[512];
      ssize_t n;
      while ((n = ::recv(client, chunk, sizeof chunk, 0)) > 0) {
        buffer.append(chunk, static_cast<std::size_t>(n));
        for (std::size_t nl; (nl = buffer.find('\n')) != std::string::npos;) {
          const std::string line = buffer.substr(0, nl);
          buffer.erase(0, nl + 1);
          // The firmware's own parser judges the line: a teleop line it would refuse fails here.
          const app::ParsedLine parsed = app::parse_operator_line(line);
          EXPECT_NE(parsed.kind, app::ParsedLine::Kind::error) << line << ": " << parsed.error;
          {
            std::lock_guard<std::mutex> lock(mutex_);
            lines_.push_back(line);
          }
          const std::string reply = parsed.kind == app::ParsedLine::Kind::error ? parsed.error + "\n" : "ok\n";
          (void)::send(client, reply.data(), reply.size(), MSG_NOSIGNAL);
        }
      }
      ::close(client);
    }
  }
  std::string path_;
  int fd_ = -1;
  std::thread thread_;
  std::mutex mutex_;
  Lines lines_;
};

test::CommandRun teleop_program(const std::string& args) {
  return test::run_program(SPRINGBOK_TEST_EMULATOR, "springbok-teleop", args);
}

// The program with a recorded pad: start, mode control, trot, walk forward with the dead-man
// held, then the pad is pulled out mid-walk: the walk stops ("walk 0 0 0", "gait stand") and
// nothing follows.
TEST(Teleop, TheProgramWalksTheRobotAndStopsItWhenThePadIsUnpluggedMidWalk) {
  TempDir dir;
  const std::string socket = (dir.path / "operator.sock").string();
  const auto events = dir.path / "pad.txt";
  {
    std::ofstream f(events);
    f << "axis ABS_X -32768 32767\naxis ABS_Y -32768 32767\naxis ABS_RX -32768 32767\n"
         "0.00 EV_KEY BTN_START 1\n0.01 EV_KEY BTN_START 0\n"
         "0.05 EV_KEY BTN_SOUTH 1\n0.06 EV_KEY BTN_SOUTH 0\n"
         "0.10 EV_KEY BTN_WEST 1\n0.11 EV_KEY BTN_WEST 0\n"
         "0.20 EV_KEY BTN_TL 1\n0.20 EV_ABS ABS_Y -32768\n0.20 EV_SYN SYN_REPORT 0\n";
    for (int k = 1; k <= 6; ++k) f << 0.2 + 0.1 * k << " EV_SYN SYN_REPORT 0\n";  // the pad keeps talking
    f << "0.85 unplug\n";
  }
  RecordingServer server(socket);
  const test::CommandRun run = teleop_program("--events " + events.string() + " --socket " + socket);
  EXPECT_EQ(run.exit_code, 0) << run.out;
  EXPECT_NE(run.out.find("is gone"), std::string::npos) << run.out;
  const Lines got = server.lines();
  ASSERT_GE(got.size(), 5u);
  EXPECT_EQ((Lines{got[0], got[1], got[2]}), (Lines{"start", "mode control", "gait trot"}));
  std::size_t walks = 0;
  std::size_t i = 3;
  for (; i < got.size() && got[i] != "walk 0 0 0"; ++i) {
    EXPECT_EQ(got[i], walk(limit("velocity_x"), 0, 0)) << "line " << i;
    ++walks;
  }
  EXPECT_GE(walks, 9u);   // 0.65 s of walking at 20 Hz: 13 or 14, fewer on a slow machine
  EXPECT_LE(walks, 15u);
  ASSERT_EQ(got.size(), i + 2) << "nothing after the stop";
  EXPECT_EQ(got[i + 1], "gait stand");
}

TEST(Teleop, TheProgramRefusesABadStreamAndAMissingDevice) {
  TempDir dir;
  const auto events = dir.path / "pad.txt";
  std::ofstream(events) << "0.1 EV_KEY BTN_TL\n";
  test::CommandRun bad = teleop_program("--events " + events.string() + " --socket " + (dir.path / "none.sock").string());
  EXPECT_EQ(bad.exit_code, 2) << bad.out;
  EXPECT_NE(bad.out.find("pad.txt:1: expected 'TYPE CODE VALUE'"), std::string::npos) << bad.out;
  test::CommandRun missing = teleop_program("--device " + (dir.path / "event99").string());
  EXPECT_EQ(missing.exit_code, 2) << missing.out;
  EXPECT_NE(missing.out.find("cannot open"), std::string::npos) << missing.out;
}

}  // namespace
