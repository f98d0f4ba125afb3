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
#include "run_command.hpp"
#include "springbok/app/operator_server.hpp"

namespace springbok::app::test {
namespace {

using Rig = LoopRig<KinematicTestHardware>;

TEST(OperatorLine, Parsing) {
  using K = ParsedLine::Kind;
  EXPECT_EQ(parse_operator_line("start").kind, K::command);
  EXPECT_EQ(parse_operator_line("  mode   control \r").command, safety::OperatorCommand::mode_control);
  EXPECT_EQ(parse_operator_line("status").kind, K::status);
  EXPECT_EQ(parse_operator_line("").error, "error: empty command (start, stop, mode, reset, status, gait, walk, tune, hand, tare, controller, dump)");
  EXPECT_EQ(parse_operator_line("START").error, "error: unknown command 'START' (start, stop, mode, reset, status, gait, walk, tune, hand, tare, controller, dump)");
  EXPECT_EQ(parse_operator_line("stop now").error, "error: stop takes no argument");
  EXPECT_EQ(parse_operator_line("mode").error, "error: mode needs one argument: stand or control");
  EXPECT_EQ(parse_operator_line("mode idle").error, "error: unknown mode 'idle' (stand or control)");
  EXPECT_EQ(parse_operator_line(std::string("st\0art", 6)).error, "error: non-printable byte in the command");
  EXPECT_EQ(parse_operator_line("reset \xff").error, "error: non-printable byte in the command");
  EXPECT_EQ(parse_operator_line(std::string(300, 'a')).error, "error: line too long (at most 255 bytes)");
}

// The controller's requests; gait trot's keys checked by the config's reader.
TEST(OperatorLine, ControllerRequests) {
  using K = ParsedLine::Kind;
  const ParsedLine trot = parse_operator_line("gait trot step_frequency=1.2 duty_factor=0.7");
  ASSERT_EQ(trot.kind, K::controller_request) << trot.error;
  EXPECT_EQ(trot.name, "gait trot");
  EXPECT_EQ(trot.request.kind, ControllerRequest::Kind::gait);
  EXPECT_EQ(trot.request.gait.kind, control::GaitKind::trot);
  EXPECT_DOUBLE_EQ(trot.request.gait.trot.step_frequency_hz, 1.2);
  EXPECT_DOUBLE_EQ(trot.request.gait.trot.duty_factor, 0.7);
  EXPECT_DOUBLE_EQ(trot.request.gait.trot.step_height_m, gait::TrotParams{}.step_height_m);  // default kept
  const ParsedLine plain = parse_operator_line("gait trot");
  EXPECT_EQ(plain.kind, K::controller_request);
  EXPECT_DOUBLE_EQ(plain.request.gait.trot.duty_factor, gait::TrotParams{}.duty_factor);
  const ParsedLine stand = parse_operator_line(" gait  stand ");
  EXPECT_EQ(stand.kind, K::controller_request);
  EXPECT_EQ(stand.request.gait.kind, control::GaitKind::stand);
  EXPECT_EQ(parse_operator_line("tare").request.kind, ControllerRequest::Kind::tare);
  const ParsedLine walk = parse_operator_line("walk 0.3 -0.1 0.25");
  ASSERT_EQ(walk.kind, K::controller_request) << walk.error;
  EXPECT_EQ(walk.name, "walk");
  EXPECT_EQ(walk.request.kind, ControllerRequest::Kind::walk);
  EXPECT_EQ(walk.request.velocity, (std::array<double, 3>{0.3, -0.1, 0.25}));
  EXPECT_EQ(parse_operator_line("walk 0.6 0 0").error, "error: walk.velocity_x: must be in [-0.5, 0.5], got 0.6");
  EXPECT_EQ(parse_operator_line("walk 0 0 nan").error, "error: walk.yaw_rate: must be a finite number, got 'nan'");
  EXPECT_EQ(parse_operator_line("walk 0.1").error, "error: walk needs three numbers: v_x v_y yaw_rate (m/s, m/s, rad/s)");
  EXPECT_EQ(parse_operator_line("controller").kind, K::controller_status);

  EXPECT_EQ(parse_operator_line("gait trot duty_factor=0.3").error,
            "error: gait trot.duty_factor: must be in [0.5, 0.95], got 0.3");
  EXPECT_EQ(parse_operator_line("gait trot step_frequency=nan").error,
            "error: gait trot.step_frequency: must be a finite number, got 'nan'");
  EXPECT_EQ(parse_operator_line("gait trot step_frequency=1.4x").error,
            "error: gait trot.step_frequency: must be a number, got '1.4x'");
  EXPECT_EQ(parse_operator_line("gait trot speed=3").error.rfind("error: gait trot.speed: unknown key", 0), 0u);
  EXPECT_EQ(parse_operator_line("gait trot duty_factor").error, "error: gait trot: expected key=value, got 'duty_factor'");
  EXPECT_EQ(parse_operator_line("gait trot =1").error, "error: gait trot: expected key=value, got '=1'");
  EXPECT_EQ(parse_operator_line("gait trot duty_factor=0.6 duty_factor=0.7").error,
            "error: gait trot.duty_factor: given twice");
  EXPECT_EQ(parse_operator_line("gait").error, "error: gait needs an argument: stand or trot [key=value ...]");
  EXPECT_EQ(parse_operator_line("gait walk").error, "error: unknown gait 'walk' (stand or trot)");
  EXPECT_EQ(parse_operator_line("gait stand now").error, "error: gait stand takes no parameter");
  EXPECT_EQ(parse_operator_line("tare now").error, "error: tare takes no argument");
  EXPECT_EQ(parse_operator_line("controller x").error, "error: controller takes no argument");
}

// The log's words: what the numbers of a record mean, sensor and fault names included.
// Live tuning: the template's keys (a number for every axis or [x,y,z]), the posture
// gains and the ramp, with the config's ranges; keys not given are not set.
TEST(OperatorLine, TuneTakesTheTemplatesKeysWithTheConfigsRanges) {
  using K = ParsedLine::Kind;
  using T = control::TuningRequest;
  const ParsedLine p = parse_operator_line("tune base.stiffness=800 ee.mass=[4,4,2] posture_kp=50 ramp=0.5");
  ASSERT_EQ(p.kind, K::controller_request) << p.error;
  EXPECT_EQ(p.name, "tune");
  ASSERT_EQ(p.request.kind, ControllerRequest::Kind::tune);
  const T& t = p.request.tune;
  EXPECT_TRUE(t.set[T::base_stiffness]);
  EXPECT_EQ(t.value[T::base_stiffness], (std::array<double, 3>{800.0, 800.0, 800.0}));
  EXPECT_TRUE(t.set[T::ee_mass]);
  EXPECT_EQ(t.value[T::ee_mass], (std::array<double, 3>{4.0, 4.0, 2.0}));
  for (int part : {T::base_mass, T::base_damping, T::ee_damping, T::ee_stiffness}) EXPECT_FALSE(t.set[part]) << part;
  EXPECT_TRUE(t.set_posture_kp);
  EXPECT_EQ(t.posture_kp_per_s2, 50.0);
  EXPECT_FALSE(t.set_posture_kd);
  EXPECT_EQ(t.ramp_s, 0.5);
  const ParsedLine rot = parse_operator_line("tune rot.ee.stiffness=100 rot.ee.inertia=[0.2,0.2,0.4] rot.base.damping=120");
  ASSERT_EQ(rot.kind, K::controller_request) << rot.error;
  EXPECT_EQ(rot.request.tune.value[T::rot_ee_stiffness], (std::array<double, 3>{100.0, 100.0, 100.0}));
  EXPECT_EQ(rot.request.tune.value[T::rot_ee_inertia], (std::array<double, 3>{0.2, 0.2, 0.4}));
  EXPECT_TRUE(rot.request.tune.set[T::rot_base_damping]);
  EXPECT_FALSE(rot.request.tune.set[T::rot_base_stiffness]);
  EXPECT_EQ(parse_operator_line("tune rot.ee.inertia=0").error, "error: tune.rot.ee.inertia: must be in [1e-06, 1000], got 0");
  EXPECT_EQ(parse_operator_line("tune ee.damping=100").request.tune.ramp_s, 1.0);  // the default ramp
  EXPECT_EQ(parse_operator_line("tune ee.mass=0").error, "error: tune.ee.mass: must be in [1e-06, 10000], got 0");
  EXPECT_EQ(parse_operator_line("tune base.mass=[1,2]").error, "error: tune.base.mass: must be a list of 3, got 2 elements");
  EXPECT_EQ(parse_operator_line("tune ramp=100").error, "error: tune.ramp: must be in [0, 60], got 100");
  EXPECT_EQ(parse_operator_line("tune base.stiffness=stiff").error,
            "error: tune.base.stiffness: must be a number, got 'stiff'");
  EXPECT_NE(parse_operator_line("tune colour=1").error.find("tune.colour: unknown key"), std::string::npos);
  EXPECT_EQ(parse_operator_line("tune base.mass").error, "error: tune: expected key=value, got 'base.mass'");
  EXPECT_EQ(parse_operator_line("tune").error.rfind("error: tune needs key=value", 0), 0u);
  EXPECT_EQ(parse_operator_line("tune ramp=1 ramp=2").error, "error: tune.ramp: given twice");
}

TEST(OperatorLine, HandTakesAnOffsetAndADuration) {
  const ParsedLine p = parse_operator_line("hand 0.1 -0.05 0.02 1.5");
  ASSERT_EQ(p.kind, ParsedLine::Kind::controller_request) << p.error;
  EXPECT_EQ(p.request.kind, ControllerRequest::Kind::hand);
  EXPECT_EQ(p.request.hand_target, (std::array<double, 3>{0.1, -0.05, 0.02}));
  EXPECT_EQ(p.request.hand_duration_s, 1.5);
  EXPECT_EQ(parse_operator_line("hand 0.3 0 0 1").error, "error: hand.offset[0]: must be in [-0.25, 0.25], got 0.3");
  EXPECT_EQ(parse_operator_line("hand 0 0 0 0.01").error, "error: hand.duration: must be in [0.1, 60], got 0.01");
  EXPECT_EQ(parse_operator_line("hand 0 0 up 1").error, "error: hand.offset[2]: must be a number, got 'up'");
  EXPECT_EQ(parse_operator_line("hand 0 0 1").error.rfind("error: hand needs x y z", 0), 0u);
  const ParsedLine turn = parse_operator_line("hand 0 0 0.05 0.3 0 -0.2 2");
  ASSERT_EQ(turn.kind, ParsedLine::Kind::controller_request) << turn.error;
  EXPECT_EQ(turn.request.hand_rotation[0], 0.3);
  EXPECT_EQ(turn.request.hand_rotation[2], -0.2);
  EXPECT_EQ(turn.request.hand_target[2], 0.05);
  EXPECT_EQ(turn.request.hand_duration_s, 2.0);
  EXPECT_EQ(parse_operator_line("hand 0 0 0 0.7 0 0 2").error, "error: hand.rotation[0]: must be in [-0.6, 0.6], got 0.7");
  EXPECT_EQ(parse_operator_line("hand 0 0 0 0 0 2").error.rfind("error: hand needs x y z", 0), 0u);
}

TEST(OperatorLine, LogRecordsAreDescribedByName) {
  using safety::fault::kImuLost;
  using safety::fault::kWristFtLost;
  const auto describe = [](rt::LogEvent e, std::int64_t a, std::int64_t b) {
    return describe_log_record(rt::LogRecord{1, 0, e, a, b, 0.0});
  };
  EXPECT_EQ(describe(rt::LogEvent::fault_latched, kImuLost, kImuLost | kWristFtLost),
            "new=imu_lost latched=imu_lost,wrist_ft_lost");
  EXPECT_EQ(describe(rt::LogEvent::sensors_lost, kWristFtLost, static_cast<std::int64_t>(safety::Mode::stand)),
            "lost=wrist_ft_lost mode=stand");
  EXPECT_EQ(describe(rt::LogEvent::mode_change, static_cast<std::int64_t>(safety::Mode::control),
                     static_cast<std::int64_t>(safety::Mode::damping)),
            "control -> damping");
  EXPECT_EQ(describe(rt::LogEvent::command_rejected, static_cast<std::int64_t>(safety::OperatorCommand::mode_control),
                     static_cast<std::int64_t>(safety::Verdict::sensor_lost)),
            std::string("mode control: ") + safety::to_string(safety::Verdict::sensor_lost));
  EXPECT_EQ(describe(rt::LogEvent::controller_request, 0, 1), "gait trot");
  EXPECT_EQ(describe(rt::LogEvent::controller_request_refused, 1, 0), "tare");
  EXPECT_EQ(describe(rt::LogEvent::mode_change, 99, -1), "? -> ?");
  EXPECT_EQ(describe(rt::LogEvent::buses_degraded, (1 << 6) | 1, 1 << 6), "degraded=bus0,bus6 was=bus6");
  EXPECT_EQ(describe(rt::LogEvent::buses_degraded, 0, 1 << 9), "degraded=none was=bus9");
  EXPECT_EQ(describe(rt::LogEvent::overrun, 1, 2), "");
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
                             "status\n", "gait trot duty_factor=0.65\n", "tare\n", "controller\n"}) {
      replies.push_back(exchange(fd, line));
    }
    ::close(fd);
  });
  ASSERT_EQ(replies.size(), 16u);
  EXPECT_EQ(replies[0].substr(0, 38), "ok status mode=idle faults=none ticks=");
  EXPECT_EQ(replies[1], "error: mode control: mode control needs mode stand (mode=idle faults=none)");
  EXPECT_EQ(replies[2], "error: unknown command 'frobnicate' (start, stop, mode, reset, status, gait, walk, tune, hand, tare, controller, dump)");
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
  // The rig's control mode is joint_pd: the controller's requests are refused, saying why.
  EXPECT_EQ(replies[13], std::string("error: gait trot: ") + kNotTheWbc + " (mode=idle faults=none)");
  EXPECT_EQ(replies[14], std::string("error: tare: ") + kNotTheWbc + " (mode=idle faults=none)");
  EXPECT_EQ(replies[15], "ok controller controller=joint_pd");
}

// springbokctl, the socket's command-line client, run: the reply on stdout and exit 0 when
// ok, on stderr and exit 1 when an error, --field prints one value, exit 2 without a server.
using CliRun = springbok::test::CommandRun;
// A cross-built client runs under the build's emulator (qemu-aarch64), as ctest runs this test.
CliRun springbokctl(const std::string& args) {
  return springbok::test::run_program(SPRINGBOK_TEST_EMULATOR, "springbokctl", args);
}

TEST_F(OperatorSocket, SpringbokctlSendsOneCommandAndExitsWithItsVerdict) {
  CliRun status, mode, field, missing_key, start, bad;
  with_loop_running([&] {
    status = springbokctl("--socket " + path + " status");
    mode = springbokctl("--socket " + path + " mode control");
    field = springbokctl("--socket " + path + " --field mode status");
    missing_key = springbokctl("--socket " + path + " --field colour status");
    start = springbokctl("--socket " + path + " start");
    bad = springbokctl("--socket " + path + " gait trot duty_factor=2");
  });
  EXPECT_EQ(status.exit_code, 0) << status.out;
  EXPECT_EQ(status.out.substr(0, 31), "ok status mode=idle faults=none");
  EXPECT_EQ(mode.exit_code, 1) << mode.out;
  EXPECT_EQ(mode.out, "error: mode control: mode control needs mode stand (mode=idle faults=none)\n");
  EXPECT_EQ(field.exit_code, 0) << field.out;
  EXPECT_EQ(field.out, "idle\n");
  EXPECT_EQ(missing_key.exit_code, 1) << missing_key.out;
  EXPECT_EQ(start.exit_code, 0) << start.out;
  EXPECT_EQ(start.out, "ok start (mode=stand_up faults=none)\n");
  EXPECT_EQ(bad.exit_code, 1) << bad.out;
  const CliRun nobody = springbokctl("--socket " + dir + "/none.sock status");
  EXPECT_EQ(nobody.exit_code, 2) << nobody.out;
  EXPECT_NE(nobody.out.find("springbokctl: cannot connect to " + dir + "/none.sock"), std::string::npos) << nobody.out;
  const CliRun help = springbokctl("--help");
  EXPECT_EQ(help.exit_code, 0);
  EXPECT_NE(help.out.find("--field"), std::string::npos) << help.out;
  EXPECT_NE(springbokctl("").exit_code, 0);  // a command is required
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
