// The Bullet robot against the independent reference states (RBDL, checked
// by a second implementation): frame placements, and forward dynamics in free
// flight (one Bullet step from (q, v) under tau_aba vs vdot_aba = M^-1 (tau_aba - h)).
#include <cstdio>
#include <string>

#include <gtest/gtest.h>

#include "sim_test_util.hpp"
#include "springbok/sim_hal/bullet_robot.hpp"
#include "test_data.hpp"

namespace {
using namespace springbok;

constexpr int kStates = 10;

std::string state_path(int i) {
  char name[64];
  std::snprintf(name, sizeof name, "reference/hyq_gen3/state_%03d.txt", i);
  return (springbok::test::data_dir() / name).string();
}

sim::SimConfig free_flight(const VecNq& q, const VecNv& v) {
  sim::SimConfig c;
  c.ground = false;
  c.saturate_torques = false;
  c.rotors = Rotors::none;  // the reference states' robot: the URDF alone
  c.initial_q = q;
  c.initial_v = v;
  return c;
}

TEST(SimReference, FramePlacementsMatchTheReference) {
  const char* names[] = {"lf_foot", "rf_foot", "lh_foot", "rh_foot"};
  double worst_m = 0.0;
  for (int i = 0; i < kStates; ++i) {
    auto ref = test::read_reference_state(state_path(i));
    ASSERT_EQ(ref.count("q"), 1u) << state_path(i);
    const VecNq q = ref["q"].transpose();
    sim::BulletRobot robot(free_flight(q, VecNv::Zero()));
    ASSERT_TRUE(robot.configure().ok);
    for (int f = 0; f < kFeet; ++f) {
      const Vec3 p = robot.frame_placement(*sim::find_frame(names[f])).translation();
      const Vec3 expected = ref[std::string("p_") + names[f]].transpose();
      worst_m = std::max(worst_m, (p - expected).norm());
    }
    const auto ee = robot.frame_placement(*sim::find_frame("arm_end_effector_link"));
    worst_m = std::max(worst_m, (ee.translation() - Vec3(ref["p_ee"].transpose())).norm());
    EXPECT_LT((ee.linear() - ref["R_ee"]).norm(), 1e-9) << "state " << i;
    // Ground truth reads the same state back.
    EXPECT_LT((robot.ground_truth().q - q).norm(), 1e-12) << "state " << i;
  }
  EXPECT_LT(worst_m, 1e-9);
  std::printf("worst frame position error vs reference: %.3g m\n", worst_m);
}

TEST(SimReference, FreeFlightAccelerationsMatchTheReference) {
  double worst_rel = 0.0;
  for (int i = 0; i < kStates; ++i) {
    auto ref = test::read_reference_state(state_path(i));
    const VecNq q = ref["q"].transpose();
    const VecNv v = ref["v"].transpose();
    const VecNv tau = ref["tau_aba"].transpose();
    const VecNv expected = ref["vdot_aba"].transpose();
    sim::BulletRobot robot(free_flight(q, v));
    ASSERT_TRUE(robot.configure().ok);
    ASSERT_TRUE(robot.activate().ok);
    test::add_base_wrench(robot, q, tau.head<6>());
    hal::JointCommands cmd;
    cmd.mode = hal::CommandMode::enabled;
    cmd.tau_ff_nm = tau.tail<kNj>();
    ASSERT_EQ(robot.write(cmd), hal::IoStatus::ok);
    const VecNq q0 = robot.ground_truth().q;
    const VecNv v0 = robot.ground_truth().v;
    robot.step();
    const VecNv a = test::acceleration_from_step(q0, v0, robot.ground_truth().q, robot.ground_truth().v,
                                                 robot.config().step_s);
    const double rel = (a - expected).cwiseAbs().maxCoeff() / std::max(1.0, expected.cwiseAbs().maxCoeff());
    worst_rel = std::max(worst_rel, rel);
    EXPECT_LT(rel, 1e-8) << "state " << i << "\nbullet " << a.transpose() << "\nref    " << expected.transpose();
  }
  std::printf("worst relative acceleration error vs reference vdot_aba: %.3g\n", worst_rel);
}

}  // namespace
