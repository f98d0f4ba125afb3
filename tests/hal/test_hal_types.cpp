#include <type_traits>

#include <gtest/gtest.h>

#include "alloc_trap.hpp"
#include "springbok/hal/hardware.hpp"

namespace {
using namespace springbok;

static_assert(std::is_copy_assignable_v<hal::Measurements>);
static_assert(std::is_abstract_v<hal::Hardware>);

TEST(HalTypes, DriveTorqueLaw) {
  hal::JointCommands c;
  c.mode = hal::CommandMode::enabled;
  c.tau_ff_nm[4] = 2.0;
  c.kp_nm_per_rad[4] = 100.0;
  c.q_des_rad[4] = 0.5;
  c.kd_nms_per_rad[4] = 3.0;
  c.qd_des_rad_s[4] = 0.0;
  EXPECT_DOUBLE_EQ(hal::drive_torque_nm(c, 4, 0.4, 1.0), 2.0 + 100.0 * 0.1 - 3.0);
  c.mode = hal::CommandMode::disabled;
  EXPECT_DOUBLE_EQ(hal::drive_torque_nm(c, 4, 0.4, 1.0), 0.0);
}

TEST(HalTypes, CopyingAMeasurementDoesNotAllocate) {
  hal::Measurements a, b;
  a.q_rad.setConstant(0.3);
  a.drives[7].state = hal::DriveState::fault;
  const auto n = test::count_allocations([&] { b = a; });
  EXPECT_EQ(n, 0u);
  EXPECT_EQ(b.drives[7].state, hal::DriveState::fault);
  EXPECT_DOUBLE_EQ(b.q_rad[18], 0.3);
}
}  // namespace
