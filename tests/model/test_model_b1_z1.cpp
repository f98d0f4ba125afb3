// Unitree B1 + Z1's generated model against the numbers its README states independently
// (../shared/robot/b1_z1/README.md): the mass, the feet and the flange at q = 0, the limits.
// The URDF's joints turn about x and y: these checks go through the turned body frames.
#include <gtest/gtest.h>

#include "model_fk.hpp"
#include "springbok/model/model.hpp"

namespace {
using namespace springbok;
using springbok::test::frame_in_trunk;

TEST(ModelB1Z1, Dimensions) {
  EXPECT_EQ(kNj, 18);
  EXPECT_EQ(kNv, 24);
  EXPECT_EQ(kArmJoints, 6);
  EXPECT_EQ(robot::kJoints[0].name, "FL_hip_joint");  // the URDF's FR first: reordered LF RF LH RH
  EXPECT_EQ(robot::kJoints[3].name, "FR_hip_joint");
  EXPECT_EQ(robot::kJoints[6].name, "RL_hip_joint");
  EXPECT_EQ(robot::kJoints[kFirstArmJoint].name, "joint1");
  EXPECT_EQ(robot::kBaseLink, "base");
}

TEST(ModelB1Z1, MassOfEveryLinkWithTheLockedJaw) {
  EXPECT_NEAR(total_mass_kg(), 60.90997083, 1e-6);
  // The jaw (0.27621302 kg, locked) and the stator are part of link06's body.
  EXPECT_GT(robot::kJoints[kNj - 1].inertia.mass_kg, 0.52603655 + 0.27621302);
}

TEST(ModelB1Z1, FeetAndFlangeAtZero) {
  const VecNj q = VecNj::Zero();
  const double sx[4] = {1, 1, -1, -1}, sy[4] = {1, -1, 1, -1};
  for (int f = 0; f < kFeet; ++f) {
    const Eigen::Vector3d p = frame_in_trunk(kFootFrames[f], q).translation();
    EXPECT_NEAR(p.x(), sx[f] * 0.3455, 1e-9) << f;
    EXPECT_NEAR(p.y(), sy[f] * 0.19875, 1e-9) << f;
    EXPECT_NEAR(p.z(), -0.70, 1e-9) << f;
  }
  const Eigen::Isometry3d ee = frame_in_trunk(kEeFrame, q);
  EXPECT_NEAR((ee.translation() - Eigen::Vector3d(0.3882, 0.0, 0.2505)).norm(), 0.0, 1e-9);
  EXPECT_NEAR((ee.linear() - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff(), 0.0, 1e-12);
  EXPECT_DOUBLE_EQ(kFootRadius_m, 0.04);
}

// A thigh turns about the URDF's y: +0.5 rad swings the foot backwards (-x) and up.
TEST(ModelB1Z1, ThighAboutY) {
  VecNj q = VecNj::Zero();
  q[1] = 0.5;
  const Eigen::Vector3d p = frame_in_trunk(kFootFrames[0], q).translation();
  EXPECT_NEAR(p.x(), 0.3455 - 0.7 * std::sin(0.5), 1e-9);
  EXPECT_NEAR(p.z(), -0.7 * std::cos(0.5), 1e-9);
}

TEST(ModelB1Z1, LimitsFromTheUrdf) {
  const auto& hip = robot::kJoints[0].limits;
  EXPECT_DOUBLE_EQ(hip.lower_rad, -0.75);
  EXPECT_DOUBLE_EQ(hip.upper_rad, 0.75);
  EXPECT_DOUBLE_EQ(hip.effort_nm, 91.0035);
  EXPECT_DOUBLE_EQ(robot::kJoints[2].limits.effort_nm, 140.0);
  EXPECT_DOUBLE_EQ(robot::kJoints[kFirstArmJoint + 1].limits.upper_rad, 2.9670597283903604);
  for (int j = 0; j < kNj; ++j) EXPECT_EQ(torque_limit_peak_nm(j), robot::kJoints[static_cast<std::size_t>(j)].limits.effort_nm);
}

}  // namespace
