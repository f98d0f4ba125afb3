// Runs the generator CLI on good and broken URDFs: a bad file gets an error
// naming the element, a non-zero exit status and no output file.
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

GenResult run_generator(const std::string& urdf_text, const fs::path& out) {
  const fs::path dir = fs::temp_directory_path() / ("urdf2model_test_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  const fs::path in = dir / "robot.urdf", log = dir / "stderr.txt";
  std::ofstream(in) << urdf_text;
  const std::string cmd = std::string(SPRINGBOK_BIN_DIR) + "/urdf2model " + in.string() + " " + out.string() +
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

class Urdf2Model : public ::testing::Test {
 protected:
  fs::path out = fs::temp_directory_path() / ("urdf2model_out_" + std::to_string(::getpid()) + ".hpp");
  void SetUp() override { fs::remove(out); }
  void TearDown() override { fs::remove(out); }
  void expect_error(const std::string& urdf, const std::string& needle) {
    const GenResult r = run_generator(urdf, out);
    EXPECT_NE(r.status, 0);
    EXPECT_NE(r.err.find(needle), std::string::npos) << "stderr: " << r.err;
    EXPECT_FALSE(fs::exists(out));
  }
};

TEST_F(Urdf2Model, GoodTreeGenerates) {
  const GenResult r = run_generator(robot(link("a") + link("b") + joint("j", "revolute", "a", "b")), out);
  EXPECT_EQ(r.status, 0) << r.err;
  ASSERT_TRUE(fs::exists(out));
  std::ifstream f(out);
  const std::string text((std::istreambuf_iterator<char>(f)), {});
  EXPECT_NE(text.find("kNumJoints = 1;"), std::string::npos);
  EXPECT_NE(text.find("\"j\", \"b\", 0"), std::string::npos);
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
