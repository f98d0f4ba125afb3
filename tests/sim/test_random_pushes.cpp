// A scenario's random_pushes, as load_scenario expands them into step wrenches: the
// spacing, magnitudes, directions, durations and frames the key asks for, the same
// pushes for the same seed, other pushes for another, and refusals naming the field.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <set>
#include <string>

#include "cli_test_util.hpp"
#include "scenario.hpp"

namespace springbok::test {
namespace {

std::string scenario(const std::string& pushes) {
  return "duration_s: 70.0\n"
         "initial:\n"
         "  joint_positions_rad: [0, 0.7, -1.4, 0, 0.7, -1.4, 0, -0.7, 1.4, 0, -0.7, 1.4, 0, 0.6, 0, 1.9, 0, 0.9, 0]\n"
         "controller: {type: stand}\n"
         "external_wrenches:\n"
         "  - {frame: arm_end_effector_link, axis: [1, 0, 0], profile: step, amplitude: 50, start_s: 2.0}\n"
         "random_pushes: " + pushes + "\n";
}

simtool::Scenario load(const fs::path& dir, const std::string& pushes) {
  std::ofstream(dir / "s.yaml") << scenario(pushes);
  return simtool::load_scenario((dir / "s.yaml").string());
}

constexpr const char* kSoak =
    "{seed: 7, start_s: 3.0, end_s: 63.0, every_s: [2.0, 4.0], duration_s: 0.2, max_force_n: 80, "
    "frames: [trunk, arm_end_effector_link]}";

TEST(RandomPushes, AreSpacedSizedAndAimedAsAsked) {
  const fs::path dir = scratch("random_pushes");
  const simtool::Scenario s = load(dir, kSoak);
  ASSERT_GE(s.wrenches.size(), 1u + 60 / 4);  // the scripted step, then a push every 2-4 s over 60 s
  ASSERT_LE(s.wrenches.size(), 1u + 60 / 2);
  std::set<std::string> frames;
  double last_start_s = 3.0;
  for (std::size_t i = 1; i < s.wrenches.size(); ++i) {
    const sim::ExternalWrench& w = s.wrenches[i].wrench;
    EXPECT_EQ(w.kind, sim::WrenchKind::force);
    EXPECT_EQ(w.profile.shape, sim::ProfileShape::step);
    EXPECT_EQ(w.profile.duration_s, 0.2);
    EXPECT_GE(w.profile.amplitude, 20.0);
    EXPECT_LE(w.profile.amplitude, 80.0);
    EXPECT_NEAR(w.axis_world.norm(), 1.0, 1e-12);
    EXPECT_EQ(w.axis_world.z(), 0.0);
    const double gap_s = w.profile.start_s - last_start_s;
    EXPECT_GE(gap_s, 2.0) << i;
    EXPECT_LE(gap_s, 4.0) << i;
    EXPECT_LE(w.profile.start_s + 0.2, 63.0);
    last_start_s = w.profile.start_s;
    frames.insert(s.wrenches[i].frame);
  }
  EXPECT_EQ(frames, (std::set<std::string>{"trunk", "arm_end_effector_link"}));
  // Deterministic from the seed.
  const simtool::Scenario again = load(dir, kSoak);
  ASSERT_EQ(again.wrenches.size(), s.wrenches.size());
  for (std::size_t i = 0; i < s.wrenches.size(); ++i) {
    EXPECT_EQ(again.wrenches[i].wrench.profile.start_s, s.wrenches[i].wrench.profile.start_s);
    EXPECT_EQ(again.wrenches[i].wrench.axis_world, s.wrenches[i].wrench.axis_world);
    EXPECT_EQ(again.wrenches[i].frame, s.wrenches[i].frame);
  }
  std::string other(kSoak);
  other.replace(other.find("seed: 7"), 7, "seed: 8");
  const simtool::Scenario reseeded = load(dir, other);
  EXPECT_NE(reseeded.wrenches[1].wrench.profile.start_s, s.wrenches[1].wrench.profile.start_s);
}

TEST(RandomPushes, BadFieldsAreNamed) {
  const fs::path dir = scratch("random_pushes_bad");
  const auto error_of = [&](const std::string& pushes) {
    try {
      (void)load(dir, pushes);
    } catch (const std::exception& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_NE(error_of("{every_s: [3, 2], frames: [trunk]}").find("random_pushes.every_s: must be [lo, hi], lo <= hi"),
            std::string::npos);
  EXPECT_NE(error_of("{frames: [trunk, nose]}").find("random_pushes.frames[1]: unknown frame 'nose'"), std::string::npos);
  EXPECT_NE(error_of("{frames: []}").find("random_pushes.frames: must name at least one frame"), std::string::npos);
  EXPECT_NE(error_of("{frames: [trunk], every_s: [0.5, 0.5], end_s: 60}").find("random_pushes: more than 64"),
            std::string::npos);
  EXPECT_NE(error_of("{frames: [trunk], force: 3}").find("random_pushes.force: unknown key"), std::string::npos);
}

// The WBC settles first (wrist F/T tare, reference pose): a wrench that starts before
// controller.settle_s would be built into both (a 50 N step from t = 0 with settle_s 0.5 was
// tared out and the robot fell), so it is refused naming the field; from settle_s on it is fine.
TEST(ScenarioWrenches, AWrenchBeforeTheWbcSettledIsRefusedNamingTheField) {
  const fs::path dir = scratch("wrench_before_settle");
  const auto error_of = [&](const std::string& settle_s, const std::string& wrenches) {
    std::ofstream(dir / "s.yaml") << "duration_s: 5.0\n"
                                     "controller: {type: wbc, settle_s: " + settle_s + ", params: {}}\n" + wrenches;
    try {
      (void)simtool::load_scenario((dir / "s.yaml").string());
    } catch (const std::exception& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  const std::string step_at_0 =
      "external_wrenches:\n"
      "  - {frame: trunk, axis: [0, 1, 0], profile: step, amplitude: 5, start_s: 2.0}\n"
      "  - {frame: arm_end_effector_link, axis: [1, 0, 0], profile: step, amplitude: 50}\n";
  EXPECT_NE(error_of("0.5", step_at_0).find("external_wrenches[1].start_s: 0 s is before controller.settle_s (0.5 s)"),
            std::string::npos)
      << error_of("0.5", step_at_0);
  EXPECT_EQ(error_of("0.0", step_at_0), "no error");  // the controller runs from the first tick
  EXPECT_EQ(error_of("0.5",
                     "external_wrenches:\n"
                     "  - {frame: arm_end_effector_link, axis: [1, 0, 0], profile: step, amplitude: 50, start_s: 0.5}\n"),
            "no error");
  EXPECT_NE(error_of("4.0", "random_pushes: {seed: 1, start_s: 1.0, end_s: 5.0, every_s: [1, 1], frames: [trunk]}\n")
                .find("random_pushes.start_s: the first push at 2 s is before controller.settle_s (4 s)"),
            std::string::npos);
}

}  // namespace
}  // namespace springbok::test
