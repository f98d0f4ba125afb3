// HyQ + Gen3's generated model against the numbers PARAMS.md and ACTUATORS.md state
// independently.
#include <gtest/gtest.h>

#include <limits>
#include <numbers>

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>

#include "hyq_actuator_oracle.hpp"
#include "model_fk.hpp"
#include "springbok/model/model.hpp"

namespace {
using namespace springbok;
using springbok::test::frame_in_trunk;

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

// ACTUATORS.md's tables (hind-leg convention, N m to 0.1): every row, on the hind legs at the
// angle and on the front legs at its negative, the same limit in both directions.
TEST(Model, HydraulicJointLimitsFollowTheActuatorTable) {
  const std::array<double, 13> hfe{81.7, 107.5, 128.7, 144.9, 155.7, 161.2, 161.6,
                                   157.2, 148.5, 135.9, 120.0, 101.4, 80.5};
  const std::array<double, 13> kfe{81.1, 101.9, 120.5, 136.3, 148.7, 157.3, 161.6,
                                   161.1, 155.5, 144.5, 128.2, 106.8, 80.9};
  constexpr double kDeg = std::numbers::pi / 180.0;
  for (int foot = 0; foot < kFeet; ++foot) {
    const bool front = foot < 2;
    const double sign = front ? -1.0 : 1.0;
    const int j_hfe = leg_first_joint(foot) + 1;
    const int j_kfe = leg_first_joint(foot) + 2;
    for (std::size_t i = 0; i < hfe.size(); ++i) {
      const double q_hfe = sign * (-70.0 + 10.0 * static_cast<double>(i)) * kDeg;
      const double q_kfe = sign * (20.0 + 10.0 * static_cast<double>(i)) * kDeg;
      EXPECT_NEAR(torque_limit_nm(j_hfe, q_hfe), hfe[i], 0.051) << "foot " << foot << " row " << i;
      EXPECT_NEAR(torque_limit_nm(j_kfe, q_kfe), kfe[i], 0.051) << "foot " << foot << " row " << i;
      EXPECT_NEAR(torque_limit_nm(j_hfe, q_hfe), test::hyq_leg_limit_nm(j_hfe, q_hfe), 1e-9);
      EXPECT_NEAR(torque_limit_nm(j_kfe, q_kfe), test::hyq_leg_limit_nm(j_kfe, q_kfe), 1e-9);
    }
    // The ranges are the table's: its ends are the joint's stops.
    EXPECT_NEAR(robot::kJoints[static_cast<std::size_t>(j_hfe)].limits.lower_rad, front ? -50 * kDeg : -70 * kDeg, 1e-9);
    EXPECT_NEAR(robot::kJoints[static_cast<std::size_t>(j_kfe)].limits.upper_rad, front ? -20 * kDeg : 140 * kDeg, 1e-9);
  }
}

TEST(Model, TorqueLimitsBeyondTheRangeUnknownAngleAndPeak) {
  constexpr int kKnee = robot::kJoint_lh_kfe_joint;  // [20, 140] deg
  const auto& lim = robot::kJoints[kKnee].limits;
  // Beyond a stop the cylinder is at its end.
  EXPECT_DOUBLE_EQ(torque_limit_nm(kKnee, lim.upper_rad + 0.3), torque_limit_nm(kKnee, lim.upper_rad));
  EXPECT_DOUBLE_EQ(torque_limit_nm(kKnee, lim.lower_rad - 0.3), torque_limit_nm(kKnee, lim.lower_rad));
  // An unknown angle: the smallest over the range (the 140 deg end, 80.9 N m).
  EXPECT_NEAR(torque_limit_nm(kKnee, std::numeric_limits<double>::quiet_NaN()), 80.9, 0.05);
  EXPECT_NEAR(torque_limit_nm(robot::kJoint_rf_hfe_joint, std::numeric_limits<double>::infinity()), 80.5, 0.05);
  // The peak: the lever perpendicular, F b = 3600 N x 0.045 m, reached inside both ranges.
  for (int j : {robot::kJoint_lf_hfe_joint, robot::kJoint_rf_kfe_joint, robot::kJoint_lh_hfe_joint, kKnee}) {
    EXPECT_DOUBLE_EQ(torque_limit_peak_nm(j), 162.0) << j;
    double sampled = 0.0;
    const auto& l = robot::kJoints[static_cast<std::size_t>(j)].limits;
    for (int i = 0; i <= 10000; ++i) {
      sampled = std::max(sampled, torque_limit_nm(j, l.lower_rad + (l.upper_rad - l.lower_rad) * i / 10000.0));
    }
    EXPECT_NEAR(sampled, 162.0, 1e-3) << j;
    EXPECT_LE(sampled, 162.0 + 1e-12) << j;
  }
  // HAA and the arm: the URDF's flat effort at any angle.
  for (double q : {-1.0, 0.0, 0.3, std::numeric_limits<double>::quiet_NaN()}) {
    EXPECT_EQ(torque_limit_nm(robot::kJoint_rh_haa_joint, q), 150.0);
    EXPECT_EQ(torque_limit_nm(robot::kJoint_arm_joint_2, q), 39.0);
    EXPECT_EQ(torque_limit_nm(robot::kJoint_arm_joint_6, q), 9.0);
  }
  EXPECT_EQ(torque_limit_peak_nm(robot::kJoint_rh_haa_joint), 150.0);
  VecNj q = VecNj::Constant(0.5);
  const VecNj all = torque_limits_nm(q);
  for (int j = 0; j < kNj; ++j) EXPECT_EQ(all[j], torque_limit_nm(j, 0.5)) << j;
}
}  // namespace
