// springbok-sim trotting in place with the whole-body controller (controller.params.gait):
// the diagonal pairs alternate at the configured rate, the robot keeps its height and
// does not fall; a bad gait parameter is refused naming its field.
#include <gtest/gtest.h>

#include <fstream>
#include <string>

#include "../sim/cli_test_util.hpp"

namespace springbok::test {
namespace {

std::string scenario(const std::string& gait) {
  return "duration_s: 2.5\n"
         "initial:\n"
         "  joint_positions_rad: [0, 0.7, -1.4, 0, 0.7, -1.4, 0, -0.7, 1.4, 0, -0.7, 1.4, 0, 0.6, 0, 1.9, 0, 0.9, 0]\n"
         "  feet_clearance_m: 0.0\n"
         "controller:\n"
         "  type: wbc\n"
         "  settle_s: 0.5\n"
         "  params:\n"
         "    template:\n"
         "      base: {mass: 92, damping: 610, stiffness: 1000}\n"
         "      ee: {mass: 4, damping: 90, stiffness: 500}\n"
         "    gait: " + gait + "\n";
}

TEST(SimTrot, TrotsInPlace) {
  const fs::path dir = scratch("trot");
  std::ofstream(dir / "s.yaml") << scenario("{step_frequency: 1.4, duty_factor: 0.65, step_height: 0.08}");
  const CliResult r = run((dir / "s.yaml").string(), dir / "out");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const std::string json = slurp(dir / "out" / "summary.json");
  EXPECT_FALSE(json_true(json, "fell")) << json;
  // 2 s of trot at 1.4 Hz: each foot lifts off and touches down 2.8 times (2 changes per cycle).
  const double changes = json_number(json.substr(json.find("\"gait\":")), "stance_changes");
  EXPECT_GE(changes, 4 * 2 * 2.0) << json;
  EXPECT_LE(changes, 4 * 2 * 3.0) << json;
  EXPECT_LE(json_number(json, "qp_failures"), 5.0) << json;
  // The trunk stays up: the final base height is that of the stance (0.63 m) within 3 cm.
  const auto at = json.find("\"final_base_position_m\"");
  ASSERT_NE(at, std::string::npos);
  const std::string tail = json.substr(json.find('[', at) + 1);
  const double z = std::stod(tail.substr(tail.rfind(',', tail.find(']')) + 1));
  EXPECT_NEAR(z, 0.63, 0.03) << json;
}

TEST(SimTrot, BadGaitParameterIsNamed) {
  const fs::path dir = scratch("trot_bad");
  std::ofstream(dir / "s.yaml") << scenario("{duty_factor: 0.3}");
  const CliResult r = run((dir / "s.yaml").string(), dir / "out");
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.err.find("controller.params.gait.duty_factor"), std::string::npos) << r.err;
}

}  // namespace
}  // namespace springbok::test
