// Bullet's robot against springbok::dynamics (an independent implementation
// of the same model): free-flight accelerations for random states and torques,
// with and without gravity, and the response to a force at the end-effector
// with the base fixed.
#include <cstdio>
#include <random>

#include <Eigen/Cholesky>
#include <gtest/gtest.h>

#include "sim_test_util.hpp"
#include "springbok/dynamics/dynamics.hpp"
#include "springbok/sim_hal/bullet_robot.hpp"

namespace {
using namespace springbok;

VecNq random_q(std::mt19937_64& rng) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  VecNq q;
  q.head<3>() = Vec3(u(rng), u(rng), 1.0 + u(rng));
  q.segment<4>(3) = Eigen::Vector4d(u(rng), u(rng), u(rng), u(rng)).normalized();
  for (int j = 0; j < kNj; ++j) {
    const auto& lim = robot::kJoints[j].limits;
    const double lo = lim.bounded ? lim.lower_rad + 0.1 : -3.0;
    const double hi = lim.bounded ? lim.upper_rad - 0.1 : 3.0;
    q[7 + j] = lo + (hi - lo) * 0.5 * (1.0 + u(rng));
  }
  return q;
}

template <int N>
Vec<N> random_vec(std::mt19937_64& rng, double scale) {
  std::normal_distribution<double> n(0.0, scale);
  Vec<N> v;
  for (int i = 0; i < N; ++i) v[i] = n(rng);
  return v;
}

sim::SimConfig free_flight(const VecNq& q, const VecNv& v, double gravity) {
  sim::SimConfig c;
  c.ground = false;
  c.saturate_torques = false;
  c.gravity_m_s2 = gravity;
  c.initial_q = q;
  c.initial_v = v;
  return c;
}

// Free flight: physical input has no base force; the joints get random torques.
double worst_free_flight_error(double gravity, int states, std::uint64_t seed) {
  dyn::Model model;
  model.gravity_world_m_s2 = Vec3(0.0, 0.0, -gravity);
  auto data = std::make_unique<dyn::Data>();
  std::mt19937_64 rng(seed);
  double worst = 0.0;
  for (int i = 0; i < states; ++i) {
    const VecNq q = random_q(rng);
    const VecNv v = random_vec<kNv>(rng, 1.0);
    VecNv tau = VecNv::Zero();
    tau.tail<kNj>() = random_vec<kNj>(rng, 10.0);
    const MatNv m = dyn::crba(model, *data, q);
    const VecNv h = dyn::nonlinear_effects(model, *data, q, v);
    const VecNv expected = m.ldlt().solve(tau - h);

    sim::BulletRobot robot(free_flight(q, v, gravity));
    EXPECT_TRUE(robot.configure().ok);
    EXPECT_TRUE(robot.activate().ok);
    hal::JointCommands cmd;
    cmd.mode = hal::CommandMode::enabled;
    cmd.tau_ff_nm = tau.tail<kNj>();
    EXPECT_EQ(robot.write(cmd), hal::IoStatus::ok);
    const VecNq q0 = robot.ground_truth().q;
    const VecNv v0 = robot.ground_truth().v;
    robot.step();
    const VecNv a = test::acceleration_from_step(q0, v0, robot.ground_truth().q, robot.ground_truth().v,
                                                 robot.config().step_s);
    const double err = (a - expected).cwiseAbs().maxCoeff() / std::max(1.0, expected.cwiseAbs().maxCoeff());
    EXPECT_LT(err, 1e-8) << "state " << i << "\nbullet   " << a.transpose() << "\ndynamics " << expected.transpose();
    worst = std::max(worst, err);
  }
  return worst;
}

TEST(SimVsDynamics, FreeFlightWithGravity) {
  const double worst = worst_free_flight_error(kGravity_m_s2, 20, 7);
  std::printf("free flight, gravity: worst relative error of Bullet vs M^-1 (tau - h): %.3g\n", worst);
}

TEST(SimVsDynamics, FreeFlightWithoutGravity) {
  const double worst = worst_free_flight_error(0.0, 20, 8);
  std::printf("free flight, no gravity: worst relative error of Bullet vs M^-1 (tau - h): %.3g\n", worst);
}

TEST(SimVsDynamics, EndEffectorForceWithTheBaseFixed) {
  const dyn::Model model;
  auto data = std::make_unique<dyn::Data>();
  std::mt19937_64 rng(11);
  const auto ee = sim::find_frame("arm_end_effector_link");
  ASSERT_TRUE(ee.has_value());
  double worst = 0.0;
  for (int i = 0; i < 10; ++i) {
    VecNq q = random_q(rng);
    VecNv v = VecNv::Zero();
    v.tail<kNj>() = random_vec<kNj>(rng, 0.5);
    const Vec3 force_n = random_vec<3>(rng, 30.0);
    // Base fixed: only the joint rows and columns move, M_jj qdd = J_j^T F - h_j.
    const MatNv m = dyn::crba(model, *data, q);
    const VecNv h = dyn::nonlinear_effects(model, *data, q, v);
    dyn::point_jacobians(model, *data, q);
    const VecNj generalized = data->J_ee.topRows<3>().rightCols<kNj>().transpose() * force_n - h.tail<kNj>();
    const VecNj expected = m.bottomRightCorner<kNj, kNj>().ldlt().solve(generalized);

    sim::SimConfig c = free_flight(q, v, kGravity_m_s2);
    c.fixed_base = true;
    sim::BulletRobot robot(c);
    ASSERT_TRUE(robot.configure().ok);
    sim::ExternalWrench push;
    push.frame = *ee;
    push.axis_world = force_n.normalized();
    push.profile = {sim::ProfileShape::constant, force_n.norm()};
    ASSERT_TRUE(robot.add_external_wrench(push));
    ASSERT_TRUE(robot.activate().ok);
    const VecNv v0 = robot.ground_truth().v;
    robot.step();
    const VecNj a = (robot.ground_truth().v.tail<kNj>() - v0.tail<kNj>()) / robot.config().step_s;
    const double err = (a - expected).cwiseAbs().maxCoeff() / std::max(1.0, expected.cwiseAbs().maxCoeff());
    EXPECT_LT(err, 1e-8) << "state " << i << "\nbullet   " << a.transpose() << "\ndynamics " << expected.transpose();
    worst = std::max(worst, err);
    // The wrist sensor sees the push (the F/T frame is the EE frame), in its own axes.
    hal::Measurements meas;
    ASSERT_EQ(robot.read(meas), hal::IoStatus::ok);
    const Mat3 r_ee = robot.frame_placement(*ee).linear();
    EXPECT_LT((r_ee * meas.wrist.force_n - force_n).norm(), 1e-9);
    EXPECT_LT(meas.wrist.torque_nm.norm(), 1e-9);
  }
  std::printf("EE force, fixed base: worst relative error of Bullet vs M^-1 (J^T F - h): %.3g\n", worst);
}

}  // namespace
