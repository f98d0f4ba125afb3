// springbok-view: see the robot. Three uses:
//   springbok-view RUN [--out PAGE.html]         the 3D replay page of a run (RUN: a springbok-sim
//                                                output folder, or a flight-recorder file); opened
//                                                from a file:// URL, no server
//   springbok-view --screenshot OUT.png --at SECONDS RUN    a PNG of the run at a time (headless chromium)
//   springbok-view --config springbok.yaml [--port 8090]    live: serves the page and relays the
//                                                firmware's telemetry to it (WebSocket)
#include <fmt/format.h>

#include <CLI/CLI.hpp>
#include <atomic>
#include <csignal>
#include <cstdio>
#include <optional>

#include "browser.hpp"
#include "live_server.hpp"
#include "springbok/app/config.hpp"
#include "view_page.hpp"

namespace {

std::atomic<bool> g_stop{false};
void on_signal(int) { g_stop.store(true); }

}  // namespace

int main(int argc, char** argv) {
  using namespace springbok;
  CLI::App app{"springbok-view: the robot in 3D in a browser, replayed from a run or live from the firmware"};
  std::string run, out, screenshot_png, config, browser, address = "127.0.0.1", size = "1280x720";
  std::optional<double> at_s;
  double rate_hz = 100.0;
  int port = 8090;
  app.add_option("run", run, "a springbok-sim output folder (log.csv) or a flight-recorder file (flight-*.csv)");
  app.add_option("--out", out, "the page to write (default: RUN/view.html, or FILE.html beside a file)");
  app.add_option("--rate-hz", rate_hz, "samples per second of the run kept in the page (default 100)")
      ->check(CLI::Range(0.1, 1000.0));
  app.add_option("--screenshot", screenshot_png, "write a PNG of the run at --at SECONDS (headless chromium)");
  app.add_option("--at", at_s, "the run's time for --screenshot [s from its start]")->check(CLI::Range(0.0, 1e6));
  app.add_option("--size", size, "the screenshot's WIDTHxHEIGHT in pixels (default 1280x720)");
  app.add_option("--browser", browser, "the browser (default: $SPRINGBOK_BROWSER, else chromium on PATH)");
  app.add_option("--config", config, "live: the firmware's springbok.yaml (its telemetry: address and port)");
  app.add_option("--address", address, "live: the address the page is served on (default 127.0.0.1)");
  app.add_option("--port", port, "live: the page's TCP port (default 8090; 0: any free one)")->check(CLI::Range(0, 65535));
  CLI11_PARSE(app, argc, argv);

  try {
    if (!config.empty()) {
      if (!run.empty() || !screenshot_png.empty()) throw view::Error("--config (live) takes no RUN and no --screenshot");
      const app::ConfigResult loaded = app::load_config_file(config);
      if (!loaded.ok) {
        for (const auto& e : loaded.errors) std::fprintf(stderr, "%s: %s\n", config.c_str(), e.c_str());
        return 2;
      }
      const app::TelemetryConfig& t = loaded.config.telemetry;
      if (!t.enabled) throw view::Error(config + ": telemetry.enabled is false: the firmware sends nothing to show");
      // The datagrams arrive on the telemetry port; on this machine's address if the config
      // sends them to one of its own, else on any of its addresses.
      view::LiveServer server({address, port, t.address == "127.0.0.1" ? "127.0.0.1" : "0.0.0.0", t.port});
      std::signal(SIGINT, on_signal);
      std::signal(SIGTERM, on_signal);
      std::printf("springbok-view: http://%s:%d/ (telemetry from UDP port %d)\n", address.c_str(), server.http_port(),
                  t.port);
      std::fflush(stdout);
      server.serve(g_stop);
      const auto c = server.counts();
      std::printf("springbok-view: %lld records received, %lld sent to pages, %lld missed by slow pages\n", c.datagrams,
                  c.frames_sent, c.dropped);
      return 0;
    }
    if (run.empty()) throw view::Error("give a RUN (a springbok-sim output folder or a flight-recorder file), or --config");
    const view::Run loaded = view::load_run(run, rate_hz);
    const std::string page = view::page_html("window.SPRINGBOK_RUN = " + view::run_json(loaded) + ";");
    if (!screenshot_png.empty()) {
      if (!at_s) throw view::Error("--screenshot needs --at SECONDS");
      view::BrowserRun b;
      b.browser = view::find_browser(browser);
      if (std::sscanf(size.c_str(), "%dx%d", &b.width_px, &b.height_px) != 2 || b.width_px < 64 || b.height_px < 64 ||
          b.width_px > 7680 || b.height_px > 4320) {
        throw view::Error("--size " + size + ": WIDTHxHEIGHT, 64..7680 by 64..4320");
      }
      const double duration = loaded.time_s.back() - loaded.time_s.front();
      if (*at_s > duration + 1e-9) throw view::Error(fmt::format("--at {}: the run lasts {:.3f} s", *at_s, duration));
      // The page goes to a temporary file unless --out names one.
      const std::filesystem::path page_path =
          out.empty() ? std::filesystem::path(screenshot_png).replace_extension(".view.html") : std::filesystem::path(out);
      view::write_file(page_path, page);
      view::screenshot(b, page_path, fmt::format("t={}", *at_s), screenshot_png);
      if (out.empty()) std::filesystem::remove(page_path);
      std::printf("springbok-view: wrote %s (%s at %.3f s)\n", screenshot_png.c_str(), loaded.title.c_str(), *at_s);
      return 0;
    }
    const std::filesystem::path page_path = out.empty() ? view::default_page_path(run) : std::filesystem::path(out);
    view::write_file(page_path, page);
    std::printf("springbok-view: wrote %s (%zu frames, %.3f s, %.1f MB)\n", page_path.c_str(), loaded.time_s.size(),
                loaded.time_s.back() - loaded.time_s.front(), static_cast<double>(page.size()) / 1e6);
    return 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "springbok-view: %s\n", e.what());
    return 1;
  }
}
