// Live telemetry: the `telemetry:` section's checks, a record as one flat JSON object
// (read back with a JSON parser: yaml-cpp reads JSON), the sender on loopback (one
// datagram per record, in order), and the loop on the stepped clock: a record every
// N ticks, timestamps exactly N ms apart, no allocation in the tick, drops counted
// when nobody drains the ring.
#include <arpa/inet.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <yaml-cpp/yaml.h>

#include "alloc_trap.hpp"
#include "loop_fixture.hpp"
#include "springbok/app/config.hpp"
#include "springbok/app/telemetry.hpp"
#include "springbok/yaml/reader.hpp"

namespace springbok::app {
namespace {

TelemetryConfig read(const std::string& yaml, std::vector<std::string>* errors = nullptr) {
  yaml::Errors e;
  const YAML::Node node = YAML::Load(yaml);
  const TelemetryConfig c = read_telemetry_config(yaml::Field(node["telemetry"], "telemetry", e));
  if (errors != nullptr) *errors = e.lines();
  return c;
}

TEST(Telemetry, TheSectionIsOptionalAndItsErrorsNameTheKey) {
  const TelemetryConfig d = read("other: 1\n");
  EXPECT_TRUE(d.enabled);
  EXPECT_EQ(d.rate_hz, 100.0);
  EXPECT_EQ(d.address, "127.0.0.1");
  EXPECT_EQ(d.port, 9870);
  const TelemetryConfig c = read("telemetry: {rate_hz: 250, address: 10.0.0.7, port: 9000, enabled: false}\n");
  EXPECT_FALSE(c.enabled);
  EXPECT_EQ(c.rate_hz, 250.0);
  EXPECT_EQ(c.address, "10.0.0.7");
  EXPECT_EQ(c.port, 9000);
  std::vector<std::string> errors;
  (void)read("telemetry: {rate_hz: 2000}\n", &errors);
  ASSERT_EQ(errors.size(), 1u);
  EXPECT_NE(errors[0].find("telemetry.rate_hz: must be in [1, 1000], got 2000"), std::string::npos) << errors[0];
  (void)read("telemetry: {address: plotter.local}\n", &errors);
  ASSERT_EQ(errors.size(), 1u);
  EXPECT_NE(errors[0].find("telemetry.address: must be an IPv4 address"), std::string::npos) << errors[0];
  (void)read("telemetry: {port: 0}\n", &errors);
  ASSERT_EQ(errors.size(), 1u);
  EXPECT_NE(errors[0].find("telemetry.port"), std::string::npos) << errors[0];
  (void)read("telemetry: {rate: 5}\n", &errors);
  ASSERT_EQ(errors.size(), 1u);
  EXPECT_NE(errors[0].find("telemetry.rate: unknown key"), std::string::npos) << errors[0];
  // The loop's ticks between two records.
  TelemetryConfig r;
  r.rate_hz = 100.0;
  EXPECT_EQ(telemetry_every_ticks(r, 1000), 10u);
  r.rate_hz = 1000.0;
  EXPECT_EQ(telemetry_every_ticks(r, 1000), 1u);
  r.rate_hz = 300.0;
  EXPECT_EQ(telemetry_every_ticks(r, 1000), 3u);  // 333 Hz: the nearest whole number of ticks
}

TEST(Telemetry, ARecordIsOneFlatJsonObjectWithUnitsInItsNames) {
  TelemetryRecord r;
  r.timestamp_s = 12.345;
  r.tick = 12345;
  r.mode = 4;
  r.faults = 16;
  r.compute_us = 7.5;
  r.wbc = true;
  r.engaged = true;
  r.qp_iterations = 9;
  r.base_position_m = {0.1, -0.2, 0.63};
  r.hand_displacement_m = {0.05, 0.0, std::numeric_limits<double>::quiet_NaN()};
  r.external_force_n = {30.0, 0.0, -1.5};
  r.foot_force_n[2] = {1.0, 2.0, 345.5};
  r.stance = {true, false, true, false};
  r.q_rad[kFirstArmJoint + 3] = 1.9;
  r.tau_nm[1] = -42.25;
  r.bus_voltage_v[4] = 23.5;  // a drive that reports its supply (CAN.md 1.4); the others do not
  const std::string json = telemetry_json(r);
  const YAML::Node n = YAML::Load(json);  // JSON is YAML
  ASSERT_TRUE(n.IsMap()) << json;
  EXPECT_DOUBLE_EQ(n["timestamp"].as<double>(), 12.345);
  EXPECT_EQ(n["tick"].as<double>(), 12345.0);
  EXPECT_EQ(n["mode"].as<int>(), 4);
  EXPECT_EQ(n["faults"].as<int>(), 16);
  EXPECT_EQ(n["compute_us"].as<double>(), 7.5);
  EXPECT_EQ(n["qp_iterations"].as<int>(), 9);
  EXPECT_EQ(n["base_z_m"].as<double>(), 0.63);
  EXPECT_EQ(n["hand_displacement_x_m"].as<double>(), 0.05);
  EXPECT_FALSE(n["hand_displacement_z_m"].IsDefined()) << "JSON has no NaN: the field is left out";
  EXPECT_EQ(n["fe_x_n"].as<double>(), 30.0);
  EXPECT_EQ(n["lh_force_z_n"].as<double>(), 345.5);
  EXPECT_EQ(n["rf_stance"].as<int>(), 0);
  EXPECT_EQ(n["q_arm_joint_4_rad"].as<double>(), 1.9);
  EXPECT_EQ(n["tau_lf_hfe_joint_nm"].as<double>(), -42.25);
  EXPECT_EQ(n["bus_voltage_rf_hfe_joint_v"].as<double>(), 23.5);
  EXPECT_FALSE(n["bus_voltage_lf_hfe_joint_v"].IsDefined()) << "not reported: left out";
  for (const auto& kv : n) {  // flat: every value a number
    EXPECT_TRUE(kv.second.IsScalar()) << kv.first.as<std::string>();
    EXPECT_NO_THROW((void)kv.second.as<double>()) << kv.first.as<std::string>();
  }
  EXPECT_LT(json.size(), 8000u);  // one datagram, well under the UDP limit
}

// The timestamp beyond what fixed notation fits in its buffer (the fuzzer's find: 1e300 s came
// out as 32 bytes of garbage) is written in general notation; a non-finite one drops the datagram.
TEST(Telemetry, AnyTimestampIsANumberOrTheDatagramIsDropped) {
  TelemetryRecord r;
  r.timestamp_s = 1e300;
  EXPECT_EQ(YAML::Load(telemetry_json(r))["timestamp"].as<double>(), 1e300);
  r.timestamp_s = -123456789012345.5;
  EXPECT_EQ(YAML::Load(telemetry_json(r))["timestamp"].as<double>(), -123456789012345.5);
  r.timestamp_s = std::numeric_limits<double>::quiet_NaN();
  EXPECT_EQ(telemetry_json(r), "");
  r.timestamp_s = -std::numeric_limits<double>::infinity();
  EXPECT_EQ(telemetry_json(r), "");
}

// A UDP socket on 127.0.0.1 with an ephemeral port, for the sender to send to.
struct Listener {
  int fd = ::socket(AF_INET, SOCK_DGRAM, 0);
  int port = 0;
  Listener() {
    sockaddr_in a{};
    a.sin_family = AF_INET;
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    EXPECT_EQ(::bind(fd, reinterpret_cast<sockaddr*>(&a), sizeof a), 0);
    socklen_t len = sizeof a;
    EXPECT_EQ(::getsockname(fd, reinterpret_cast<sockaddr*>(&a), &len), 0);
    port = ntohs(a.sin_port);
  }
  ~Listener() { ::close(fd); }
  // The next datagram within timeout_ms, "" when none.
  std::string receive(int timeout_ms = 2000) const {
    pollfd p{fd, POLLIN, 0};
    if (::poll(&p, 1, timeout_ms) != 1) return "";
    char buf[65536];
    const ssize_t n = ::recv(fd, buf, sizeof buf, 0);
    return n > 0 ? std::string(buf, static_cast<std::size_t>(n)) : "";
  }
};

TEST(Telemetry, TheSenderSendsOneDatagramPerRecordInOrder) {
  Listener listener;
  TelemetryConfig c;
  c.port = listener.port;
  TelemetrySender sender;
  ASSERT_EQ(sender.open(c), "");
  auto ring = std::make_unique<TelemetryRing>();
  for (int i = 0; i < 40; ++i) {
    TelemetryRecord r;
    r.tick = static_cast<std::uint64_t>(i);
    r.timestamp_s = 0.01 * i;
    ASSERT_TRUE(ring->push(r));
  }
  sender.start(*ring);
  for (int i = 0; i < 40; ++i) {
    const std::string d = listener.receive();
    ASSERT_FALSE(d.empty()) << "datagram " << i;
    const YAML::Node n = YAML::Load(d);
    EXPECT_EQ(n["tick"].as<int>(), i);
    EXPECT_NEAR(n["timestamp"].as<double>(), 0.01 * i, 1e-9);
  }
  sender.stop();
  EXPECT_EQ(sender.sent(), 40u);
  EXPECT_EQ(sender.send_errors(), 0u);
  TelemetryConfig bad;
  bad.address = "localhost";
  TelemetrySender refused;
  EXPECT_NE(refused.open(bad).find("telemetry.address"), std::string::npos);
}

TEST(Telemetry, TheLoopRecordsEveryNthTickWithoutAllocatingAndCountsDrops) {
  rt::SteppedClock clock{0};
  test::KinematicTestHardware hw(clock);
  auto rig = std::make_unique<test::LoopRig<test::KinematicTestHardware>>(clock, hw);
  auto ring = std::make_unique<TelemetryRing>();
  rig->loop.set_telemetry(ring.get(), 10);  // 100 Hz at 1 kHz
  rig->executive->run_ticks(5);
  TelemetryRecord r;
  while (ring->pop(r)) {
  }
  {
    springbok::test::AllocationTrap trap;
    rig->executive->run_ticks(1000);
    EXPECT_EQ(trap.disarm(), 0u);
  }
  std::vector<TelemetryRecord> got;
  while (ring->pop(r)) got.push_back(r);
  ASSERT_EQ(got.size(), 100u);
  for (std::size_t i = 1; i < got.size(); ++i) {
    EXPECT_EQ(got[i].tick - got[i - 1].tick, 10u);
    EXPECT_NEAR(got[i].timestamp_s - got[i - 1].timestamp_s, 0.010, 1e-12);
  }
  EXPECT_EQ(got.back().mode, static_cast<std::uint8_t>(rig->supervisor.mode()));
  EXPECT_EQ(got.back().q_rad[2], hw.state().q_rad[2]);  // the measured joints
  EXPECT_FALSE(got.back().wbc);                         // the joint PD has no controller fields
  // Nobody drains: the ring fills, the tick goes on, the rest is counted as dropped.
  rig->executive->run_ticks(10 * (TelemetryRing::capacity() + 50));
  EXPECT_EQ(ring->dropped(), 50u);
}

}  // namespace
}  // namespace springbok::app
