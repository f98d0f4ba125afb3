// The trap must catch what it claims to catch, or every allocation test is void.
#include <memory>
#include <string>
#include <vector>

#include <Eigen/Dense>
#include <gtest/gtest.h>

#include "alloc_trap.hpp"

namespace {
using springbok::test::AllocationTrap;
using springbok::test::count_allocations;

TEST(AllocTrap, CountsADeliberateNew) {
  std::unique_ptr<int> p;
  const auto n = count_allocations([&] { p = std::make_unique<int>(42); });
  EXPECT_EQ(n, 1u);
}

TEST(AllocTrap, CountsVectorGrowthAndStrings) {
  std::vector<double> v;
  std::string s;
  const auto n = count_allocations([&] {
    v.resize(1000);
    s.assign(200, 'x');  // beyond the small-string buffer
  });
  EXPECT_EQ(n, 2u);
}

TEST(AllocTrap, FixedSizeEigenDoesNotAllocate) {
  Eigen::Matrix<double, 25, 25> a = Eigen::Matrix<double, 25, 25>::Random();
  Eigen::Matrix<double, 25, 1> x = Eigen::Matrix<double, 25, 1>::Random();
  Eigen::Matrix<double, 25, 1> y;
  const auto n = count_allocations([&] { y.noalias() = a * x; });
  EXPECT_EQ(n, 0u);
  EXPECT_TRUE(y.allFinite());
}

TEST(AllocTrapDeathTest, DynamicEigenAllocationAborts) {
  if (!springbok::test::eigen_malloc_trap_available()) {
    GTEST_SKIP() << "EIGEN_RUNTIME_NO_MALLOC is not armed in this build (release)";
  }
  GTEST_FLAG_SET(death_test_style, "threadsafe");
  EXPECT_DEATH(
      {
        AllocationTrap trap;
        Eigen::MatrixXd m(30, 30);  // heap: must trip eigen_assert
        m.setZero();
      },
      "is_malloc_allowed");
}

TEST(AllocTrap, DisarmedTrapLetsEigenAllocate) {
  { AllocationTrap trap; }
  Eigen::MatrixXd m(30, 30);
  m.setOnes();
  EXPECT_DOUBLE_EQ(m.sum(), 900.0);
}
}  // namespace
