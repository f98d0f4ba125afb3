// Text of springbok-sim scenarios for tests (YAML, as tools/scenarios/README.md describes it).
#pragma once
#include <string>

namespace springbok::test {

// The experiments' robot standing with its arm bent: the initial joint positions (legs, then arm) most
// scenarios start from.
inline const std::string kBentArm = "[0, 0.7, -1.4, 0, 0.7, -1.4, 0, -0.7, 1.4, 0, -0.7, 1.4, 0, 0.6, 0, 1.9, 0, 0.9, 0]";
// The same legs with the arm straight up (every arm joint at zero).
inline const std::string kStraightArm = "[0, 0.7, -1.4, 0, 0.7, -1.4, 0, -0.7, 1.4, 0, -0.7, 1.4, 0, 0, 0, 0, 0, 0, 0]";

// A springbok-sim scenario's head with the WBC: its length, the robot standing on the ground
// (`arm`: the initial joint positions), the settle time and the template's base and ee maps. It ends
// inside controller.params: callers add their keys (4-space lines), then their wrenches.
inline std::string wbc_scenario_head(const std::string& duration_s, const std::string& settle_s,
                                     const std::string& base, const std::string& ee,
                                     const std::string& arm = kBentArm) {
  return "duration_s: " + duration_s + "\n" +
         "initial:\n"
         "  joint_positions_rad: " + arm + "\n" +
         "  feet_clearance_m: 0.0\n"
         "controller:\n"
         "  type: wbc\n"
         "  settle_s: " + settle_s + "\n" +
         "  params:\n"
         "    template:\n"
         "      base: " + base + "\n" +
         "      ee: " + ee + "\n";
}

}  // namespace springbok::test
