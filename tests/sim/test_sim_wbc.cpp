// springbok-sim with the whole-body controller (controller.type: wbc): a short
// 50 N step at the hand must render the template (scores computed by the tool
// against the exactly integrated template), a bad parameter is refused naming
// its field, and tools/experiments/report.py turns a run into plots and a report.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdlib>
#include <sstream>
#include <vector>
#include <fstream>
#include <string>
#include <tuple>

#include "cli_test_util.hpp"

namespace springbok::test {
namespace {

// M_b 4 kg settles within a second of the push: 3 s of simulation suffices.
std::string step_scenario(const std::string& base_mass) {
  return wbc_scenario_head("3.0", "0.2", "{mass: " + base_mass + ", damping: 126.5, stiffness: 1000}",
                           "{mass: 4, damping: 90, stiffness: 500}") +
         "    contact: {foot_radius: 0.02175}\n"
         "external_wrenches:\n"
         "  - {frame: arm_end_effector_link, axis: [1, 0, 0], profile: step, amplitude: 50, start_s: 0.5}\n";
}

fs::path write_file(const fs::path& dir, const std::string& name, const std::string& text) {
  std::ofstream(dir / name) << text;
  return dir / name;
}

TEST(SimWbc, StepRendersTheTemplate) {
  const fs::path dir = scratch("wbc_step");
  const fs::path out = dir / "base_step_mb4";
  std::string json;
  ASSERT_NO_FATAL_FAILURE(run_to_summary(write_file(dir, "step.yaml", step_scenario("4")).string(), out, json));
  expect_upright_and_solved(json);
  EXPECT_LE(json_number(json, "max_torque_ratio"), 1.0);
  EXPECT_NE(json.find("\"joint_limit_hit\": null"), std::string::npos);
  EXPECT_LE(member(json, "nrmse", "base_x"), 0.08);
  EXPECT_LE(member(json, "nrmse", "ee_x"), 0.03);
  EXPECT_LE(member(json, "steady_state_error", "base_x"), 0.01);
  EXPECT_LE(member(json, "steady_state_error", "ee_x"), 0.01);
  // Axes the template does not move along are not scored.
  EXPECT_NE(json.find("\"base_y\": null"), std::string::npos);
  EXPECT_GT(member(json, "tick_us", "median"), 0.0);
  // The slowest tick, with what it met (one of the five causes) and when.
  EXPECT_GE(member(json, "tick_us", "p99_9"), member(json, "tick_us", "p99"));
  EXPECT_GE(member(json, "tick_us", "max"), member(json, "tick_us", "p99_9"));
  EXPECT_GE(member(json, "tick_us", "max_at_s"), 0.2);
  EXPECT_GE(member(json, "tick_us", "max_page_faults"), 0.0);
  const auto cause = json.find("\"max_cause\": \"");
  ASSERT_NE(cause, std::string::npos);
  const std::string word = json.substr(cause + 14, json.find('"', cause + 14) - cause - 14);
  EXPECT_TRUE(word == "page_fault" || word == "context_switch" || word == "first_tick" || word == "qp_solve" ||
              word == "unattributed")
      << word;
  // The log carries the WBC's columns.
  const std::string log = slurp(out / "log.csv");
  for (const char* column : {",base_dx_m,", ",template_ee_x_m,", ",fe_x_n,", ",lf_fx_n,", ",qp_status,", ",tick_us,", ",tick_page_faults,", ",tick_context_switches"}) {
    EXPECT_NE(log.find(column), std::string::npos) << column;
  }

  // The report from this one run: its plots and table; the other runs are listed as missing.
  const std::string report_cmd = "/usr/bin/python3 '" + std::string(SPRINGBOK_SOURCE_DIR) +
                                 "/tools/experiments/report.py' '" + dir.string() + "' >/dev/null 2>&1";
  ASSERT_EQ(std::system(report_cmd.c_str()), 0);
  const std::string report = slurp(dir / "report.md");
  EXPECT_NE(report.find("| base_step_mb4 |"), std::string::npos);
  EXPECT_NE(report.find("PASS base_step_mb4"), std::string::npos);
  EXPECT_NE(report.find("MISS arm_step_me4: missing"), std::string::npos);
  EXPECT_GT(fs::file_size(dir / "base_step_x.png"), 1000u);
}

// A step push from 1 s, on the hand unless `frame` says where, the experiments' template (M_b 92,
// D_b 610, K_b 1000; M_e 4, D_e 90, K_e 500) on sphere feet: the scenario's text, for the arm's
// `joint_positions_rad`, the push's axis and force, `contact` keys after foot_radius, the
// run's length, and more of controller.params (whole lines).
std::string push_scenario(const std::string& arm, const std::string& axis, const std::string& force,
                          const std::string& contact_extra, const std::string& duration_s,
                          const std::string& frame = "arm_end_effector_link", const std::string& params_extra = "") {
  return wbc_scenario_head(duration_s, "0.5", "{mass: 92, damping: 610, stiffness: 1000}", "{mass: 4, damping: 90, stiffness: 500}",
                           arm) +
         "    contact: {foot_radius: 0.02175" + contact_extra + "}\n" + params_extra +
         "external_wrenches:\n"
         "  - {frame: " + frame + ", axis: " + axis + ", profile: step, amplitude: " + force + ", start_s: 1.0}\n";
}

// A run's summary says the robot stood to the end, every QP solved, the supervisor in control
// without a fault.
void expect_stood(const std::string& json, const std::string& name) {
  EXPECT_FALSE(json_true(json, "fell")) << name;
  EXPECT_EQ(json_number(json, "qp_failures"), 0.0) << name;
  EXPECT_NE(json.find("\"supervisor\": {\"mode\": \"control\", \"faults\": 0}"), std::string::npos) << name;
}

// A push the arm cannot hold leaves the robot standing: the paper's 50 N and 100 N on the
// straight arm (kStraightArm: the hand 0.9 m above the shoulder, whose 39 N m hold 43 N there) and
// 120 N on the bent arm of the experiments. The arm yields (arm_overloaded_s) and the base keeps
// its task. Before, the QP gave the arm's task and speed rows the trunk instead: it pitched the
// trunk 0.3-0.8 rad, a hind foot unloaded, and the robot fell (QP failures, damping) within a
// second. And the folded arm's stretched spring no longer drags the base after the hand (the
// base sank 21 cm under 50 N on the straight arm; under 100 N the robot tipped over).
TEST(SimWbc, APushTheArmCannotHoldLeavesTheRobotStanding) {
  for (const auto& [name, arm, force] :
       {std::tuple{"straight_50n", kStraightArm.c_str(), "50"}, std::tuple{"straight_100n", kStraightArm.c_str(), "100"},
        std::tuple{"bent_120n", kBentArm.c_str(), "120"}}) {
    const fs::path dir = scratch(std::string("wbc_overload_") + name);
    const std::string text = push_scenario(arm, "[1, 0, 0]", force, "", "4.0");
    std::string json;
    ASSERT_NO_FATAL_FAILURE(run_to_summary(write_file(dir, "push.yaml", text).string(), dir / "out", json));
    expect_stood(json, name);
    EXPECT_GT(json_number(json, "arm_overloaded_s"), 1.0) << name << ": the arm could not hold it";
    EXPECT_LE(member(json, "peak_deviation", "base_x"), 0.1) << name;
    EXPECT_LE(member(json, "peak_deviation", "base_z"), 0.1) << name;
  }
}

// A push whose moment takes the robot toward tipping: the template's base compliance (K_b 1000)
// moved the trunk, and with it the centre of mass, toward the edge of the feet the push tips
// the robot over. 100 N along y on the bent arm took the right feet to their minimum force with
// the base 5.6 cm over, and the robot rolled over at 3.3 s; 150 N along x fell at 3.1 s, 100 N
// along y on the straight arm at 2.4 s. The support limit (WholeBodyController::support_limit)
// holds the base back so that the static centre of pressure stays 4 cm inside the feet's
// polygon: all three stand. With contact.support_margin 0 (the limit off) the first falls.
// A push the wrist does not measure (on the trunk) counts too: the robot's momentum balance
// estimates it (RobotController: the external force less the feet's and the hand's, log
// columns unmeasured_f*_n), at the centre of mass. 120 N along y on the trunk tipped the
// standing robot over at 3.3 s, 200 N along x at 2.7 s; both stand now, the estimate within
// 5 % of the push, and without the limit the first falls. Stepping to catch a push is off here
// (push_stepping: the straight arm's 100 N comes within its 2 cm of the edge and would step):
// these are the limit's cases; APushPastWhatStandingHoldsMakesTheRobotStep is stepping's.
TEST(SimWbc, APushTowardTippingLeavesTheRobotStanding) {
  const std::string& bent = kBentArm;
  const std::string hand = "arm_end_effector_link", trunk = "trunk";
  for (const auto& [name, arm, frame, axis, force, margin] :
       {std::tuple{"bent_y100", bent.c_str(), hand.c_str(), "[0, 1, 0]", 100.0, ""},
        std::tuple{"bent_x150", bent.c_str(), hand.c_str(), "[1, 0, 0]", 150.0, ""},
        std::tuple{"straight_y100", kStraightArm.c_str(), hand.c_str(), "[0, 1, 0]", 100.0, ""},
        std::tuple{"bent_y100_off", bent.c_str(), hand.c_str(), "[0, 1, 0]", 100.0, ", support_margin: 0"},
        std::tuple{"trunk_y120", bent.c_str(), trunk.c_str(), "[0, 1, 0]", 120.0, ""},
        std::tuple{"trunk_x200", bent.c_str(), trunk.c_str(), "[1, 0, 0]", 200.0, ""},
        std::tuple{"trunk_y120_off", bent.c_str(), trunk.c_str(), "[0, 1, 0]", 120.0, ", support_margin: 0"}}) {
    const fs::path dir = scratch(std::string("wbc_tipping_") + name);
    const std::string text =
        push_scenario(arm, axis, std::to_string(force), margin, "5.0", frame, "    push_stepping: {enabled: false}\n");
    std::string json;
    ASSERT_NO_FATAL_FAILURE(run_to_summary(write_file(dir, "push.yaml", text).string(), dir / "out", json));
    if (std::string(margin).empty()) {
      expect_stood(json, name);
      EXPECT_GT(json_number(json, "support_limited_s"), 0.5) << name << ": the limit held the base";
      EXPECT_LE(member(json, "peak_deviation", "base_z"), 0.1) << name;
      if (frame == trunk) {
        const std::string along = std::string(axis) == "[0, 1, 0]" ? "y" : "x";
        const std::vector<double> estimate = log_column(dir / "out" / "log.csv", "unmeasured_f" + along + "_n");
        ASSERT_FALSE(estimate.empty());
        EXPECT_NEAR(estimate.back(), force, 0.05 * force) << name;
      }
    } else {
      EXPECT_TRUE(json_true(json, "fell")) << name << ": without the limit";
      EXPECT_EQ(json_number(json, "support_limited_s"), 0.0) << name;
    }
  }
}

// A push past what standing can hold: 250 N along y on the trunk toppled the standing robot at
// 2.2 s (the support limit leans the trunk against a push only until the centre of pressure
// reaches the feet's edge), 250 N backwards (-x) at 3.4 s, and 200 N along x at the hand at
// 2.9 s. Stepping (control::PushStepping: the centre of pressure or its capture point within
// 2 cm of the edge, or a foot's normal force within 5 N of its minimum - backwards the front
// feet unload first -, for 0.05 s, starts a trot in place whose footholds centre under it and
// lead the trunk's velocity by 0.25 s) all stand, and so does 300 N backwards, which fell at
// 2.1 s while stepping when only the static centre of pressure and the feet triggered it (at
// 1.8 s; the capture point, at 1.5 s);
// the trunk's stands again on its new footholds once the robot and the push have settled
// (stepping_for_push back to 0, all feet down), still pushed, the base over by about the
// template's F / K_b. With push_stepping off the first falls, as before. (Without the
// velocity lead the trunk's case fell too; 200 N overshot to 0.74 m and sagged 13 cm.)
TEST(SimWbc, APushPastWhatStandingHoldsMakesTheRobotStep) {
  const std::string& bent = kBentArm;
  for (const auto& [name, frame, axis, force, extra, duration] :
       {std::tuple{"trunk_y250", "trunk", "[0, 1, 0]", "250", "", "5.0"},
        std::tuple{"trunk_mx250", "trunk", "[-1, 0, 0]", "250", "", "4.0"},
        std::tuple{"trunk_mx300", "trunk", "[-1, 0, 0]", "300", "", "4.0"},
        std::tuple{"hand_x200", "arm_end_effector_link", "[1, 0, 0]", "200", "", "4.0"},
        std::tuple{"trunk_y250_off", "trunk", "[0, 1, 0]", "250", "    push_stepping: {enabled: false}\n", "4.0"}}) {
    const fs::path dir = scratch(std::string("wbc_push_step_") + name);
    const std::string text = push_scenario(bent, axis, force, "", duration, frame, extra);
    std::string json;
    ASSERT_NO_FATAL_FAILURE(run_to_summary(write_file(dir, "push.yaml", text).string(), dir / "out", json));
    if (std::string(extra).empty()) {
      expect_stood(json, name);
      EXPECT_GE(member(json, "push_stepping", "times"), 1.0) << name << ": it stepped";
      EXPECT_LE(member(json, "peak_deviation", "base_z"), 0.1) << name;
    } else {
      EXPECT_TRUE(json_true(json, "fell")) << name << ": without stepping";
      EXPECT_EQ(member(json, "push_stepping", "times"), 0.0) << name;
    }
    if (std::string(name) == "trunk_y250") {  // settled: standing again, pushed
      const fs::path log = dir / "out" / "log.csv";
      const std::vector<double> stepping = log_column(log, "stepping_for_push");
      ASSERT_FALSE(stepping.empty());
      EXPECT_EQ(stepping.back(), 0.0);
      for (const char* foot : {"lf_stance", "rf_stance", "lh_stance", "rh_stance"}) EXPECT_EQ(log_column(log, foot).back(), 1.0) << foot;
      EXPECT_NEAR(log_column(log, "base_y_m").back(), 250.0 / 1000.0, 0.1) << "the base stands over, pushed";
    }
  }
}

// The rotational template (beyond the paper): the shipped 5 N m torque step about y at the hand
// (I_e 0.4 kg m^2), cut to 4 s: trunk and hand orientations follow the template driven by the
// measured wrist torque (measured 0.05 % NRMSE, steady state within 0.01 % of T/K); the
// translational axes are not scored (no force), the rotations about x and z not either.
// The chirp's gain error is scored for any linear sweep the schema allows: falling (here
// 3 -> 0.25 Hz) and constant-frequency chirps too (before: null, the windows assumed a rise).
TEST(SimWbc, ChirpGainIsScoredFallingAndAtAConstantFrequency) {
  const std::string text = slurp(fs::path(SPRINGBOK_SOURCE_DIR) / "tools/scenarios/base_chirp_x_mb92.yaml");
  for (const auto& [name, sweep, duration] : {std::tuple{"falling", "start_frequency_hz: 3, end_frequency_hz: 0.25", "6.0"},
                                              std::tuple{"constant", "start_frequency_hz: 1, end_frequency_hz: 1", "3.0"}}) {
    const fs::path dir = scratch(std::string("wbc_chirp_") + name);
    std::string t = text;
    t.replace(t.find("start_frequency_hz: 0, end_frequency_hz: 5"), 42, sweep);
    t.replace(t.find("duration_s: 10.0"), 16, std::string("duration_s: ") + duration);
    t.replace(t.find("duration_s: 11.5"), 16, "duration_s: " + std::to_string(std::stod(duration) + 1.2));
    std::string json;
    ASSERT_NO_FATAL_FAILURE(run_to_summary(write_file(dir, "chirp.yaml", t).string(), dir / "out", json));
    EXPECT_FALSE(json_true(json, "fell")) << name;
    const double base_db = member(json, "chirp_gain_db_error", "base_x"), ee_db = member(json, "chirp_gain_db_error", "ee_x");
    EXPECT_TRUE(std::isfinite(base_db) && std::isfinite(ee_db)) << name << ": " << json;
    EXPECT_LE(base_db, 2.0) << name;
    EXPECT_LE(ee_db, 2.0) << name;
  }
}

TEST(SimWbc, TorqueStepRendersTheRotationalTemplate) {
  const fs::path dir = scratch("wbc_rot_step");
  std::string text = slurp(fs::path(SPRINGBOK_SOURCE_DIR) / "tools/scenarios/rot_step_y_ie0p4.yaml");
  const auto at = text.find("duration_s: 6.0");
  ASSERT_NE(at, std::string::npos);
  text.replace(at, 15, "duration_s: 4.0");
  std::string json;
  ASSERT_NO_FATAL_FAILURE(run_to_summary(write_file(dir, "rot.yaml", text).string(), dir / "out", json));
  expect_upright_and_solved(json);
  EXPECT_LE(member(json, "nrmse", "base_ry"), 0.05);
  EXPECT_LE(member(json, "nrmse", "ee_ry"), 0.05);
  EXPECT_LE(member(json, "steady_state_error", "base_ry"), 0.01);
  EXPECT_LE(member(json, "steady_state_error", "ee_ry"), 0.01);
  const auto nrmse = json.substr(json.find("\"nrmse\":"));
  for (const char* axis : {"ee_x", "base_x", "ee_rx", "ee_rz"}) {
    EXPECT_NE(nrmse.substr(0, nrmse.find('}')).find(std::string("\"") + axis + "\": null"), std::string::npos) << axis;
  }
  // The log carries the rotational template and the measured torque.
  const std::string log = slurp(dir / "out" / "log.csv");
  for (const char* column : {",template_ee_ry_rad,", ",ee_ry_rad,", ",te_y_nm"}) {
    EXPECT_NE(log.find(column), std::string::npos) << column;
  }
}

// Hand pose commands, orientation: the shipped hand_turn (the rest orientation turns 0.4 rad
// about z and 0.3 about y and back while a 2 N m torque about x acts): the hand follows its
// moving rest orientation (measured 1.2 mrad rms) and renders the torque about it; without
// the rotational template the turning waypoints are refused, naming the key.
TEST(SimWbc, TheHandTurnsWithItsRestOrientationAndRendersTheTorqueAboutIt) {
  const fs::path dir = scratch("wbc_hand_turn");
  const std::string shipped = slurp(fs::path(SPRINGBOK_SOURCE_DIR) / "tools/scenarios/hand_turn.yaml");
  std::string json;
  ASSERT_NO_FATAL_FAILURE(run_to_summary(write_file(dir, "turn.yaml", shipped).string(), dir / "out", json));
  expect_upright_and_solved(json);
  EXPECT_LE(member(json, "nrmse", "ee_rx"), 0.05);
  EXPECT_LE(member(json, "steady_state_error", "ee_rx"), 0.01);
  EXPECT_LE(member(json, "rms_error", "ee_ry"), 0.005);
  EXPECT_LE(member(json, "rms_error", "ee_rz"), 0.005);
  EXPECT_LE(member(json, "rms_error", "ee_x"), 0.001);
  EXPECT_NE(slurp(dir / "out" / "log.csv").find(",hand_rest_rz_rad"), std::string::npos);

  std::string without = shipped;
  const auto from = without.find("    rotational_template:");
  const auto to = without.find("    contact:");
  ASSERT_NE(from, std::string::npos);
  without.erase(from, to - from);
  const CliResult refused = run(write_file(dir, "no_rot.yaml", without).string(), dir / "refused");
  EXPECT_EQ(refused.exit_code, 2);
  EXPECT_NE(refused.err.find("controller.params.hand_trajectory"), std::string::npos) << refused.err;
  EXPECT_NE(refused.err.find("rotational template"), std::string::npos) << refused.err;
}

TEST(SimWbc, NegativeMassIsRefusedNamingTheField) {
  const fs::path dir = scratch("wbc_bad_mass");
  const CliResult r = run(write_file(dir, "bad.yaml", step_scenario("-4")).string(), dir / "out");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("controller.params.template.base.mass"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(dir / "out" / "log.csv"));
}

// Hand pose commands: the shipped hand_circle (the rest point draws a 10 cm circle at 0.5 Hz
// while a 20 N push acts on the hand): the rest point moves on the circle, the hand follows
// it and renders the push (measured 0.12 mm rms, ee_x NRMSE 0.02 %); waypoints the hand
// cannot reach in time are refused naming the key.
TEST(SimWbc, TheHandFollowsAMovingRestPointAndRendersThePushOnIt) {
  const fs::path dir = scratch("wbc_hand_circle");
  std::string json;
  ASSERT_NO_FATAL_FAILURE(
      run_to_summary(std::string(SPRINGBOK_SOURCE_DIR) + "/tools/scenarios/hand_circle.yaml", dir / "out", json));
  expect_upright_and_solved(json);
  EXPECT_LE(member(json, "nrmse", "ee_x"), 0.03);
  EXPECT_LE(member(json, "rms_error", "ee_y"), 0.005);
  EXPECT_LE(member(json, "rms_error", "ee_z"), 0.005);
  // The rest point went round: its offset reached the circle's top, 10 cm up.
  const std::vector<double> rest_dz = log_column(dir / "out" / "log.csv", "hand_rest_dz_m");
  ASSERT_FALSE(rest_dz.empty());
  EXPECT_NEAR(*std::max_element(rest_dz.begin(), rest_dz.end()), 0.10, 0.002);

  std::string fast = slurp(std::string(SPRINGBOK_SOURCE_DIR) + "/tools/scenarios/hand_circle.yaml");
  fast.replace(fast.find("{at_s: 1.2500"), 13, "{at_s: 1.1260");  // 16 mm in 1 ms
  const CliResult refused = run(write_file(dir, "fast.yaml", fast).string(), dir / "fast");
  EXPECT_EQ(refused.exit_code, 2);
  EXPECT_NE(refused.err.find("controller.params.hand_trajectory: the path between the waypoints"), std::string::npos)
      << refused.err;
}

TEST(SimWbc, RunAllNeedsTwoArguments) {
  const std::string cmd = "'" + std::string(SPRINGBOK_SOURCE_DIR) + "/tools/experiments/run_all' >/dev/null 2>&1";
  const int status = std::system(cmd.c_str());
  EXPECT_EQ(WIFEXITED(status) ? WEXITSTATUS(status) : -1, 2);
}

}  // namespace
}  // namespace springbok::test
