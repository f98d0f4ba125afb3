// FootForceObserver's sum of the external forces on the robot against Newton's law for the
// whole robot, an oracle independent of the mass matrix: a pure translation of the trunk with
// the joints at rest accelerates every body alike, so the external force but gravity is
// m (a + g e_z), m the model's total mass. And the tick allocates nothing.
#include <memory>
#include <random>

#include <gtest/gtest.h>

#include "alloc_trap.hpp"
#include "springbok/estimation/foot_force_observer.hpp"

namespace {
using namespace springbok;

TEST(FootForceObserver, TheExternalForceIsTheWholeRobotsMassTimesItsAccelerationAndWeight) {
  const dyn::Model model;
  auto data = std::make_unique<dyn::Data>();
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> angle(-0.4, 0.4), accel(-3.0, 3.0), joint(-0.3, 0.3);
  const double dt_s = 1e-3;
  for (int trial = 0; trial < 20; ++trial) {
    VecNq q = VecNq::Zero();
    q.head<3>() = Vec3(0.1, -0.2, 0.6);
    const Quat o(Eigen::AngleAxisd(angle(rng), Vec3::UnitZ()) * Eigen::AngleAxisd(angle(rng), Vec3::UnitY()) *
                 Eigen::AngleAxisd(angle(rng), Vec3::UnitX()));
    q.segment<4>(3) = o.coeffs();
    for (int j = 0; j < kNj; ++j) q[7 + j] = joint(rng);
    const Mat3 rotation = o.toRotationMatrix();
    const Vec3 a_world(accel(rng), accel(rng), accel(rng));
    est::FootForceObserver observer;
    VecNv v = VecNv::Zero();
    const VecNj torques = VecNj::Zero(), friction = VecNj::Zero();
    dyn::compute_tick(model, *data, q, v);
    observer.update(*data, v, rotation, torques, friction, dt_s);  // primes the difference
    v.head<3>() = rotation.transpose() * a_world * dt_s;           // trunk frame, as v_B
    dyn::compute_tick(model, *data, q, v);
    const std::size_t allocations =
        test::count_allocations([&] { observer.update(*data, v, rotation, torques, friction, dt_s); });
    EXPECT_EQ(allocations, 0u);
    const Vec3 expected = model.total_mass_kg * (a_world + kGravity_m_s2 * Vec3::UnitZ());
    EXPECT_LT((observer.external_force_world_n() - expected).norm(), 1e-9 * expected.norm()) << "trial " << trial;
  }
}

}  // namespace
