// The deployed program's live telemetry, end to end: springbok-on-sim (the firmware on
// the simulated robot) runs for 2 s with the shipped config, its telemetry pointed at a
// UDP socket of this test on loopback; the datagrams are what PlotJuggler's UDP server
// reads (one flat JSON object each, a `timestamp` in seconds) at the configured rate: the
// shipped 100 Hz, and the most there is, 1 kHz (one datagram per tick), with no drop. At the
// stop the flight recorder writes every tick of the run to its CSV file.
#include <arpa/inet.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include <gtest/gtest.h>
#include <yaml-cpp/yaml.h>

#include "springbok/safety/supervisor.hpp"

namespace {

std::string replaced(std::string text, const std::string& from, const std::string& to) {
  const auto at = text.find(from);
  EXPECT_NE(at, std::string::npos) << from;
  if (at != std::string::npos) text.replace(at, from.size(), to);
  return text;
}

class TelemetryStream : public ::testing::TestWithParam<int> {};

TEST_P(TelemetryStream, TheDeployedProgramStreamsPlotJugglerJsonAtTheConfiguredRate) {
  const int rate_hz = GetParam();
  const double period_s = 1.0 / rate_hz;
  // A UDP socket on 127.0.0.1 with an ephemeral port.
  const int fd = ::socket(AF_INET, SOCK_DGRAM, 0);
  ASSERT_GE(fd, 0);
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  ASSERT_EQ(::bind(fd, reinterpret_cast<sockaddr*>(&a), sizeof a), 0);
  socklen_t len = sizeof a;
  ASSERT_EQ(::getsockname(fd, reinterpret_cast<sockaddr*>(&a), &len), 0);
  const int port = ntohs(a.sin_port);

  const std::filesystem::path dir = std::filesystem::temp_directory_path() /
                                    ("springbok_telemetry_" + std::to_string(::getpid()) + "_" + std::to_string(rate_hz));
  std::filesystem::create_directories(dir);
  std::stringstream shipped;
  shipped << std::ifstream(SPRINGBOK_APP_CONFIG).rdbuf();
  std::string cfg = replaced(shipped.str(), "socket: /run/springbok/operator.sock", "socket: " + (dir / "op.sock").string());
  cfg = replaced(cfg, "path: /var/log/springbok/rt.log", "path: \"-\"");
  cfg = replaced(cfg, "port: 9870 ", "port: " + std::to_string(port) + " ");
  cfg = replaced(cfg, "  rate_hz: 100 ", "  rate_hz: " + std::to_string(rate_hz) + " ");
  cfg = replaced(cfg, "  dir: /var/log/springbok ", "  dir: " + (dir / "flight").string() + " ");
  std::ofstream(dir / "robot.yaml") << cfg;

  std::atomic<bool> done{false};
  std::string output;
  std::thread program([&] {
    const std::string cmd = std::string("\"") + SPRINGBOK_ON_SIM + "\" --config \"" + (dir / "robot.yaml").string() +
                            "\" --duration 2 2>&1";
    if (std::FILE* p = ::popen(cmd.c_str(), "r")) {
      char buf[4096];
      while (std::fgets(buf, sizeof buf, p) != nullptr) output += buf;
      ::pclose(p);
    }
    done = true;
  });
  std::vector<std::string> datagrams;
  char buf[65536];
  while (true) {
    pollfd p{fd, POLLIN, 0};
    if (::poll(&p, 1, 200) == 1) {
      const ssize_t n = ::recv(fd, buf, sizeof buf, 0);
      if (n > 0) datagrams.emplace_back(buf, static_cast<std::size_t>(n));
    } else if (done) {
      break;
    }
  }
  program.join();
  ::close(fd);
  // The flight recorder's file at the stop: every tick of the run (the warm-up's included),
  // one row each, a tick apart, the same fields as the datagrams.
  std::vector<std::string> flight_rows;
  std::string flight_header;
  for (const auto& e : std::filesystem::directory_iterator(dir / "flight")) {
    if (e.path().string().find("-stop.csv") == std::string::npos) continue;
    std::ifstream in(e.path());
    std::getline(in, flight_header);
    for (std::string line; std::getline(in, line);) flight_rows.push_back(line);
  }
  std::filesystem::remove_all(dir);
  EXPECT_NE(output.find("flight recorder (stop): "), std::string::npos) << output;
  ASSERT_GE(flight_rows.size(), 1800u) << output;  // 2 s of ticks, fewer where a loaded machine skipped some
  EXPECT_LE(flight_rows.size(), 2600u);
  EXPECT_EQ(flight_header.rfind("timestamp,tick,mode,faults,", 0), 0u) << flight_header;
  for (std::size_t i = 1; i < flight_rows.size(); ++i) {
    const double t0 = std::stod(flight_rows[i - 1]), t1 = std::stod(flight_rows[i]);
    ASSERT_NEAR(t1 - t0, 1e-3 * std::round((t1 - t0) / 1e-3), 1e-9) << "row " << i;
    ASSERT_GE(t1 - t0, 1e-3 - 1e-9) << "row " << i;  // a grid point apart (more after a skipped one)
  }

  // 2 s of firmware time (the warm-up's ticks stream too). At 1 kHz a loaded machine may lose a
  // few on the loopback (the receiver's buffer); the program itself must drop none (below).
  const auto expected = static_cast<std::size_t>(2 * rate_hz);
  ASSERT_GE(datagrams.size(), expected * 9 / 10) << output;
  EXPECT_LE(datagrams.size(), expected * 11 / 10) << output;
  std::vector<double> stamps;
  for (const std::string& d : datagrams) {
    const YAML::Node n = YAML::Load(d);
    ASSERT_TRUE(n.IsMap()) << d;
    stamps.push_back(n["timestamp"].as<double>());
  }
  // The stamps are the ticks' grid times: a period apart (a multiple of it after a skipped tick
  // or a datagram lost on the loopback).
  std::vector<double> gaps;
  for (std::size_t i = 1; i < stamps.size(); ++i) {
    const double gap = stamps[i] - stamps[i - 1];
    EXPECT_NEAR(gap / period_s, std::round(gap / period_s), 1e-3) << i;
    EXPECT_GE(std::round(gap / period_s), 1.0) << i;
    gaps.push_back(gap);
  }
  std::nth_element(gaps.begin(), gaps.begin() + static_cast<long>(gaps.size() / 2), gaps.end());
  EXPECT_NEAR(gaps[gaps.size() / 2], period_s, 1e-6);
  std::printf("telemetry at %d Hz: %zu datagrams received in 2 s of firmware time\n", rate_hz, datagrams.size());
  // The fields: mode, faults, the base estimate, the hand, the template, F_e, foot forces,
  // joints, the QP, the tick's time.
  const YAML::Node last = YAML::Load(datagrams.back());
  for (const char* key : {"mode", "faults", "compute_us", "wake_latency_us", "wbc", "engaged", "qp_status",
                          "qp_iterations", "arm_overloaded", "support_limited", "stepping_for_push", "base_x_m", "base_qw", "base_roll_rad", "base_velocity_x_m_s",
                          "base_rate_z_rad_s", "hand_x_m", "base_rest_x_m", "hand_rest_z_m", "base_displacement_x_m",
                          "hand_displacement_y_m", "hand_qw", "hand_rest_qx", "fe_x_n", "te_z_nm", "unmeasured_y_n", "lf_force_z_n", "rh_stance", "q_lf_haa_joint_rad",
                          "qd_arm_joint_7_rad_s", "tau_rh_kfe_joint_nm"}) {
    EXPECT_TRUE(last[key].IsDefined()) << key << " in " << datagrams.back();
  }
  // Nobody started it: idle. Only a machine too loaded to run the 1 kHz loop may have it in
  // damping instead, and then for overruns alone (the deployed loop is real time; CI's
  // shared cores may miss its deadlines): anything else fails.
  namespace fault = springbok::safety::fault;
  const auto mode = static_cast<springbok::safety::Mode>(last["mode"].as<int>());
  const auto faults = last["faults"].as<springbok::safety::FaultMask>();
  const springbok::safety::FaultMask overruns = fault::kOverrunStreak | fault::kOverrunRate;
  if (mode == springbok::safety::Mode::damping && faults != 0 && (faults & ~overruns) == 0) {
    std::printf("note: the loop overran its deadlines on this loaded machine (faults %u): damping, as it must\n", faults);
  } else {
    EXPECT_EQ(mode, springbok::safety::Mode::idle) << "faults " << faults << "\n" << output;
  }
  EXPECT_EQ(last["wbc"].as<int>(), 1);  // the shipped control mode
  EXPECT_NE(output.find("telemetry to 127.0.0.1:" + std::to_string(port)), std::string::npos) << output;
  EXPECT_NE(output.find("dropped=0 send_errors=0"), std::string::npos) << output;
}

INSTANTIATE_TEST_SUITE_P(Rates, TelemetryStream, ::testing::Values(100, 1000),
                         [](const ::testing::TestParamInfo<int>& info) { return std::to_string(info.param) + "Hz"; });

}  // namespace
