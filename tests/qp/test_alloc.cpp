// A full solve, cold and warm, at the firmware size and the controller's tight
// size, allocates nothing (counting operator new + Eigen's malloc trap).
#include <algorithm>
#include <memory>
#include <string>

#include <gtest/gtest.h>

#include "alloc_trap.hpp"
#include "kkt_check.hpp"
#include "qp_file.hpp"
#include "springbok/qp/solver.hpp"
#include "test_data.hpp"

namespace {

using springbok::qp::Status;

template <int N, int ME, int MI>
void expect_no_allocation(const std::string& file) {
  using S = springbok::qp::Solver<N, ME, MI>;
  std::string error;
  const auto in = springbok::qpfile::read_instance(springbok::test::qp_instance(file), error);
  ASSERT_TRUE(in.has_value()) << error;
  auto [solver, problem, result] = springbok::qp::test::on_heap<S>();
  auto warm = std::make_unique<springbok::qp::ActiveSet<MI>>();
  ASSERT_TRUE(springbok::qpfile::load_problem(*in, *problem));
  typename S::Hint hint;
  hint.active_set = warm.get();
  Status cold = Status::bad_input, warm_status = Status::bad_input, short_status = Status::bad_input;
  int active = 0;
  Status empty_status = Status::bad_input;
  bool warm_direct = false, empty_direct = true;
  int short_repairs = 0;
  springbok::qp::Side first_side = springbok::qp::Side::equal;
  {
    springbok::test::AllocationTrap trap;
    cold = solver->solve(*problem, *result);
    *warm = result->active;
    active = warm->size;
    warm_status = solver->solve(*problem, *result, hint);  // the hinted set holds: solved on it directly
    warm_direct = result->from_hint;
    // The hint short of its first row (an inequality row: those come first): that row is
    // violated on the rest; the shortcut's repairs run (and here and there the full method).
    first_side = warm->side[0];
    std::copy(warm->row.begin() + 1, warm->row.begin() + warm->size, warm->row.begin());
    std::copy(warm->side.begin() + 1, warm->side.begin() + warm->size, warm->side.begin());
    --warm->size;
    short_status = solver->solve(*problem, *result, hint);
    short_repairs = result->iterations;
    // No hinted row at all: more rows to add than the shortcut repairs, the full method runs
    // from the (empty) warm set.
    warm->clear();
    empty_status = solver->solve(*problem, *result, hint);
    empty_direct = result->from_hint;
    EXPECT_EQ(trap.disarm(), 0u);
  }
  EXPECT_EQ(cold, Status::optimal);
  EXPECT_EQ(warm_status, Status::optimal);
  EXPECT_TRUE(warm_direct);
  EXPECT_NE(first_side, springbok::qp::Side::equal);
  EXPECT_EQ(short_status, Status::optimal);
  EXPECT_GE(short_repairs, 1);
  EXPECT_EQ(empty_status, Status::optimal);
  EXPECT_FALSE(empty_direct);
  EXPECT_GT(active, S::kShortcutRepairs) << "pick an instance with more active rows than the shortcut repairs";
}

TEST(QpAllocation, FirmwareSizeColdAndWarm) { expect_no_allocation<64, 32, 160>("wbc_fmax_qdd_07.qp"); }
TEST(QpAllocation, TightSizeColdAndWarm) { expect_no_allocation<40, 12, 62>("wbc_fmax_qdd_06.qp"); }
// The trap is armed in the builds that run the allocation tests for real (the debug preset:
// SPRINGBOK_TRAP_EIGEN_MALLOC with assertions); a Release build has no trap to check.
TEST(QpAllocation, TrapIsLive) {
#if defined(EIGEN_RUNTIME_NO_MALLOC) && !defined(NDEBUG)
  EXPECT_TRUE(springbok::test::eigen_malloc_trap_available());
#else
  GTEST_SKIP() << "no Eigen malloc trap in this build (SPRINGBOK_TRAP_EIGEN_MALLOC, with assertions)";
#endif
}

}  // namespace
