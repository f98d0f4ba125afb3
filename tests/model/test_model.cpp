// What holds for any robot's generated model (firmware/model/robots/README.md): its structure,
// the robot file's frames and poses within the model, physical inertias, the torque limits' laws.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include <Eigen/Eigenvalues>

#include "model_fk.hpp"
#include "springbok/model/model.hpp"

namespace {
using namespace springbok;

TEST(Model, LegsThenArmEachAChainFromTheBase) {
  EXPECT_EQ(kNq, 7 + kNj);
  EXPECT_EQ(kNv, 6 + kNj);
  EXPECT_EQ(kFeet * kLegJoints + kArmJoints, kNj);
  for (int foot = 0; foot < kFeet; ++foot) {
    const int first = leg_first_joint(foot);
    EXPECT_EQ(robot::kJoints[static_cast<std::size_t>(first)].parent_body, 0) << foot;
    for (int k = 1; k < kLegJoints; ++k) EXPECT_EQ(robot::kJoints[static_cast<std::size_t>(first + k)].parent_body, first + k);
    EXPECT_EQ(robot::kFrames[static_cast<std::size_t>(kFootFrames[foot])].body, first + kLegJoints) << "the foot on the leg's last body";
  }
  EXPECT_EQ(robot::kJoints[kFirstArmJoint].parent_body, 0);
  for (int j = kFirstArmJoint + 1; j < kNj; ++j) EXPECT_EQ(robot::kJoints[static_cast<std::size_t>(j)].parent_body, j);
  EXPECT_EQ(robot::kFrames[kEeFrame].body, kNj) << "the hand on the arm's last body";
  EXPECT_EQ(robot::kFrames[kWristFtFrame].body, kNj);
  EXPECT_EQ(robot::kFrames[kImuFrame].body, 0);
  for (const auto& j : robot::kJoints) {
    EXPECT_EQ(j.axis[0], 0.0);  // every axis turned to z by urdf2model
    EXPECT_EQ(j.axis[1], 0.0);
    EXPECT_EQ(j.axis[2], 1.0);
  }
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

// A rotor adds I_r a a' to its body: nothing else changes, and a joint's own axis inertia grows
// by exactly I_r.
TEST(Model, RotorsAddAlongTheirAxis) {
  for (int j = 0; j < kNj; ++j) {
    const model::Inertia with = body_inertia(j + 1), without = body_inertia(j + 1, Rotors::none);
    EXPECT_EQ(with.mass_kg, without.mass_kg);
    EXPECT_NEAR(with.inertia_com_kgm2[2] - without.inertia_com_kgm2[2], kRotorInertia_kgm2[static_cast<std::size_t>(j)], 1e-15);
    for (int k : {0, 1, 3, 4, 5}) EXPECT_EQ(with.inertia_com_kgm2[static_cast<std::size_t>(k)], without.inertia_com_kgm2[static_cast<std::size_t>(k)]);
    EXPECT_GE(kRotorInertia_kgm2[static_cast<std::size_t>(j)], 0.0);
  }
  EXPECT_FALSE(robot::kRotorInertiaSource.empty());
}

// The stance and the lying pose are within every joint's range; standing, the feet are below the
// trunk and apart (a support polygon), the lying feet higher than the standing ones.
TEST(Model, StanceAndLyingPose) {
  VecNj stance, lying;
  for (int j = 0; j < kNj; ++j) {
    stance[j] = robot::kStance_rad[static_cast<std::size_t>(j)];
    lying[j] = robot::kLying_rad[static_cast<std::size_t>(j)];
    const auto& l = robot::kJoints[static_cast<std::size_t>(j)].limits;
    if (!l.bounded) continue;
    EXPECT_GE(stance[j], l.lower_rad) << j;
    EXPECT_LE(stance[j], l.upper_rad) << j;
    EXPECT_GE(lying[j], l.lower_rad) << j;
    EXPECT_LE(lying[j], l.upper_rad) << j;
  }
  for (int f = 0; f < kFeet; ++f) {
    const Eigen::Vector3d standing = test::frame_in_trunk(kFootFrames[f], stance).translation();
    const Eigen::Vector3d folded = test::frame_in_trunk(kFootFrames[f], lying).translation();
    EXPECT_LT(standing.z(), -0.2) << f;
    EXPECT_GT(folded.z(), standing.z() + 0.05) << f;
    EXPECT_GT(standing.x() * (f < 2 ? 1.0 : -1.0), 0.0) << f << ": front feet ahead, hind behind";
    EXPECT_GT(standing.y() * (f % 2 == 0 ? 1.0 : -1.0), 0.0) << f << ": left feet left, right right";
  }
  EXPECT_GT(kFootRadius_m, 0.0);
}

// The limit at any angle is within (0, peak]; a flat one is the URDF's effort everywhere; an
// unknown angle gets the smallest over the range; beyond a stop, the stop's.
TEST(Model, TorqueLimits) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  for (int j = 0; j < kNj; ++j) {
    const auto& joint = robot::kJoints[static_cast<std::size_t>(j)];
    const double peak = torque_limit_peak_nm(j);
    double smallest = peak, sampled = 0.0;
    const double lo = joint.limits.bounded ? joint.limits.lower_rad : -3.2;
    const double hi = joint.limits.bounded ? joint.limits.upper_rad : 3.2;
    for (int i = 0; i <= 2000; ++i) {
      const double t = torque_limit_nm(j, lo + (hi - lo) * i / 2000.0);
      EXPECT_GT(t, 0.0) << j;
      EXPECT_LE(t, peak + 1e-12) << j;
      smallest = std::min(smallest, t);
      sampled = std::max(sampled, t);
    }
    EXPECT_NEAR(sampled, peak, 1e-3 * peak) << j;
    EXPECT_NEAR(torque_limit_nm(j, nan), smallest, 1e-9 * peak) << j;
    if (robot::kTorqueLimits[static_cast<std::size_t>(j)].kind == model::TorqueLimit::Kind::flat) {
      EXPECT_EQ(peak, joint.limits.effort_nm) << j;
      EXPECT_EQ(torque_limit_nm(j, nan), joint.limits.effort_nm) << j;
    }
    if (joint.limits.bounded) {
      EXPECT_EQ(torque_limit_nm(j, hi + 0.3), torque_limit_nm(j, hi)) << j;
      EXPECT_EQ(torque_limit_nm(j, lo - 0.3), torque_limit_nm(j, lo)) << j;
    }
  }
  const VecNj q = VecNj::Constant(0.1);
  const VecNj all = torque_limits_nm(q);
  for (int j = 0; j < kNj; ++j) EXPECT_EQ(all[j], torque_limit_nm(j, 0.1)) << j;
}

}  // namespace
