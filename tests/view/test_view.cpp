// springbok-view: the replay page of a springbok-sim run loaded in a real browser (headless
// Chromium), seeked, and the joint angles and base position it shows read back from its scene
// and compared with log.csv; a screenshot kept as the test's artefact; a flight-recorder file
// replayed; the live page in the browser drawing the record the relay sent it; refusals of bad
// input. (The relay without a browser: test_view_live.cpp.)
#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <regex>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include <gtest/gtest.h>

#include "browser.hpp"
#include "live_server.hpp"
#include "run_command.hpp"
#include "springbok/app/telemetry.hpp"
#include "springbok/model/model.hpp"
#include "view_page.hpp"

namespace {
using namespace springbok;
namespace fs = std::filesystem;

const fs::path kOut = fs::path(SPRINGBOK_BIN_DIR).parent_path() / "artefacts" / "view";

// A log.csv as rows of named columns (the first column of a repeated name, as springbok-sim's
// simulator columns come first).
struct Log {
  std::vector<std::string> names;
  std::vector<std::vector<std::string>> rows;
  int column(const std::string& name) const {
    for (std::size_t i = 0; i < names.size(); ++i) {
      if (names[i] == name) return static_cast<int>(i);
    }
    ADD_FAILURE() << "no column " << name;
    return 0;
  }
  double at(std::size_t row, const std::string& name) const { return std::stod(rows[row][static_cast<std::size_t>(column(name))]); }
};

std::vector<std::string> split(const std::string& line) {
  std::vector<std::string> cells;
  std::stringstream ss(line);
  for (std::string cell; std::getline(ss, cell, ',');) cells.push_back(cell);
  return cells;
}

Log read_log(const fs::path& path) {
  Log log;
  std::ifstream in(path);
  std::string line;
  std::getline(in, line);
  log.names = split(line);
  while (std::getline(in, line)) log.rows.push_back(split(line));
  return log;
}

// A springbok-sim run of the robot file's own base step (any robot), made once per test: ctest
// runs the cases as processes side by side, so each has its own folder (one reading a log.csv
// another is writing would read it cut short).
const fs::path& sim_run() {
  static const fs::path dir = [] {
    const fs::path d = kOut / ("base_step." + std::string(::testing::UnitTest::GetInstance()->current_test_info()->name()));
    fs::create_directories(kOut);
    const auto r = test::run_program("", "springbok-sim",
                                     std::string(SPRINGBOK_SOURCE_DIR) + "/tools/scenarios/any_robot/base_step.yaml --out " +
                                         d.string());
    EXPECT_EQ(r.exit_code, 0) << r.out;
    return d;
  }();
  return dir;
}

// The numbers after `"key":` in the page's readback (a flat JSON object but for `base`, `joints`).
double number_after(const std::string& text, const std::string& key) {
  const std::size_t at = text.find("\"" + key + "\":");
  if (at == std::string::npos) {
    ADD_FAILURE() << "no " << key << " in " << text.substr(0, 300);
    return NAN;
  }
  return std::stod(text.substr(at + key.size() + 3));
}

std::string readback_of(const std::string& dom) {
  const std::size_t start = dom.find("<pre id=\"readback\">");
  const std::size_t end = dom.find("</pre>", start);
  if (start == std::string::npos || end == std::string::npos) return {};
  return dom.substr(start + 19, end - start - 19);
}

TEST(ViewInBrowser, ShowsTheLoggedJointAnglesAtTheSeekedTime) {
  const fs::path& run = sim_run();
  const auto page = test::run_program("", "springbok-view", run.string());
  ASSERT_EQ(page.exit_code, 0) << page.out;
  ASSERT_TRUE(fs::is_regular_file(run / "view.html"));
  const Log log = read_log(run / "log.csv");
  ASSERT_GT(log.rows.size(), 1000u);
  view::BrowserRun b;
  b.browser = view::find_browser("");
  // Before the push, in it, and at the last sample.
  for (const double seek_s : {0.5, 1.37, 7.999}) {
    const std::string readback = readback_of(view::dump_dom(b, run / "view.html", "t=" + std::to_string(seek_s)));
    ASSERT_FALSE(readback.empty()) << "the page wrote no readback at t=" << seek_s;
    const double shown_s = number_after(readback, "time_s");
    // The page shows the last sample at or before the time from the run's start (100 a second).
    const double start_s = log.at(0, "time_s");
    EXPECT_LE(shown_s - start_s, seek_s + 1e-6);
    EXPECT_GT(shown_s - start_s, seek_s - 0.0101);
    std::size_t row = 0;
    while (row + 1 < log.rows.size() && std::abs(log.at(row, "time_s") - shown_s) > 5e-7) ++row;
    ASSERT_NEAR(log.at(row, "time_s"), shown_s, 5e-7) << "no log row at the shown time";
    for (const auto& joint : robot::kJoints) {
      const std::string name(joint.name);
      EXPECT_NEAR(number_after(readback, name), log.at(row, "q_" + name), 2e-6) << name << " at " << shown_s << " s";
    }
    const std::size_t base = readback.find("\"base\":[");
    ASSERT_NE(base, std::string::npos);
    std::stringstream xyz(readback.substr(base + 8));
    double p[3];
    char comma;
    xyz >> p[0] >> comma >> p[1] >> comma >> p[2];
    EXPECT_NEAR(p[0], log.at(row, "base_x_m"), 2e-6);
    EXPECT_NEAR(p[1], log.at(row, "base_y_m"), 2e-6);
    EXPECT_NEAR(p[2], log.at(row, "base_z_m"), 2e-6);
  }
}

TEST(ViewInBrowser, WritesAScreenshotOfTheRunAtATime) {
  const fs::path& run = sim_run();
  const fs::path png = kOut / "base_step_at_2s.png";
  const auto r = test::run_program("", "springbok-view", "--screenshot " + png.string() + " --at 2 " + run.string());
  ASSERT_EQ(r.exit_code, 0) << r.out;
  std::ifstream in(png, std::ios::binary);
  char magic[8] = {};
  in.read(magic, 8);
  EXPECT_EQ(std::string(magic + 1, 3), "PNG");
  EXPECT_GT(fs::file_size(png), 20000u) << "a blank page's PNG is a few kB; the robot's scene is more";
  std::printf("artefact: %s\n", png.c_str());
}

TEST(ViewPage, ReplaysAFlightRecorderFile) {
  // A recorder file written with the recorder's own row format, from the run's log.
  const Log log = read_log(sim_run() / "log.csv");
  const fs::path file = kOut / "flight-test-1-dump.csv";
  {
    std::ofstream out(file);
    out << app::telemetry_csv_header() << "\n";
    std::string row;
    for (std::size_t i = 0; i < 3000; ++i) {
      app::TelemetryRecord r;
      r.timestamp_s = 100.0 + log.at(i, "time_s");
      r.base_position_m = {log.at(i, "base_x_m"), log.at(i, "base_y_m"), log.at(i, "base_z_m")};
      for (int j = 0; j < kNj; ++j) {
        r.q_rad[static_cast<std::size_t>(j)] = log.at(i, "q_" + std::string(robot::kJoints[static_cast<std::size_t>(j)].name));
      }
      row.clear();
      app::append_telemetry_csv_row(row, r);
      out << row;
    }
  }
  const view::Run run = view::load_run(file, 100.0);
  EXPECT_EQ(run.source, "flight recorder");
  EXPECT_EQ(run.title, "flight-test-1-dump");
  ASSERT_EQ(run.time_s.size(), 301u);  // 3 s at 100 per second, and the last row
  const std::string knee = "q_" + std::string(robot::kJoints[2].name) + "_rad";
  for (const auto& [name, values] : run.series) {
    if (name != knee) continue;
    for (std::size_t k = 0; k < 300; k += 37) {
      EXPECT_NEAR(values[k], log.at(k * 10, "q_" + std::string(robot::kJoints[2].name)), 1e-6);
    }
  }
  const auto r = test::run_program("", "springbok-view", file.string());
  ASSERT_EQ(r.exit_code, 0) << r.out;
  EXPECT_TRUE(fs::is_regular_file(kOut / "flight-test-1-dump.html"));
}

TEST(ViewPage, RefusesBadRunsNamingTheProblem) {
  fs::create_directories(kOut);
  const auto refused = [](const std::string& text, const std::string& message) {
    const fs::path f = kOut / "bad.csv";
    std::ofstream(f) << text;
    try {
      (void)view::load_run(f, 100.0);
      ADD_FAILURE() << "accepted: " << text;
    } catch (const view::Error& e) {
      EXPECT_NE(std::string(e.what()).find(message), std::string::npos) << e.what();
    }
  };
  refused("", "empty");
  refused("a,b\n1,2\n", "neither a springbok-sim log");
  refused("time_s,base_x_m\n0,1\n", "no column 'base_y_m'");
  std::string header = app::telemetry_csv_header();
  refused(header + "\n1,2\n", "values, the header has");
  const std::size_t width = static_cast<std::size_t>(std::count(header.begin(), header.end(), ',')) + 1;
  std::string row = "1";
  for (std::size_t i = 1; i < width; ++i) row += i == 20 ? ",nan?" : ",0";
  refused(header + "\n" + row + "\n", "is no number");
  EXPECT_THROW((void)view::load_run(kOut / "no-such-run", 100.0), view::Error);
  const auto r = test::run_program("", "springbok-view", (kOut / "no-such-run").string());
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.out.find("cannot read"), std::string::npos) << r.out;
  const auto no_at = test::run_program("", "springbok-view", "--screenshot x.png " + sim_run().string());
  EXPECT_EQ(no_at.exit_code, 1);
  EXPECT_NE(no_at.out.find("--at"), std::string::npos) << no_at.out;
  const auto bad_size = test::run_program("", "springbok-view", "--screenshot x.png --at 1 --size 10x10 " + sim_run().string());
  EXPECT_EQ(bad_size.exit_code, 1);
  EXPECT_NE(bad_size.out.find("--size 10x10"), std::string::npos) << bad_size.out;
}

// ---- live ----------------------------------------------------------------------------------





// The live page in the browser: served by the relay, fed the firmware's records over its
// WebSocket, it draws the newest one; what it shows is read back from its scene.
TEST(ViewInBrowser, TheLivePageShowsTheRelayedRecord) {
  view::LiveServer server({"127.0.0.1", 0, "127.0.0.1", 0});
  std::atomic<bool> stop{false};
  std::thread serving([&] { server.serve(stop); });
  app::TelemetryRecord record;
  record.timestamp_s = 42.5;
  record.base_position_m = {0.25, -0.5, 0.6};
  for (int j = 0; j < kNj; ++j) record.q_rad[static_cast<std::size_t>(j)] = 0.01 * (j + 1) - 0.1;
  const std::string json = app::telemetry_json(record);
  std::thread feeding([&] {  // the firmware: a record every 10 ms
    const int udp = ::socket(AF_INET, SOCK_DGRAM, 0);
    sockaddr_in to{};
    to.sin_family = AF_INET;
    to.sin_port = htons(static_cast<std::uint16_t>(server.telemetry_port()));
    to.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    while (!stop) {
      ::sendto(udp, json.data(), json.size(), 0, reinterpret_cast<const sockaddr*>(&to), sizeof to);
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
    ::close(udp);
  });
  view::BrowserRun b;
  b.browser = view::find_browser("");
  const std::string readback =
      readback_of(view::dump_dom_url(b, "http://127.0.0.1:" + std::to_string(server.http_port()) + "/", 500));
  stop = true;
  feeding.join();
  serving.join();
  ASSERT_FALSE(readback.empty()) << "the live page drew no record; " << server.counts().frames_sent << " sent to it";
  EXPECT_NEAR(number_after(readback, "time_s"), 42.5, 1e-9);
  for (int j = 0; j < kNj; ++j) {
    const std::string name(robot::kJoints[static_cast<std::size_t>(j)].name);
    EXPECT_NEAR(number_after(readback, name), 0.01 * (j + 1) - 0.1, 1e-9) << name;
  }
  EXPECT_GE(server.counts().frames_sent, 1);
}


}  // namespace
