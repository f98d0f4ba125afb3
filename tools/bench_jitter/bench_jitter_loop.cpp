// The executive's own wake-up latency: rt::Executive on the monotonic clock
// in an RtThread (SCHED_FIFO, mlockall, prefaulted, cpu_dma_latency), with a
// tick that does nothing, so what is measured is the schedule alone.
#include <CLI/CLI.hpp>

#include <atomic>
#include <cstdio>
#include <memory>

#include "springbok/rt/clock.hpp"
#include "springbok/rt/executive.hpp"
#include "springbok/rt/realtime.hpp"

namespace {

struct EmptyTick {
  void tick(const springbok::rt::TickInfo&) noexcept {}  // rt: no alloc
};

}  // namespace

int main(int argc, char** argv) {
  using namespace springbok;
  double seconds = 10.0;
  int interval_us = 1000;
  rt::RtConfig config;
  CLI::App app{"bench_jitter_loop: wake-up latency of the springbok executive"};
  app.add_option("--seconds", seconds, "run time")->check(CLI::Range(0.1, 86400.0));
  app.add_option("--interval-us", interval_us, "tick period [us]")->check(CLI::Range(100, 100000));
  app.add_option("--priority", config.priority, "SCHED_FIFO priority")->check(CLI::Range(1, 98));
  app.add_option("--cpu", config.cpu, "pin the loop to this CPU (-1: not pinned)");
  CLI11_PARSE(app, argc, argv);

  rt::RtReport report;
  const rt::RtProcess process(config, report);
  rt::MonotonicClock clock;
  EmptyTick body;
  const auto executive =
      std::make_unique<rt::Executive<rt::MonotonicClock, EmptyTick>>(clock, body, interval_us * rt::kNsPerUs);
  const auto ticks = static_cast<std::uint64_t>(seconds * 1e6 / interval_us);
  auto run = [&] {
    executive->start();
    executive->run_ticks(200);  // warm-up (RT.md step 8)
    executive->reset_stats();
    executive->run_ticks(ticks);
  };
  rt::RtThread thread;
  if (!thread.start(config, run, report)) {
    rt::print_report(report, stderr);
    return 2;
  }
  thread.join();
  rt::print_report(report, stderr);
  const auto& s = executive->stats();
  const auto& h = s.wake_latency;
  std::printf("ours: samples=%llu p50_us=%.0f p99_us=%.0f p999_us=%.0f max_us=%.1f overruns=%llu fifo=%d\n",
              static_cast<unsigned long long>(h.count()), h.quantile_ns(0.5) / 1e3, h.quantile_ns(0.99) / 1e3,
              h.quantile_ns(0.999) / 1e3, static_cast<double>(h.max_ns()) / 1e3,
              static_cast<unsigned long long>(s.overruns), report.fifo ? 1 : 0);
  return 0;
}
