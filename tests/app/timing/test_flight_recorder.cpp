// The flight recorder: the ring keeps the last ticks oldest first; a file is asked for in the
// tick a fault latches and holds the ticks up to it; a write while the RT side records leaves
// out what it overwrote and never tears a row; the operator's `dump`; the config's checks.
#include <gtest/gtest.h>
#include <unistd.h>

#include <atomic>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "loop_fixture.hpp"
#include "springbok/app/flight_recorder.hpp"
#include "springbok/app/operator_server.hpp"
#include "springbok/yaml/reader.hpp"

namespace springbok::app::test {
namespace {

struct TempDir {
  std::filesystem::path path;
  TempDir() : path(std::filesystem::temp_directory_path() / ("springbok_flight_" + std::to_string(::getpid()))) {
    std::filesystem::remove_all(path);
  }
  ~TempDir() { std::filesystem::remove_all(path); }
};

struct Csv {
  std::vector<std::string> header;
  std::vector<std::vector<double>> rows;
  int column(const std::string& name) const {
    for (std::size_t i = 0; i < header.size(); ++i) {
      if (header[i] == name) return static_cast<int>(i);
    }
    ADD_FAILURE() << "no column " << name;
    return 0;
  }
};

std::vector<std::string> split(const std::string& line) {
  std::vector<std::string> out;
  std::stringstream ss(line);
  for (std::string cell; std::getline(ss, cell, ',');) out.push_back(cell);
  return out;
}

Csv read_csv(const std::string& path) {
  Csv csv;
  std::ifstream in(path);
  std::string line;
  EXPECT_TRUE(std::getline(in, line)) << path;
  csv.header = split(line);
  while (std::getline(in, line)) {
    std::vector<double> row;
    for (const std::string& cell : split(line)) row.push_back(std::stod(cell));
    EXPECT_EQ(row.size(), csv.header.size()) << "row " << csv.rows.size();
    csv.rows.push_back(std::move(row));
  }
  return csv;
}

TelemetryRecord record_of_tick(std::uint64_t k) {
  TelemetryRecord r;
  r.tick = k;
  r.timestamp_s = static_cast<double>(k) * 1e-3;
  for (auto& q : r.q_rad) q = static_cast<double>(k);
  for (auto& tau : r.tau_nm) tau = -static_cast<double>(k);
  return r;
}

TEST(FlightRecorder, TheRingKeepsTheLastTicksOldestFirst) {
  TempDir dir;
  FlightRecorder recorder(100, dir.path.string());
  for (std::uint64_t k = 0; k < 250; ++k) recorder.record(record_of_tick(k));
  std::string error;
  const std::string path = recorder.write(DumpReason::operator_request, error);
  ASSERT_FALSE(path.empty()) << error;
  EXPECT_NE(path.find("-operator.csv"), std::string::npos) << path;
  const Csv csv = read_csv(path);
  EXPECT_EQ(csv.header, split(telemetry_csv_header()));
  ASSERT_EQ(csv.rows.size(), 100u);
  const int tick = csv.column("tick");
  const int q0 = csv.column("q_" + std::string(robot::kJoints[0].name) + "_rad");
  for (std::size_t i = 0; i < csv.rows.size(); ++i) {
    EXPECT_EQ(csv.rows[i][static_cast<std::size_t>(tick)], 150.0 + static_cast<double>(i));
    EXPECT_EQ(csv.rows[i][static_cast<std::size_t>(q0)], 150.0 + static_cast<double>(i));
    EXPECT_DOUBLE_EQ(csv.rows[i][0], (150.0 + static_cast<double>(i)) * 1e-3);  // timestamp
  }
  EXPECT_EQ(recorder.files(), 1u);
  EXPECT_EQ(recorder.last_file(), path);
}

// The RT side records as fast as it can (far above 1 kHz) while the writer copies: every row
// written is one tick's whole record (its q and tau agree with its tick), the rows are
// consecutive ticks in order, and the file is never empty (the copy starts at the newest tick).
TEST(FlightRecorder, AWriteWhileTicksAreRecordedNeverTearsARow) {
  TempDir dir;
  FlightRecorder recorder(512, dir.path.string());
  std::atomic<bool> done{false};
  std::thread rt([&] {
    for (std::uint64_t k = 0; !done.load(std::memory_order_relaxed); ++k) recorder.record(record_of_tick(k));
  });
  while (recorder.recorded() < 2000) std::this_thread::yield();
  std::vector<std::string> paths;
  for (int i = 0; i < 5; ++i) {
    std::string error;
    paths.push_back(recorder.write(DumpReason::operator_request, error));
    ASSERT_FALSE(paths.back().empty()) << error;
  }
  done = true;
  rt.join();
  for (const std::string& path : paths) {
    const Csv csv = read_csv(path);
    ASSERT_GT(csv.rows.size(), 0u) << path;
    EXPECT_LE(csv.rows.size(), 512u);
    const auto tick = static_cast<std::size_t>(csv.column("tick"));
    const auto q = static_cast<std::size_t>(csv.column("q_" + std::string(robot::kJoints[kNj - 1].name) + "_rad"));
    const auto tau = static_cast<std::size_t>(csv.column("tau_" + std::string(robot::kJoints[0].name) + "_nm"));
    for (std::size_t i = 0; i < csv.rows.size(); ++i) {
      const std::vector<double>& row = csv.rows[i];
      EXPECT_EQ(row[q], row[tick]) << path << " row " << i;
      EXPECT_EQ(row[tau], -row[tick]) << path << " row " << i;
      if (i > 0) {
        EXPECT_EQ(row[tick], csv.rows[i - 1][tick] + 1.0) << path << " row " << i;  // contiguous
      }
    }
  }
}

// The loop records every tick; the tick a fault latches asks for a file, which holds the
// ticks up to the fault and the fault itself.
TEST(FlightRecorder, AFaultAsksForAFileHoldingTheTicksUpToIt) {
  TempDir dir;
  rt::SteppedClock clock{0};
  KinematicTestHardware hardware{clock};
  LoopRig<KinematicTestHardware> rig(clock, hardware);
  FlightRecorder recorder(2000, dir.path.string());
  rig.loop.set_recorder(&recorder);
  rig.executive->run_ticks(5);
  ASSERT_EQ(rig.command(safety::OperatorCommand::start), safety::Verdict::accepted);
  rig.executive->run_ticks(300);
  EXPECT_EQ(recorder.pending(), DumpReason::none);
  hardware.silent = true;
  std::uint64_t fault_tick = 0;
  for (int i = 0; i < 100 && rig.supervisor.faults() == 0; ++i) {
    rig.executive->run_ticks(1);
    fault_tick = recorder.recorded() - 1;
  }
  ASSERT_EQ(rig.supervisor.faults(), safety::fault::kHalWatchdog);
  EXPECT_EQ(recorder.pending(), DumpReason::fault);
  rig.executive->run_ticks(10);  // what happens after it, until the writer looks
  std::string error;
  const std::string path = recorder.write(recorder.pending(), error);
  ASSERT_FALSE(path.empty()) << error;
  EXPECT_NE(path.find("-fault.csv"), std::string::npos);
  const Csv csv = read_csv(path);
  ASSERT_EQ(csv.rows.size(), recorder.recorded());  // every tick so far: fewer than the ring holds
  const auto faults = static_cast<std::size_t>(csv.column("faults"));
  const auto mode = static_cast<std::size_t>(csv.column("mode"));
  const auto tick = static_cast<std::size_t>(csv.column("tick"));
  for (std::size_t i = 0; i < csv.rows.size(); ++i) {
    const bool after = i >= fault_tick;
    EXPECT_EQ(csv.rows[i][faults] != 0.0, after) << "row " << i;
    EXPECT_EQ(csv.rows[i][mode] == static_cast<double>(safety::Mode::damping), after) << "row " << i;
    if (i > 0) {
      EXPECT_EQ(csv.rows[i][tick], csv.rows[i - 1][tick] + 1.0) << "row " << i;
    }
  }
}

TEST(FlightRecorder, TheOperatorsDumpWritesAFileAndNamesIt) {
  TempDir dir;
  OperatorMailbox mailbox;
  LoopStatus status;
  rt::PublishedStats stats;
  OperatorServer server(mailbox, status, stats);
  EXPECT_EQ(server.handle_line("dump"), "error: dump: the flight recorder is off (recorder.enabled)");
  FlightRecorder recorder(10, dir.path.string());
  for (std::uint64_t k = 0; k < 3; ++k) recorder.record(record_of_tick(k));
  server.set_recorder(&recorder);
  const std::string reply = server.handle_line("dump");
  ASSERT_EQ(reply.rfind("ok dump ", 0), 0u) << reply;
  EXPECT_EQ(read_csv(reply.substr(8)).rows.size(), 3u);
  EXPECT_EQ(server.handle_line("dump now"), "error: dump takes no argument");
}

TEST(FlightRecorder, TheConfigSectionIsChecked) {
  const auto errors_of = [](const std::string& text) {
    const yaml::Document doc = yaml::parse_text(text);
    EXPECT_TRUE(doc.ok) << doc.error;
    yaml::Errors errors;
    const RecorderConfig c = read_recorder_config(yaml::Field(doc.root, "", errors)["recorder"]);
    (void)c;
    return errors.joined();
  };
  EXPECT_EQ(errors_of("recorder: {seconds: 10, dir: /tmp/x, enabled: false}\n"), "");
  EXPECT_NE(errors_of("recorder: {seconds: 0}\n").find("recorder.seconds"), std::string::npos);
  EXPECT_NE(errors_of("recorder: {seconds: .nan}\n").find("recorder.seconds"), std::string::npos);
  EXPECT_NE(errors_of("recorder: {minutes: 1}\n").find("minutes"), std::string::npos);
  EXPECT_NE(errors_of("recorder: {dir: \"\"}\n").find("recorder.dir"), std::string::npos);
  const yaml::Document doc = yaml::parse_text("other: 1\n");
  yaml::Errors errors;
  const RecorderConfig absent = read_recorder_config(yaml::Field(doc.root, "", errors)["recorder"]);
  EXPECT_TRUE(absent.enabled);
  EXPECT_EQ(absent.seconds, 30.0);
}

}  // namespace
}  // namespace springbok::app::test
