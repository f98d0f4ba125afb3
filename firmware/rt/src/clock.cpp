#include "springbok/rt/clock.hpp"

#include <cerrno>
#include <ctime>

namespace springbok::rt {

std::int64_t MonotonicClock::now_ns() noexcept {  // rt: no alloc
  timespec ts{};
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return static_cast<std::int64_t>(ts.tv_sec) * kNsPerS + ts.tv_nsec;
}

void MonotonicClock::sleep_until_ns(std::int64_t t_ns) noexcept {  // rt: no alloc
  timespec deadline{};
  deadline.tv_sec = static_cast<time_t>(t_ns / kNsPerS);
  deadline.tv_nsec = static_cast<long>(t_ns % kNsPerS);
  // clock_nanosleep returns the error number (it does not set errno).
  while (clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &deadline, nullptr) == EINTR) {
  }
}

}  // namespace springbok::rt
