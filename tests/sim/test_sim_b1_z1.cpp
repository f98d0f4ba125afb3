// The second robot, Unitree B1 + Z1, in simulation (a -DSPRINGBOK_ROBOT=b1_z1 build): the
// paper's base step with the template scaled to it (tools/scenarios/b1_z1). The firmware is the
// same code as HyQ + Gen3's; only the robot folder differs.
#include <gtest/gtest.h>

#include "cli_test_util.hpp"

namespace {
using namespace springbok::test;

TEST(SimB1Z1, RendersTheBaseStepOfItsTemplate) {
  const fs::path dir = scratch("b1_z1_base_step");
  const CliResult r = run(kScenarios + "b1_z1/base_step_mb61.yaml", dir / "out");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const std::string json = slurp(dir / "out" / "summary.json");
  EXPECT_FALSE(json_true(json, "fell")) << json;
  EXPECT_EQ(json_number(json, "qp_failures"), 0.0);
  EXPECT_LE(json_number(json, "max_torque_ratio"), 1.0);
  // The targets of the paper's stance set (SPEC section 7), as for HyQ + Gen3.
  EXPECT_LE(member(json, "nrmse", "base_x"), 0.08);
  EXPECT_LE(member(json, "nrmse", "ee_x"), 0.03);
  // At rest the template's closed form: the base F / K_b forward (30 N / 663 N/m).
  const std::vector<double> t = log_column(dir / "out" / "log.csv", "time_s");
  const std::vector<double> x = log_column(dir / "out" / "log.csv", "base_x_m");
  ASSERT_EQ(t.size(), x.size());
  const auto before_push = static_cast<std::size_t>(std::lower_bound(t.begin(), t.end(), 0.999) - t.begin());
  ASSERT_LT(before_push, x.size());
  EXPECT_NEAR(x.back() - x[before_push], 30.0 / 663.0, 0.01 * 30.0 / 663.0);
}

}  // namespace
