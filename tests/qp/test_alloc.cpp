// A full solve, cold and warm, at the firmware size and the controller's tight
// size, allocates nothing (counting operator new + Eigen's malloc trap).
#include <memory>
#include <string>

#include <gtest/gtest.h>

#include "alloc_trap.hpp"
#include "qp_file.hpp"
#include "springbok/qp/solver.hpp"

namespace {

using springbok::qp::Status;

template <int N, int ME, int MI>
void expect_no_allocation(const std::string& file) {
  using S = springbok::qp::Solver<N, ME, MI>;
  std::string error;
  const auto in = springbok::qpfile::read_instance(std::string(SPRINGBOK_SHARED_DIR) + "/qp/instances/" + file, error);
  ASSERT_TRUE(in.has_value()) << error;
  auto solver = std::make_unique<S>();
  auto problem = std::make_unique<typename S::ProblemType>();
  auto result = std::make_unique<typename S::ResultType>();
  auto warm = std::make_unique<springbok::qp::ActiveSet<MI>>();
  ASSERT_TRUE(springbok::qpfile::load_problem(*in, *problem));
  typename S::Hint hint;
  hint.active_set = warm.get();
  Status cold = Status::bad_input, warm_status = Status::bad_input;
  int active = 0;
  {
    springbok::test::AllocationTrap trap;
    cold = solver->solve(*problem, *result);
    *warm = result->active;
    active = warm->size;
    warm_status = solver->solve(*problem, *result, hint);
    EXPECT_EQ(trap.disarm(), 0u);
  }
  EXPECT_EQ(cold, Status::optimal);
  EXPECT_EQ(warm_status, Status::optimal);
  EXPECT_GT(active, 0) << "pick an instance with active rows";
}

TEST(QpAllocation, FirmwareSizeColdAndWarm) { expect_no_allocation<64, 32, 160>("wbc_stance4_19.qp"); }
TEST(QpAllocation, TightSizeColdAndWarm) { expect_no_allocation<40, 12, 62>("wbc_fmax_qdd_06.qp"); }
TEST(QpAllocation, TrapIsLive) { EXPECT_TRUE(springbok::test::eigen_malloc_trap_available()); }

}  // namespace
