// springbok-teleop: drive the robot with a gamepad through the operator socket (teleop.hpp
// for the mapping, event_source.hpp for the input).
//
//   springbok-teleop --device /dev/input/eventN [--socket PATH] [--rate HZ] [--dead-zone F]
//                    [--speed F] [--event-timeout S] [--record FILE]
//   springbok-teleop --events FILE ...          (a recorded stream instead of a pad)
//
// A pad that is unplugged stops the walk (teleop.hpp) and is opened again once a second until
// it is back; a recorded stream ends the program once its end (an unplug) has been handled.
// Each command's reply is read; a refused one is printed (once per command until it changes),
// and a socket that cannot be reached is retried at the next command. SIGINT/SIGTERM: the
// walk is stopped as on a release, then the program exits.
#include <signal.h>
#include <time.h>

#include <atomic>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include "event_source.hpp"
#include "springbok/app/operator_client.hpp"
#include "teleop.hpp"

namespace {

using namespace springbok;

std::atomic<bool> g_stop{false};
void on_signal(int) { g_stop.store(true); }

double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

// Sends each line and reports what went wrong, each kind of complaint once until it changes.
class Sender {
 public:
  Sender(const std::string& socket, int timeout_ms) : client_(socket), timeout_ms_(timeout_ms) {}
  void send(const std::string& line) {
    std::string reply, error;
    const std::string verb = line.substr(0, line.find(' '));
    std::string& last = last_complaint_[verb];
    if (!client_.exchange(line, timeout_ms_, reply, error)) {
      if (last != error) std::fprintf(stderr, "springbok-teleop: %s: %s\n", line.c_str(), error.c_str());
      last = error;
      return;
    }
    ++sent_;
    if (reply.rfind("ok", 0) != 0) {
      if (last != reply) std::fprintf(stderr, "springbok-teleop: %s: %s\n", line.c_str(), reply.c_str());
      last = reply;
      return;
    }
    if (verb != "walk") std::fprintf(stderr, "springbok-teleop: %s: %s\n", line.c_str(), reply.c_str());
    last.clear();
  }
  unsigned long sent() const noexcept { return sent_; }

 private:
  app::OperatorClient client_;
  int timeout_ms_;
  std::map<std::string, std::string> last_complaint_;
  unsigned long sent_ = 0;
};

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"springbok-teleop: drive the robot with a gamepad through the operator socket"};
  const char* env = std::getenv("SPRINGBOK_OPERATOR_SOCKET");
  std::string socket_path = env != nullptr && *env != '\0' ? env : "/run/springbok/operator.sock";
  std::string device, events, record;
  double rate_hz = 20.0;
  int reply_timeout_ms = 500;
  teleop::TeleopConfig config;
  auto* source_group = app.add_option_group("input", "where the events come from");
  source_group->add_option("--device", device, "the gamepad's evdev device (/dev/input/eventN)");
  source_group->add_option("--events", events, "a recorded event stream instead of a pad (event_source.hpp's format)")
      ->check(CLI::ExistingFile);
  source_group->require_option(1);
  app.add_option("--socket", socket_path,
                 "the operator socket (default: $SPRINGBOK_OPERATOR_SOCKET, else /run/springbok/operator.sock)");
  app.add_option("--rate", rate_hz, "walk commands per second while the dead-man is held")->check(CLI::Range(1.0, 200.0));
  app.add_option("--dead-zone", config.dead_zone, "the sticks' dead zone, a fraction of their half range")
      ->check(CLI::Range(0.0, 0.9));
  app.add_option("--speed", config.speed_fraction, "full stick: this fraction of the trot's velocity limits")
      ->check(CLI::Range(0.05, 1.0));
  app.add_option("--event-timeout", config.event_timeout_s,
                 "no event from the pad for this long stops the walk, as a released dead-man does (s)")
      ->check(CLI::Range(0.05, 10.0));
  app.add_option("--reply-timeout-ms", reply_timeout_ms, "how long to wait for each reply")->check(CLI::Range(10, 10000));
  app.add_option("--record", record, "also write the pad's events to FILE (the --events format)");
  app.footer(
      "Pad (XInput layout): hold LB to walk, left stick: forward/sideways, right stick: turn. START start, "
      "BACK stop, A mode control, B mode stand, Y gait trot, X gait stand. Releasing LB, unplugging the pad "
      "or no event for --event-timeout sends 'walk 0 0 0' and 'gait stand'.");
  CLI11_PARSE(app, argc, argv);
  config.period_s = 1.0 / rate_hz;

  std::string error;
  std::unique_ptr<teleop::EventSource> source =
      events.empty() ? teleop::open_device(device, error) : teleop::open_recording(events, error);
  if (!source) {
    std::fprintf(stderr, "springbok-teleop: %s\n", error.c_str());
    return 2;
  }
  std::ofstream recording;
  if (!record.empty()) {
    recording.open(record);
    if (!recording) {
      std::fprintf(stderr, "springbok-teleop: cannot write %s\n", record.c_str());
      return 2;
    }
    recording << "# springbok-teleop events of " << source->name() << "\n";
    for (const auto& [code, r] : source->axes()) recording << "axis " << teleop::axis_name(code) << ' ' << r.min << ' ' << r.max << "\n";
  }
  signal(SIGINT, on_signal);
  signal(SIGTERM, on_signal);

  teleop::Teleop pad(config);
  for (const auto& [code, r] : source->axes()) pad.set_axis_range(code, r);
  Sender sender(socket_path, reply_timeout_ms);
  std::fprintf(stderr, "springbok-teleop: %s -> %s\n", source->name().c_str(), socket_path.c_str());
  const auto t0 = std::chrono::steady_clock::now();
  std::vector<std::string> lines;
  bool gone = false;
  double reopen_at_s = 0.0;
  for (;;) {
    const double t_s = seconds_since(t0);
    if (g_stop.load()) pad.unplugged(t_s);  // stop the walk as a release would
    teleop::InputEvent ev;
    if (!gone && !g_stop.load()) {
      // The first event within half a period, then every one already there (a report's
      // events, up to its SYN_REPORT, arrive together): the pad's state as one.
      teleop::EventSource::Next next = source->next(config.period_s / 2.0, ev);
      while (next == teleop::EventSource::Next::event) {
        pad.event(seconds_since(t0), ev.type, ev.code, ev.value);
        if (recording.is_open()) recording << teleop::format_event(seconds_since(t0), ev) << "\n";
        next = source->next(0.0, ev);
      }
      switch (next) {
        case teleop::EventSource::Next::event:
        case teleop::EventSource::Next::none:
          break;
        case teleop::EventSource::Next::gone:
          gone = true;
          pad.unplugged(seconds_since(t0));
          if (recording.is_open()) recording << teleop::format_unplug(seconds_since(t0)) << "\n";
          std::fprintf(stderr, "springbok-teleop: %s is gone\n", source->name().c_str());
          reopen_at_s = seconds_since(t0) + 1.0;
          break;
      }
    } else if (!g_stop.load()) {
      if (!events.empty() && !pad.walking()) break;  // the stream ended and its stop was sent
      struct timespec pause{0, static_cast<long>(config.period_s / 2.0 * 1e9)};
      nanosleep(&pause, nullptr);
      if (events.empty() && seconds_since(t0) >= reopen_at_s) {
        std::string why;
        if (std::unique_ptr<teleop::EventSource> again = teleop::open_device(device, why)) {
          source = std::move(again);
          gone = false;
          std::fprintf(stderr, "springbok-teleop: %s is back: press LB to walk again\n", source->name().c_str());
        }
        reopen_at_s = seconds_since(t0) + 1.0;
      }
    }
    lines.clear();
    pad.poll(seconds_since(t0), lines);
    for (const std::string& line : lines) sender.send(line);
    if (g_stop.load() && !pad.walking()) break;
  }
  std::fprintf(stderr, "springbok-teleop: %lu commands answered\n", sender.sent());
  return 0;
}
