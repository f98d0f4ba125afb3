// The robot file (robot.yaml, the format in firmware/model/robots/README.md): what a URDF cannot
// say about a quadruped manipulator. urdf2model reads it in two steps around the URDF:
//
//   RobotFile file(path);                 // YAML syntax; the URDF's path
//   Tree tree = read_urdf(file.urdf_path());
//   file.lock_joints(tree);               // locked_joints: those joints become fixed
//   Output bodies = build(tree);
//   RobotSpec spec = file.apply(tree, bodies);   // joint order LF RF LH RH then the arm, frames
//
// Every problem of the file is collected as "<field>: <what> (line N)" and thrown together as
// one Error, so a user sees all of them at once.
#pragma once

#include <array>
#include <string>
#include <vector>

#include "springbok/yaml/reader.hpp"
#include "urdf_tree.hpp"

namespace springbok::urdf2model {

inline constexpr int kFeet = 4;
inline constexpr int kLegJoints = 3;
inline constexpr std::array<const char*, kFeet> kLegNames{"lf", "rf", "lh", "rh"};

struct LeverIn {
  double force_max_n = 0, a_m = 0, b_m = 0, angle_sign = 1, angle_offset_rad = 0;
};

struct GainsIn {
  double mass = 0, damping = 0, stiffness = 0;  // mass: kg or kg m^2 (0: the composite)
};

// What the robot file adds to the bodies, in the generated joint order.
struct RobotSpec {
  std::string name;
  int first_arm_joint = 0;
  int arm_joints = 0;
  std::array<int, kFeet> foot_frames{};
  double foot_radius_m = 0;
  int ee_frame = 0, imu_frame = 0, wrist_ft_frame = 0;
  std::string rotor_source;
  std::vector<double> rotor_inertia_kgm2;  // per joint
  std::vector<bool> lever;                 // per joint: a lever actuator's limit
  std::vector<LeverIn> levers;             // per joint (lever only)
  std::vector<double> stance_rad, lying_rad;
  GainsIn base, ee, base_rotation, ee_rotation;
};

class RobotFile {
 public:
  // Throws Error when the file cannot be read or is not YAML.
  explicit RobotFile(std::string path);

  const std::string& path() const noexcept { return path_; }
  // The URDF the file names, beside the file (an absolute path as written).
  std::string urdf_path() const;
  // Turns every locked joint into a fixed joint at its angle. Throws Error on a bad entry.
  void lock_joints(Tree& tree) const;
  // Orders the joints (legs LF RF LH RH, three each from the trunk out, then the arm), adds a
  // frame where the file names a body's own link or a foot sphere off its frame, overrides the
  // URDF's flat efforts, and reads the rest. Throws Error with every problem found.
  RobotSpec apply(const Tree& tree, Output& bodies) const;

 private:
  std::string path_;
  yaml::Document doc_;
};

}  // namespace springbok::urdf2model
