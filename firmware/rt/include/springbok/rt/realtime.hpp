// The Linux real-time recipe (shared/RT.md), start-up side: kernel check,
// malloc tuning, mlockall, heap prefault, /dev/cpu_dma_latency, and the RT
// thread (SCHED_FIFO at a priority, CPU affinity, prefaulted stack).
//
// Every step is optional (RtConfig). A step that fails for lack of privileges
// gives a loud warning and the firmware runs without it; with
// RtConfig::require (`--require-rt`) it refuses to start instead. Start-up
// code: allocates, prints, never runs on the tick path.
#pragma once

#include <pthread.h>

#include <cstddef>
#include <cstdio>
#include <string>
#include <vector>

namespace springbok::rt {

struct RtConfig {
  bool enabled = true;    // false: a plain thread, nothing locked (simulation, tests)
  bool require = false;   // refuse to start unless every RT step succeeds on a PREEMPT_RT kernel
  int priority = 80;      // SCHED_FIFO priority of the control thread (1..98)
  int cpu = -1;           // CPU the control thread is pinned to; -1 = not pinned
  bool lock_memory = true;
  std::size_t prefault_heap_bytes = std::size_t{16} << 20;
  std::size_t thread_stack_bytes = std::size_t{1} << 20;
  bool hold_cpu_dma_latency = true;
};

struct RtReport {
  bool rt_kernel = false;      // /sys/kernel/realtime reads 1
  bool memory_locked = false;  // mlockall succeeded
  bool fifo = false;           // the control thread runs SCHED_FIFO
  bool pinned = false;         // the control thread is pinned to RtConfig::cpu
  bool dma_latency = false;    // /dev/cpu_dma_latency held at 0
  std::vector<std::string> notes;     // what was done
  std::vector<std::string> warnings;  // what could not be done
  std::string refusal;                // non-empty: RtConfig::require and a step failed
};

// True on a PREEMPT_RT kernel (/sys/kernel/realtime reads 1).
bool preempt_rt_kernel();

// Touches the calling thread's stack as deep as a tick's call chain may go (256 KiB), so
// that it never faults there (RtThread does it for the control thread).
void prefault_stack();

// Prints the notes, and the warnings under a loud banner.
void print_report(const RtReport& report, std::FILE* out);

// Process-wide steps, in recipe order. Holds /dev/cpu_dma_latency open for
// its lifetime. Check report.refusal afterwards.
class RtProcess {
 public:
  RtProcess(const RtConfig& config, RtReport& report);
  ~RtProcess();
  RtProcess(const RtProcess&) = delete;
  RtProcess& operator=(const RtProcess&) = delete;

 private:
  int dma_latency_fd_ = -1;
};

// The control thread, created with explicit attributes (SCHED_FIFO at the
// configured priority, affinity, stack size). Its stack is prefaulted before
// the body runs (256 KiB). Without privileges: a normal thread and a warning, or, with
// RtConfig::require, no thread and a refusal.
class RtThread {
 public:
  RtThread() = default;
  ~RtThread() { join(); }
  RtThread(const RtThread&) = delete;
  RtThread& operator=(const RtThread&) = delete;

  // Runs body() on the new thread; body must outlive the thread.
  template <class F>
  bool start(const RtConfig& config, F& body, RtReport& report) {
    entry_ = [](void* self) { (*static_cast<F*>(self))(); };
    body_ = &body;
    return start_thread(config, report);
  }
  void join();

 private:
  bool start_thread(const RtConfig& config, RtReport& report);
  static void* thread_main(void* self);

  pthread_t thread_{};
  bool started_ = false;
  bool prefault_stack_ = false;
  void (*entry_)(void*) = nullptr;  // the type-erased body: pthread's boundary only
  void* body_ = nullptr;
};

}  // namespace springbok::rt
