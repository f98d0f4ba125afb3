// Pure unit tests of the simulator's helpers (no Bullet world): principal
// inertia frames, force profiles, frame names.
#include <cmath>

#include <gtest/gtest.h>

#include "springbok/sim_hal/external_wrench.hpp"
#include "springbok/sim_hal/principal_inertia.hpp"

namespace {
using namespace springbok;

TEST(PrincipalInertia, ReproducesEveryBodyTensorWithAProperRotation) {
  for (int b = 0; b < kNb; ++b) {
    const auto& inertia = b == 0 ? robot::kBaseInertia : robot::kJoints[b - 1].inertia;
    const sim::PrincipalInertia p = sim::principal_inertia(inertia);
    const Mat3 tensor = sim::inertia_tensor(inertia);
    const Mat3 rebuilt = p.rotation * p.moments_kgm2.asDiagonal() * p.rotation.transpose();
    EXPECT_LT((rebuilt - tensor).norm(), 1e-14 * (1.0 + tensor.norm())) << "body " << b;
    EXPECT_LT((p.rotation.transpose() * p.rotation - Mat3::Identity()).norm(), 1e-14) << "body " << b;
    EXPECT_NEAR(p.rotation.determinant(), 1.0, 1e-14) << "body " << b;
    EXPECT_GT(p.moments_kgm2.minCoeff(), 0.0) << "body " << b;
    // Principal moments of a physical body satisfy the triangle inequality.
    EXPECT_GE(p.moments_kgm2[0] + p.moments_kgm2[1], p.moments_kgm2[2] * (1.0 - 1e-12)) << "body " << b;
  }
}

TEST(ForceProfile, StepAndImpulseAreBoxes) {
  sim::ForceProfile step{sim::ProfileShape::step, 50.0, 1.0};
  EXPECT_EQ(sim::profile_value(step, 0.999), 0.0);
  EXPECT_EQ(sim::profile_value(step, 1.0), 50.0);
  EXPECT_EQ(sim::profile_value(step, 1e6), 50.0);
  sim::ForceProfile impulse{sim::ProfileShape::impulse, 200.0, 0.5, 0.01};
  double impulse_ns = 0.0;
  const double dt = 1e-3;
  for (int k = 0; k < 2000; ++k) impulse_ns += sim::profile_value(impulse, k * dt) * dt;
  EXPECT_NEAR(impulse_ns, 2.0, 1e-9);  // amplitude * duration
}

TEST(ForceProfile, ChirpSweepsLinearlyFromStartToEndFrequency) {
  // 0 -> 5 Hz over 4 s: the phase gains integral f dt = 10 cycles, i.e. 20 zero crossings.
  const sim::ForceProfile chirp{sim::ProfileShape::chirp, 20.0, 2.0, 4.0, 0.0, 5.0};
  int crossings = 0;
  double previous = 0.0;
  double peak = 0.0;
  const double dt = 1e-5;
  double last_crossing = 0.0, spacing = 0.0;
  for (double t = 2.0 + dt; t < 6.0; t += dt) {
    const double s = sim::profile_value(chirp, t);
    peak = std::max(peak, std::abs(s));
    if (previous != 0.0 && (s > 0.0) != (previous > 0.0)) {
      ++crossings;
      spacing = t - last_crossing;
      last_crossing = t;
    }
    previous = s;
  }
  EXPECT_NEAR(crossings, 20, 1);
  EXPECT_NEAR(peak, 20.0, 1e-3);
  // The last half period matches the instantaneous frequency f(tau) = 5 tau / 4 at its middle.
  const double tau_mid = last_crossing - 0.5 * spacing - 2.0;
  EXPECT_NEAR(1.0 / (2.0 * spacing), 5.0 * tau_mid / 4.0, 0.01);
  EXPECT_GT(tau_mid, 3.8);
  EXPECT_EQ(sim::profile_value(chirp, 1.9), 0.0);
  EXPECT_EQ(sim::profile_value(chirp, 6.0), 0.0);
}

TEST(FindFrame, KnowsLinksAndFixedFrames) {
  EXPECT_EQ(sim::find_frame("trunk")->body, 0);
  EXPECT_EQ(sim::find_frame("lf_lowerleg")->body, 3);
  const auto ee = sim::find_frame("arm_end_effector_link");
  ASSERT_TRUE(ee.has_value());
  EXPECT_EQ(ee->body, robot::kFrames[kEeFrame].body);
  EXPECT_NEAR(ee->placement.translation[2], -0.061525, 1e-9);
  EXPECT_FALSE(sim::find_frame("no_such_frame").has_value());
}

}  // namespace
