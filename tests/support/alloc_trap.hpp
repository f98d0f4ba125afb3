// The allocation trap: a counting global operator new plus Eigen's runtime
// malloc check (EIGEN_RUNTIME_NO_MALLOC, live in the debug and asan presets).
//
//   springbok::test::AllocationTrap trap;   // armed
//   controller.tick(...);
//   EXPECT_EQ(trap.disarm(), 0u);            // operator-new calls while armed
//
// While armed, any dynamic Eigen allocation fails eigen_assert (abort), and
// every operator new (any thread) is counted. Keep gtest assertions outside
// the armed region: gtest itself allocates.
#pragma once

#include <cstddef>

namespace springbok::test {

// Total operator-new calls in this process since start-up.
std::size_t allocation_count() noexcept;

// True when this binary checks Eigen's dynamic allocations at run time.
bool eigen_malloc_trap_available() noexcept;

class AllocationTrap {
 public:
  AllocationTrap() noexcept;
  ~AllocationTrap();
  AllocationTrap(const AllocationTrap&) = delete;
  AllocationTrap& operator=(const AllocationTrap&) = delete;

  // Stops trapping; returns the operator-new calls seen while armed.
  std::size_t disarm() noexcept;

 private:
  std::size_t start_;
  std::size_t seen_ = 0;
  bool armed_ = true;
};

// Runs f under a trap; returns the number of operator-new calls it made.
template <class F>
std::size_t count_allocations(F&& f) {
  AllocationTrap trap;
  f();
  return trap.disarm();
}

}  // namespace springbok::test
