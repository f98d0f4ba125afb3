#include "springbok/rt/realtime.hpp"

#include <fcntl.h>
#include <malloc.h>
#include <sched.h>
#include <sys/mman.h>
#include <unistd.h>

#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <fstream>

namespace springbok::rt {
namespace {

std::string errno_text(int err) { return std::string(std::strerror(err)); }

}  // namespace

void prefault_stack() {
  volatile unsigned char buffer[256 * 1024];
  for (std::size_t i = 0; i < sizeof buffer; i += 4096) buffer[i] = 0;
}

bool preempt_rt_kernel() {
  std::ifstream in("/sys/kernel/realtime");
  int value = 0;
  return static_cast<bool>(in >> value) && value == 1;
}

void print_report(const RtReport& report, std::FILE* out) {
  for (const auto& note : report.notes) std::fprintf(out, "rt: %s\n", note.c_str());
  if (!report.warnings.empty()) {
    std::fprintf(out,
                 "################################################################\n"
                 "# WARNING: NOT REAL-TIME. The control loop runs without:\n");
    for (const auto& w : report.warnings) std::fprintf(out, "#   - %s\n", w.c_str());
    std::fprintf(out,
                 "# Expect missed deadlines. Use --require-rt on the robot.\n"
                 "################################################################\n");
  }
  if (!report.refusal.empty()) std::fprintf(out, "rt: REFUSING TO START: %s\n", report.refusal.c_str());
  std::fflush(out);
}

RtProcess::RtProcess(const RtConfig& config, RtReport& report) {
  if (!config.enabled) {
    report.warnings.emplace_back("real-time disabled by configuration (rt.enabled: false)");
    if (config.require) report.refusal = "--require-rt given but real-time is disabled";
    return;
  }
  report.rt_kernel = preempt_rt_kernel();
  if (report.rt_kernel) {
    report.notes.emplace_back("PREEMPT_RT kernel (/sys/kernel/realtime = 1)");
  } else {
    report.warnings.emplace_back("a PREEMPT_RT kernel (/sys/kernel/realtime is missing or 0)");
    if (config.require) {
      report.refusal = "not a PREEMPT_RT kernel";
      return;
    }
  }

  // Heap memory is never returned to the kernel: no page faults later.
  mallopt(M_MMAP_MAX, 0);
  mallopt(M_TRIM_THRESHOLD, -1);

  if (config.lock_memory) {
    if (mlockall(MCL_CURRENT | MCL_FUTURE) == 0) {
      report.memory_locked = true;
      report.notes.emplace_back("memory locked (mlockall current|future)");
    } else {
      const int err = errno;
      report.warnings.emplace_back("locked memory: mlockall failed: " + errno_text(err) +
                                   " (needs CAP_IPC_LOCK or LimitMEMLOCK=infinity)");
      if (config.require) {
        report.refusal = "mlockall failed: " + errno_text(err);
        return;
      }
    }
  }

  if (config.prefault_heap_bytes > 0) {
    // Touch the heap once: with trimming off the pages stay mapped (and locked).
    auto* block = static_cast<unsigned char*>(std::malloc(config.prefault_heap_bytes));
    if (block != nullptr) {
      for (std::size_t i = 0; i < config.prefault_heap_bytes; i += 4096) block[i] = 1;
      std::free(block);
      report.notes.emplace_back("heap prefaulted: " + std::to_string(config.prefault_heap_bytes >> 20) +
                                " MiB");
    }
  }

  if (config.hold_cpu_dma_latency) {
    dma_latency_fd_ = ::open("/dev/cpu_dma_latency", O_WRONLY | O_CLOEXEC);
    const std::int32_t zero_us = 0;
    if (dma_latency_fd_ >= 0 && ::write(dma_latency_fd_, &zero_us, sizeof zero_us) == sizeof zero_us) {
      report.dma_latency = true;
      report.notes.emplace_back("/dev/cpu_dma_latency held at 0 us");
    } else {
      report.warnings.emplace_back("/dev/cpu_dma_latency (deep C-states stay allowed): " +
                                   errno_text(errno));
      if (dma_latency_fd_ >= 0) ::close(dma_latency_fd_);
      dma_latency_fd_ = -1;
    }
  }
}

RtProcess::~RtProcess() {
  if (dma_latency_fd_ >= 0) ::close(dma_latency_fd_);
}

void* RtThread::thread_main(void* self_ptr) {
  auto* self = static_cast<RtThread*>(self_ptr);
  if (self->prefault_stack_) prefault_stack();
  self->entry_(self->body_);
  return nullptr;
}

bool RtThread::start_thread(const RtConfig& config, RtReport& report) {
  prefault_stack_ = config.enabled;
  pthread_attr_t attr;
  pthread_attr_init(&attr);
  pthread_attr_setstacksize(&attr, config.thread_stack_bytes);
  bool want_fifo = config.enabled;
  if (want_fifo) {
    sched_param param{};
    param.sched_priority = config.priority;
    pthread_attr_setinheritsched(&attr, PTHREAD_EXPLICIT_SCHED);
    pthread_attr_setschedpolicy(&attr, SCHED_FIFO);
    pthread_attr_setschedparam(&attr, &param);
  }
  cpu_set_t cpus;
  if (config.enabled && config.cpu >= 0) {
    CPU_ZERO(&cpus);
    CPU_SET(config.cpu, &cpus);
    pthread_attr_setaffinity_np(&attr, sizeof cpus, &cpus);
  }

  int err = pthread_create(&thread_, &attr, &RtThread::thread_main, this);
  if (err == EPERM || err == EINVAL) {
    const std::string why = "SCHED_FIFO " + std::to_string(config.priority) +
                            (config.cpu >= 0 ? " on CPU " + std::to_string(config.cpu) : std::string()) +
                            ": " + errno_text(err) +
                            (err == EPERM ? " (needs CAP_SYS_NICE or LimitRTPRIO)" : " (no such CPU or priority)");
    if (config.require) {
      report.refusal = why;
      pthread_attr_destroy(&attr);
      return false;
    }
    report.warnings.push_back(why);
    pthread_attr_destroy(&attr);
    pthread_attr_init(&attr);
    pthread_attr_setstacksize(&attr, config.thread_stack_bytes);
    want_fifo = false;
    err = pthread_create(&thread_, &attr, &RtThread::thread_main, this);
  }
  pthread_attr_destroy(&attr);
  if (err != 0) {
    report.refusal = "pthread_create: " + errno_text(err);
    return false;
  }
  started_ = true;
  report.fifo = want_fifo;
  report.pinned = want_fifo && config.cpu >= 0;
  if (report.fifo) report.notes.emplace_back("control thread SCHED_FIFO " + std::to_string(config.priority));
  if (report.pinned) report.notes.emplace_back("control thread pinned to CPU " + std::to_string(config.cpu));
  return true;
}

void RtThread::join() {
  if (started_) {
    pthread_join(thread_, nullptr);
    started_ = false;
  }
}

}  // namespace springbok::rt
