// Runs the generator CLI on good and broken URDFs and robot files: a bad file gets an error
// naming the element or the field, a non-zero exit status and no output file.
#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>

#include <gtest/gtest.h>

namespace {
namespace fs = std::filesystem;

struct GenResult {
  int status;
  std::string err;
};

// A robot file for the quadruped of quadruped_urdf() below.
std::string robot_file(const std::string& extra = "") {
  return "name: test_robot\n"
         "urdf: robot.urdf\n"
         "base_link: trunk\n"
         "legs:\n"
         "  lf: [lf_haa, lf_hfe, lf_kfe]\n"
         "  rf: [rf_haa, rf_hfe, rf_kfe]\n"
         "  lh: [lh_haa, lh_hfe, lh_kfe]\n"
         "  rh: [rh_haa, rh_hfe, rh_kfe]\n"
         "feet: {frames: [lf_foot, rf_foot, lh_foot, rh_foot], radius_m: 0.03, offset_m: [0, 0, 0]}\n"
         "arm: {joints: [arm_1, arm_2], end_effector: hand}\n"
         "imu_frame: imu\n"
         "wrist_ft_frame: hand\n"
         "rotor_inertia_kgm2: {source: estimate, arm_2: 0.01}\n"
         "stance_rad: {lf: [0, 0.5, -1], rf: [0, 0.5, -1], lh: [0, 0.5, -1], rh: [0, 0.5, -1], arm: [0, 0.3]}\n"
         "lying_rad: {lf: [0, 1, -2], rf: [0, 1, -2], lh: [0, 1, -2], rh: [0, 1, -2], arm: [0, 0]}\n"
         "template: {base: {mass: 20, damping: 200, stiffness: 500}, ee: {mass: 2, damping: 40, stiffness: 200}}\n"
         "rotational_template: {base: {damping: 50, stiffness: 100}, ee: {inertia: 0.05, damping: 2, stiffness: 20}}\n" +
         extra;
}

GenResult run_generator(const std::string& urdf_text, const fs::path& out, const std::string& robot = robot_file()) {
  const fs::path dir = fs::temp_directory_path() / ("urdf2model_test_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  const fs::path in = dir / "robot.urdf", file = dir / "robot.yaml", log = dir / "stderr.txt";
  std::ofstream(in) << urdf_text;
  std::ofstream(file) << robot;
  const std::string cmd = std::string(SPRINGBOK_BIN_DIR) + "/urdf2model " + file.string() + " " + out.string() +
                          " 2>" + log.string();
  const int status = std::system(cmd.c_str());
  std::string err;
  {
    std::ifstream l(log);
    err.assign(std::istreambuf_iterator<char>(l), {});
  }
  fs::remove_all(dir);  // the input and the log: what the test reads is in err
  return {status, err};
}

const char* kLink = R"(<inertial><mass value="1"/><inertia ixx="1" iyy="1" izz="1" ixy="0" ixz="0" iyz="0"/></inertial>)";

std::string link(const std::string& name, bool inertial = true) {
  return "<link name=\"" + name + "\">" + (inertial ? kLink : "") + "</link>";
}
std::string joint(const std::string& name, const std::string& type, const std::string& parent,
                  const std::string& child) {
  return "<joint name=\"" + name + "\" type=\"" + type + "\"><parent link=\"" + parent + "\"/><child link=\"" +
         child + "\"/><axis xyz=\"0 0 1\"/><limit lower=\"-1\" upper=\"1\" effort=\"1\" velocity=\"1\"/></joint>";
}
std::string robot(const std::string& body) { return "<robot name=\"t\">" + body + "</robot>"; }
std::string revolute(const std::string& name, const std::string& parent, const std::string& child,
                     const std::string& axis, double effort = 10.0) {
  return "<joint name=\"" + name + "\" type=\"revolute\"><parent link=\"" + parent + "\"/><child link=\"" + child +
         "\"/><origin xyz=\"0.1 0 0\"/><axis xyz=\"" + axis + "\"/><limit lower=\"-2.5\" upper=\"2.5\" effort=\"" +
         std::to_string(effort) + "\" velocity=\"10\"/></joint>";
}
std::string fixed(const std::string& name, const std::string& parent, const std::string& child) {
  return "<joint name=\"" + name + "\" type=\"fixed\"><parent link=\"" + parent + "\"/><child link=\"" + child +
         "\"/><origin xyz=\"0 0 -0.2\"/></joint>";
}

// A quadruped with a two-joint arm and a gripper jaw, its joints in another order than the
// robot file's (the arm first, then RF LF RH LH) and about x and y.
std::string quadruped_urdf(double lf_kfe_effort = 10.0) {
  std::string body = link("trunk") + link("imu") + fixed("imu_mount", "trunk", "imu");
  body += link("arm_l1") + link("arm_l2") + link("hand") + link("jaw") + revolute("arm_1", "trunk", "arm_l1", "0 0 1") +
          revolute("arm_2", "arm_l1", "arm_l2", "0 1 0") + fixed("flange", "arm_l2", "hand") +
          revolute("gripper", "hand", "jaw", "0 1 0");
  for (const char* leg : {"rf", "lf", "rh", "lh"}) {
    const std::string l = leg;
    body += link(l + "_hip") + link(l + "_thigh") + link(l + "_shank") + link(l + "_foot");
    body += revolute(l + "_haa", "trunk", l + "_hip", "1 0 0") + revolute(l + "_hfe", l + "_hip", l + "_thigh", "0 1 0") +
            revolute(l + "_kfe", l + "_thigh", l + "_shank", "0 1 0", l == "lf" ? lf_kfe_effort : 10.0) +
            fixed(l + "_foot_mount", l + "_shank", l + "_foot");
  }
  return robot(body);
}
std::string read_text(const fs::path& p) {
  std::ifstream f(p);
  return {std::istreambuf_iterator<char>(f), {}};
}

class Urdf2Model : public ::testing::Test {
 protected:
  fs::path out = fs::temp_directory_path() / ("urdf2model_out_" + std::to_string(::getpid()) + ".hpp");
  void SetUp() override { fs::remove(out); }
  void TearDown() override { fs::remove(out); }
  void expect_error(const std::string& urdf, const std::string& needle, const std::string& file = robot_file()) {
    const GenResult r = run_generator(urdf, out, file);
    EXPECT_NE(r.status, 0);
    EXPECT_NE(r.err.find(needle), std::string::npos) << "stderr: " << r.err;
    EXPECT_FALSE(fs::exists(out));
  }
};

// The joints come out in the robot file's order (legs LF RF LH RH, then the arm), each body
// renumbered with its parent before it; the locked jaw is a frame of the hand's body.
TEST_F(Urdf2Model, GoodRobotGenerates) {
  const GenResult r = run_generator(quadruped_urdf(), out, robot_file("locked_joints: {gripper: -0.5}\n"));
  EXPECT_EQ(r.status, 0) << r.err;
  ASSERT_TRUE(fs::exists(out));
  const std::string text = read_text(out);
  EXPECT_NE(text.find("namespace springbok::robot {"), std::string::npos);
  EXPECT_NE(text.find("kNumJoints = 14;"), std::string::npos);
  const char* order[] = {"lf_haa", "lf_hfe", "lf_kfe", "rf_haa", "rf_hfe", "rf_kfe", "lh_haa",
                         "lh_hfe", "lh_kfe", "rh_haa", "rh_hfe", "rh_kfe", "arm_1", "arm_2"};
  for (int i = 0; i < 14; ++i) {
    EXPECT_NE(text.find(std::string("kJoint_") + order[i] + " = " + std::to_string(i) + ";"), std::string::npos) << order[i];
  }
  // Each leg a chain from the base: lf_hfe (body 2) hangs on lf_haa's body 1, lf_haa on the trunk.
  EXPECT_NE(text.find("{\"lf_haa\", \"lf_hip\", 0,"), std::string::npos);
  EXPECT_NE(text.find("{\"lf_hfe\", \"lf_thigh\", 1,"), std::string::npos);
  EXPECT_NE(text.find("{\"rh_kfe\", \"rh_shank\", 11,"), std::string::npos);
  EXPECT_NE(text.find("{\"arm_2\", \"arm_l2\", 13,"), std::string::npos);
  EXPECT_NE(text.find("{\"jaw\", 14,"), std::string::npos);  // locked: a frame of the hand's body
  EXPECT_NE(text.find("kFirstArmJoint = 12;"), std::string::npos);
  EXPECT_NE(text.find("kArmJoints = 2;"), std::string::npos);
  EXPECT_NE(text.find("kFootRadius_m = 0.029999999999999999;"), std::string::npos);
  EXPECT_NE(text.find("kRotorInertia_kgm2{0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.01}"),
            std::string::npos);
  EXPECT_NE(text.find("kStance_rad{0.0, 0.5, -1.0,"), std::string::npos);
  EXPECT_NE(text.find("kTemplate{{20.0, 200.0, 500.0}, {2.0, 40.0, 200.0}, {0.0, 50.0, 100.0}, {0.050000000000000003, 2.0, 20.0}}"),
            std::string::npos);
}

// A foot sphere off its frame gets a frame of its own at its centre, which the feet then name.
TEST_F(Urdf2Model, FootOffsetAddsTheSphereCentre) {
  std::string file = robot_file();
  file.replace(file.find("offset_m: [0, 0, 0]"), 19, "offset_m: [0, 0, -0.02]");
  const GenResult r = run_generator(quadruped_urdf(), out, file + "locked_joints: {gripper: 0}\n");
  ASSERT_EQ(r.status, 0) << r.err;
  const std::string text = read_text(out);
  // The shank turns about y: its body frame is the URDF link's turned by R_a^T = Rx(pi/2) (every
  // joint about z), so the frame 0.2 m + 0.02 m down the link's -z is at +0.22 along its y.
  EXPECT_NE(text.find("{\"lf_foot_sphere\", 3, {{1.0, 0.0, 0.0, 0.0, 0.0, -1.0, 0.0, 1.0, 0.0}, {0.0, 0.22, 0.0}}}"),
            std::string::npos)
      << text;
}

// Every joint comes out about +z of its joint frame; the URDF's x axis (the hips) turns the
// joint frame by Ry(pi/2), y (hip and knee flexion) by Rx(-pi/2), and the body's inertia with it.
TEST_F(Urdf2Model, EveryAxisComesOutAsZ) {
  const GenResult r = run_generator(quadruped_urdf(), out, robot_file("locked_joints: {gripper: 0}\n"));
  ASSERT_EQ(r.status, 0) << r.err;
  const std::string text = read_text(out);
  std::size_t axes = 0;
  for (std::size_t at = text.find("model::JointType::"); at != std::string::npos; at = text.find("model::JointType::", at + 1)) {
    EXPECT_EQ(text.substr(at - 17, 15), "{0.0, 0.0, 1.0}") << text.substr(at - 40, 80);
    ++axes;
  }
  EXPECT_EQ(axes, 14u);
  // lf_haa: origin (0.1, 0, 0) turned by Ry(pi/2); its unit box-like inertia diag(1, 1, 1) unchanged.
  EXPECT_NE(text.find("{\"lf_haa\", \"lf_hip\", 0,\n     {{0.0, 0.0, 1.0, 0.0, 1.0, 0.0, -1.0, 0.0, 0.0}, {0.10000000000000001, 0.0, 0.0}}"),
            std::string::npos);
  // The hip's URDF link frame in its turned body frame: Ry(pi/2)^T (what a named link means).
  EXPECT_NE(text.find("kLinkInBody{{\n    {{1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0}, {0.0, 0.0, 0.0}},\n"
                      "    {{0.0, 0.0, -1.0, 0.0, 1.0, 0.0, 1.0, 0.0, 0.0}, {0.0, 0.0, 0.0}},"),
            std::string::npos);
  // lf_hfe hangs on the turned hip: its origin in the hip's new frame is Ry(pi/2)^T [I, (0.1, 0, 0)],
  // turned by its own Rx(-pi/2).
  EXPECT_NE(text.find("{\"lf_hfe\", \"lf_thigh\", 1,\n     {{0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 1.0, 0.0, 0.0}, {0.0, 0.0, 0.10000000000000001}}"),
            std::string::npos)
      << text.substr(text.find("{\"lf_hfe\""), 200);
}

// A lever actuator's torque limit, and a flat one in place of the URDF's effort.
TEST_F(Urdf2Model, TorqueLimitsFromTheRobotFile) {
  const GenResult r = run_generator(
      quadruped_urdf(0.0), out,
      robot_file("locked_joints: {gripper: 0}\ntorque_limits:\n  lf_kfe: {flat: 55}\n"
                 "  rh_hfe: {lever: {force_max_n: 3000, a_m: 0.3, b_m: 0.05, angle_sign: -1, angle_offset_rad: 1.5}}\n"));
  ASSERT_EQ(r.status, 0) << r.err;
  const std::string text = read_text(out);
  EXPECT_NE(text.find("{true, -2.5, 2.5, 55.0, 10.0}"), std::string::npos);
  EXPECT_NE(text.find("{model::TorqueLimit::Kind::lever, {3000.0, 0.29999999999999999, 0.050000000000000003, -1.0, 1.5}}"),
            std::string::npos);
}

// Every problem of a robot file names its field, all of them at once.
TEST_F(Urdf2Model, BadRobotFileNamesTheField) {
  const std::string urdf = quadruped_urdf();
  const std::string locked = "locked_joints: {gripper: 0}\n";
  auto with = [&](const std::string& from, const std::string& to) {
    std::string f = robot_file();
    f.replace(f.find(from), from.size(), to);
    return f + locked;
  };
  expect_error(urdf, "legs.lf[1]: 'lf_knee' is no movable joint of the URDF", with("lf_hfe,", "lf_knee,"));
  expect_error(urdf, "legs.rf[0]: 'lf_haa' is named twice", with("rf: [rf_haa", "rf: [lf_haa"));
  expect_error(urdf, "arm.joints: the URDF's movable joint 'gripper' is in no leg and not in the arm", robot_file());
  expect_error(urdf, "legs.lf[1]: 'lf_kfe' hangs on 'lf_thigh', not on 'lf_hip'",
               with("[lf_haa, lf_hfe, lf_kfe]", "[lf_haa, lf_kfe, lf_hfe]"));
  expect_error(urdf, "feet.frames[1]: 'lf_foot' must be fixed to leg rf's last body ('rf_shank')",
               with("[lf_foot, rf_foot", "[lf_foot, lf_foot"));
  expect_error(urdf, "feet.radius_m: missing", with("radius_m: 0.03, ", ""));
  expect_error(urdf, "imu_frame: 'hand' must be fixed to the base link ('trunk')", with("imu_frame: imu", "imu_frame: hand"));
  expect_error(urdf, "stance_rad.lf[1]: 3 is outside lf_hfe's range [-2.5, 2.5]", with("lf: [0, 0.5, -1]", "lf: [0, 3, -1]"));
  expect_error(urdf, "stance_rad.arm: must be a list of 2, got 3 elements", with("arm: [0, 0.3]", "arm: [0, 0.3, 0]"));
  expect_error(urdf, "wheels: unknown key", robot_file(locked + "wheels: 4\n"));
  expect_error(urdf, "locked_joints.arm_9: 'arm_9' is no movable joint of the URDF", robot_file("locked_joints: {arm_9: 0}\n"));
  expect_error(urdf, "torque_limits.lh_kfe.lever.b_m: must be shorter than a_m",
               robot_file(locked + "torque_limits:\n  lh_kfe: {lever: {force_max_n: 1, a_m: 0.1, b_m: 0.2, angle_sign: 1, "
                                   "angle_offset_rad: 0}}\n"));
  expect_error(quadruped_urdf(0.0), "torque_limits: 'lf_kfe' has no torque limit (the URDF's effort is 0): give one",
               robot_file(locked));
  expect_error(urdf, "base_link: 'imu' is not the URDF's root link 'trunk'", with("base_link: trunk", "base_link: imu"));
  expect_error(urdf, "rotor_inertia_kgm2.source: missing", with("source: estimate, ", ""));
}

TEST_F(Urdf2Model, MissingInertialNamesTheLink) {
  expect_error(robot(link("a") + link("lonely_link", false) + joint("j", "revolute", "a", "lonely_link")),
               "link 'lonely_link': missing <inertial>");
}

TEST_F(Urdf2Model, UnknownJointTypeNamesTheJoint) {
  expect_error(robot(link("a") + link("b") + joint("slider", "prismatic", "a", "b")),
               "joint 'slider': unsupported joint type 'prismatic'");
}

TEST_F(Urdf2Model, CycleIsAnError) {
  expect_error(robot(link("a") + link("b") + joint("j1", "revolute", "a", "b") + joint("j2", "revolute", "b", "a")),
               "cycle");
}

TEST_F(Urdf2Model, TwoRootsAreNamed) {
  expect_error(robot(link("a") + link("b") + link("c") + joint("j", "revolute", "a", "b")),
               "more than one root link ('a', 'c')");
}

TEST_F(Urdf2Model, UnknownLinkAndBadNumber) {
  expect_error(robot(link("a") + joint("j", "revolute", "a", "ghost")), "joint 'j': unknown child link 'ghost'");
  expect_error(robot("<link name=\"a\"><inertial><mass value=\"heavy\"/><inertia ixx=\"1\" iyy=\"1\" izz=\"1\" "
                     "ixy=\"0\" ixz=\"0\" iyz=\"0\"/></inertial></link>"),
               "link 'a' <mass> value: bad number 'heavy'");
}

TEST_F(Urdf2Model, NotXml) { expect_error("<robot><link", "cannot parse XML"); }
}  // namespace
