// The generated model against the numbers PARAMS.md states independently.
#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>

#include "springbok/model/model.hpp"

namespace {
using namespace springbok;

Eigen::Isometry3d to_iso(const model::Transform& t) {
  Eigen::Isometry3d x = Eigen::Isometry3d::Identity();
  x.linear() = Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>>(t.rotation.data());
  x.translation() = Eigen::Map<const Eigen::Vector3d>(t.translation.data());
  return x;
}

// Frame placement in the trunk frame for joint angles q (plain serial FK).
Eigen::Isometry3d frame_in_trunk(int frame, const VecNj& q) {
  std::array<Eigen::Isometry3d, kNb> body;
  body[0] = Eigen::Isometry3d::Identity();
  for (int i = 0; i < kNj; ++i) {
    const auto& j = robot::kJoints[i];
    const Eigen::Vector3d axis(j.axis[0], j.axis[1], j.axis[2]);
    body[i + 1] = body[j.parent_body] * to_iso(j.origin) * Eigen::AngleAxisd(q[i], axis);
  }
  const auto& f = robot::kFrames[frame];
  return body[f.body] * to_iso(f.placement);
}

TEST(Model, Dimensions) {
  EXPECT_EQ(kNq, 26);
  EXPECT_EQ(kNv, 25);
  EXPECT_EQ(kNj, 19);
  EXPECT_EQ(kFeet, 4);
  EXPECT_EQ(robot::kJoints[kFirstArmJoint].name, "arm_joint_1");
  for (int i = 0; i < kNj; ++i) EXPECT_LT(robot::kJoints[i].parent_body, i + 1) << robot::kJoints[i].name;
}

TEST(Model, TotalMassMatchesParams) {
  static_assert(total_mass_kg() > 94.0 && total_mass_kg() < 95.0);
  EXPECT_NEAR(total_mass_kg(), 94.824, 1e-9);
  EXPECT_NEAR(robot::kBaseInertia.mass_kg, 60.96 + 0.018 + 1.697, 1e-12);
}

TEST(Model, FeetAndEndEffectorAtZeroAndStance) {
  VecNj q = VecNj::Zero();
  const double sx[4] = {1, 1, -1, -1}, sy[4] = {1, -1, 1, -1};
  for (int f = 0; f < kFeet; ++f) {
    const Eigen::Vector3d p = frame_in_trunk(kFootFrames[f], q).translation();
    EXPECT_NEAR(p.x(), sx[f] * 0.3735, 1e-9);
    EXPECT_NEAR(p.y(), sy[f] * 0.207, 1e-9);
    EXPECT_NEAR(p.z(), -0.776, 1e-9);
  }
  const Eigen::Isometry3d ee = frame_in_trunk(kEeFrame, q);
  EXPECT_NEAR((ee.translation() - Eigen::Vector3d(0.3, -0.02486, 1.287385)).norm(), 0.0, 1e-6);
  EXPECT_NEAR((ee.linear() - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff(), 0.0, 1e-5);

  for (int f = 0; f < kFeet; ++f) {
    const double s = f < 2 ? 1.0 : -1.0;
    q.segment<3>(leg_first_joint(f)) << 0.0, s * 0.7, -s * 1.4;
  }
  for (int f = 0; f < kFeet; ++f) {
    const Eigen::Vector3d p = frame_in_trunk(kFootFrames[f], q).translation();
    EXPECT_NEAR(p.x(), sx[f] * 0.370923, 1e-6);
    EXPECT_NEAR(p.y(), sy[f] * 0.207, 1e-9);
    EXPECT_NEAR(p.z(), -0.61233, 1e-5);
  }
}

TEST(Model, LimitsFromUrdf) {
  const auto& haa = robot::kJoints[robot::kJoint_lf_haa_joint].limits;
  EXPECT_TRUE(haa.bounded);
  EXPECT_DOUBLE_EQ(haa.lower_rad, -1.2217304764);
  EXPECT_DOUBLE_EQ(haa.upper_rad, 0.436332312999);
  EXPECT_DOUBLE_EQ(haa.effort_nm, 150.0);
  const auto& a1 = robot::kJoints[robot::kJoint_arm_joint_1];
  EXPECT_EQ(a1.type, model::JointType::continuous);
  EXPECT_FALSE(a1.limits.bounded);
  EXPECT_DOUBLE_EQ(a1.limits.effort_nm, 39.0);
  EXPECT_DOUBLE_EQ(robot::kJoints[robot::kJoint_arm_joint_7].limits.effort_nm, 9.0);
}

TEST(Model, InertiasArePhysical) {
  auto check = [](const model::Inertia& in, std::string_view name) {
    const auto& I = in.inertia_com_kgm2;
    Eigen::Matrix3d m;
    m << I[0], I[3], I[4], I[3], I[1], I[5], I[4], I[5], I[2];
    const Eigen::Vector3d ev = Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(m).eigenvalues();
    EXPECT_GT(in.mass_kg, 0.0) << name;
    EXPECT_GT(ev.minCoeff(), 0.0) << name;
    EXPECT_GE(ev[0] + ev[1], ev[2] * (1 - 1e-9)) << name;  // triangle inequality
  };
  check(robot::kBaseInertia, "base");
  for (const auto& j : robot::kJoints) check(j.inertia, j.child_link);
}
}  // namespace
