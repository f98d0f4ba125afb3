// The trot: the schedule's timing (duty factor, diagonal pairs, the four-feet
// overlap), the swing trajectory against finite differences and its end
// conditions, the foothold correction, the pattern's shift and the trunk's tilt,
// the static ZMP against moment balance, config errors, no allocation.
#include <cmath>

#include <Eigen/Geometry>

#include <gtest/gtest.h>

#include "alloc_trap.hpp"
#include "springbok/gait/trot.hpp"

namespace {
using namespace springbok;

std::array<Vec3, kFeet> nominal() {
  return {Vec3(0.37, 0.3, -0.6), Vec3(0.37, -0.3, -0.6), Vec3(-0.37, 0.3, -0.6), Vec3(-0.37, -0.3, -0.6)};
}

TEST(Trot, ProfilesMatchTheirDerivativesAndEndConditions) {
  for (auto profile : {&gait::quintic_blend, &gait::swing_bump}) {
    const double h = 1e-6;
    for (double s = 0.01; s < 1.0; s += 0.049) {
      const gait::Profile p = profile(s), lo = profile(s - h), hi = profile(s + h);
      EXPECT_NEAR(p.rate, (hi.value - lo.value) / (2 * h), 1e-6);
      EXPECT_NEAR(p.curvature, (hi.rate - lo.rate) / (2 * h), 1e-5);
    }
    for (double s : {0.0, 1.0}) {
      EXPECT_EQ(profile(s).rate, 0.0);
      EXPECT_NEAR(profile(s).curvature, 0.0, 1e-12);
    }
  }
  EXPECT_EQ(gait::quintic_blend(0.0).value, 0.0);
  EXPECT_EQ(gait::quintic_blend(1.0).value, 1.0);
  EXPECT_EQ(gait::swing_bump(0.5).value, 1.0);
  EXPECT_EQ(gait::swing_bump(1.0).value, 0.0);
}

TEST(Trot, ScheduleKeepsTheDutyFactorAndTheDiagonals) {
  for (const auto& [fs, df] : std::vector<std::pair<double, double>>{{1.4, 0.55}, {1.4, 0.65}, {1.8, 0.55}, {1.8, 0.65}}) {
    gait::TrotParams p;
    p.step_frequency_hz = fs;
    p.duty_factor = df;
    gait::TrotGait trot(p);
    trot.start(nominal());
    const double dt = 1e-4, duration = 10.0 / fs;  // ten whole cycles
    std::array<int, kFeet> stance_ticks{};
    int all_four = 0, ticks = 0;
    for (double t = 0.0; t < duration - dt / 2; t += dt, ++ticks) {
      const gait::ContactPlan& plan = trot.update(t, nominal(), Vec3::Zero());
      for (int f = 0; f < kFeet; ++f) stance_ticks[f] += plan.stance[f] ? 1 : 0;
      EXPECT_EQ(plan.stance[0], plan.stance[3]) << "lf and rh move together";
      EXPECT_EQ(plan.stance[1], plan.stance[2]) << "rf and lh move together";
      EXPECT_TRUE(plan.stance[0] || plan.stance[1]) << "never more than one pair in the air";
      all_four += plan.stance[0] && plan.stance[1] ? 1 : 0;
    }
    for (int f = 0; f < kFeet; ++f) EXPECT_NEAR(static_cast<double>(stance_ticks[f]) / ticks, df, 2e-3);
    EXPECT_NEAR(static_cast<double>(all_four) / ticks, 2.0 * (df - 0.5), 2e-3);
  }
}

TEST(Trot, SwingGoesFromLiftOffToTheFootholdSmoothly) {
  gait::TrotParams p;
  p.step_frequency_hz = 1.4;
  p.duty_factor = 0.6;
  p.step_height_m = 0.1;
  p.touchdown_depth_m = 0.004;
  gait::TrotGait trot(p);
  trot.start(nominal());
  std::array<Vec3, kFeet> feet = nominal();
  feet[0] += Vec3(0.02, -0.01, 0.0);  // lf lifts off from here
  const Vec3 v_base(0.1, -0.05, 0.0);
  const double t_lift = p.duty_factor / p.step_frequency_hz, t_swing = trot.swing_duration_s();
  (void)trot.update(t_lift - 1e-9, feet, v_base);
  ASSERT_TRUE(trot.plan().stance[0]);
  const gait::SwingReference first = trot.update(t_lift + 1e-12, feet, v_base).swing[0];
  ASSERT_FALSE(trot.plan().stance[0]);
  EXPECT_LT((first.position_m - feet[0]).norm(), 1e-9);
  EXPECT_LT(first.velocity_m_s.norm(), 1e-6);
  // The foothold: nominal + T_stance / 2 * v_xy, touchdown_depth below.
  const Vec3 foothold = nominal()[0] + Vec3(0.5 * trot.stance_duration_s() * 0.1, 0.5 * trot.stance_duration_s() * -0.05,
                                             -0.004);
  const gait::SwingReference last = trot.update(t_lift + t_swing * (1 - 1e-9), feet, v_base).swing[0];
  EXPECT_LT((last.position_m - foothold).norm(), 1e-6);
  EXPECT_LT(last.velocity_m_s.norm(), 1e-6);
  // The foothold is re-planned on every tick of the swing from that tick's velocity (the
  // lift-off point stays): the trunk stopped, the foot lands under the hip.
  const gait::SwingReference stopped = trot.update(t_lift + t_swing * (1 - 1e-9), feet, Vec3::Zero()).swing[0];
  EXPECT_LT((stopped.position_m - (nominal()[0] - Vec3(0.0, 0.0, 0.004))).norm(), 1e-6);
  // Mid-swing: the step height above the straight line; velocity and acceleration by differences.
  const double tm = t_lift + 0.5 * t_swing;
  const gait::SwingReference mid = trot.update(tm, feet, v_base).swing[0];
  EXPECT_NEAR(mid.position_m.z() - 0.5 * (feet[0].z() + foothold.z()), 0.1, 1e-9);
  const double h = 1e-5;
  const Vec3 p_lo = trot.update(tm - h, feet, v_base).swing[0].position_m;
  const Vec3 v_lo = trot.plan().swing[0].velocity_m_s;
  const Vec3 p_hi = trot.update(tm + h, feet, v_base).swing[0].position_m;
  const Vec3 v_hi = trot.plan().swing[0].velocity_m_s;
  EXPECT_LT((mid.velocity_m_s - (p_hi - p_lo) / (2 * h)).norm(), 1e-6);
  EXPECT_LT((mid.acceleration_m_s2 - (v_hi - v_lo) / (2 * h)).norm(), 1e-4);
}

// With a pattern shift s and the trunk tilted by R_t, the swing runs in the
// horizontal frame H: the foothold is nominal + s (minus the touch-down depth) in H,
// the bump is along H's z, and the references handed out are R_t^T times those.
TEST(Trot, FootholdsShiftAndTiltLiveInTheHorizontalFrame) {
  gait::TrotParams p;
  p.step_frequency_hz = 1.4;
  p.duty_factor = 0.55;
  p.step_height_m = 0.08;
  p.touchdown_depth_m = 0.005;
  gait::TrotGait trot(p);
  trot.start(nominal());
  EXPECT_LT(trot.nominal_centre_h().head<2>().norm(), 1e-12);
  EXPECT_NEAR(trot.nominal_centre_h().z(), -0.6, 1e-12);
  const Vec3 shift(0.07, 0.015, 0.01);
  const Mat3 tilt = (Eigen::AngleAxisd(0.08, Vec3::UnitX()) * Eigen::AngleAxisd(-0.05, Vec3::UnitY())).toRotationMatrix();
  // rf (offset 0.5) first lifts off at cycle 0.05: its swing runs over cycles [0.05, 0.5).
  const double t_lift = 0.05 / p.step_frequency_hz, t_swing = trot.swing_duration_s();
  (void)trot.update(t_lift - 1e-9, nominal(), Vec3::Zero(), shift, tilt);
  ASSERT_TRUE(trot.plan().stance[1]);
  const gait::SwingReference first = trot.update(t_lift + 1e-12, nominal(), Vec3::Zero(), shift, tilt).swing[1];
  ASSERT_FALSE(trot.plan().stance[1]);
  EXPECT_LT((first.position_m - tilt.transpose() * nominal()[1]).norm(), 1e-9) << "lift-off: where the foot is (H)";
  const Vec3 foothold_h = nominal()[1] + shift - Vec3(0.0, 0.0, 0.005);
  const gait::SwingReference last =
      trot.update(t_lift + t_swing * (1 - 1e-9), nominal(), Vec3::Zero(), shift, Mat3::Identity()).swing[1];
  EXPECT_LT((last.position_m - foothold_h).norm(), 1e-6);
  // The foothold follows this tick's shift (re-planned on every tick of the swing).
  const gait::SwingReference moved =
      trot.update(t_lift + t_swing * (1 - 1e-9), nominal(), Vec3::Zero(), Vec3(0.3, 0.3, 0.3), Mat3::Identity()).swing[1];
  EXPECT_LT((moved.position_m - (nominal()[1] + Vec3(0.3, 0.3, 0.3 - 0.005))).norm(), 1e-6);
  const gait::SwingReference mid = trot.update(t_lift + 0.5 * t_swing, nominal(), Vec3::Zero(), shift, tilt).swing[1];
  const Vec3 mid_h = tilt * mid.position_m;
  EXPECT_NEAR(mid_h.z() - 0.5 * (nominal()[1].z() + foothold_h.z()), p.step_height_m, 1e-9);
  EXPECT_NEAR(mid_h.x(), nominal()[1].x() + 0.5 * shift.x(), 1e-9);
  EXPECT_NEAR(mid_h.y(), nominal()[1].y() + 0.5 * shift.y(), 1e-9);
  EXPECT_LT((tilt * mid.velocity_m_s - Vec3(1.875 * shift.x(), 1.875 * shift.y(), 1.875 * (shift.z() - 0.005)) / t_swing).norm(),
            1e-9)
      << "the quintic's mid-swing rate 30/16 times the span, the bump's rate 0 at mid-swing";
}

// The static ZMP: the weight at c and the wrench (F, T) at p have no horizontal
// moment about it (the moment-balance oracle, by cross products).
TEST(Trot, StaticZmpBalancesTheMoments) {
  const Vec3 com(0.075, 0.013, 0.63);
  const double weight = 94.824 * 9.81;
  const Vec3 point(0.62, 0.05, 0.95);
  const double ground = 0.0217;
  EXPECT_LT((gait::static_zmp(com, weight, point, Vec3::Zero(), Vec3::Zero(), ground).head<2>() - com.head<2>()).norm(),
            1e-15);
  for (const auto& [force, torque] : {std::pair{Vec3(50, 0, 0), Vec3(0, 0, 0)}, std::pair{Vec3(-20, 35, 60), Vec3(3, -4, 1)},
                                      std::pair{Vec3(10, -5, -200), Vec3(-2, 0.5, 7)}}) {
    const Vec3 zmp = gait::static_zmp(com, weight, point, force, torque, ground);
    EXPECT_EQ(zmp.z(), ground);
    const Vec3 moment = (com - zmp).cross(Vec3(0, 0, -weight)) + (point - zmp).cross(force) + torque;
    EXPECT_LT(moment.head<2>().norm(), 1e-9 * weight) << force.transpose();
  }
  // 50 N forward at 0.93 m above the ground moves it forward by 0.93 * 50 / W.
  EXPECT_NEAR(gait::static_zmp(com, weight, point, Vec3(50, 0, 0), Vec3::Zero(), 0.02).x() - com.x(), 0.93 * 50 / weight,
              1e-12);
  // A load that lifts the robot (F_z >= W) has no ZMP: the COM's projection.
  EXPECT_TRUE((gait::static_zmp(com, weight, point, Vec3(5, 5, weight), Vec3::Zero(), ground).head<2>() - com.head<2>()).isZero(0.0));
}

TEST(Trot, UpdateDoesNotAllocate) {
  gait::TrotGait trot(gait::TrotParams{});
  trot.start(nominal());
  test::AllocationTrap trap;
  const Mat3 tilt(Eigen::AngleAxisd(0.05, Vec3::UnitX()));
  for (int k = 0; k < 3000; ++k) (void)trot.update(k * 1e-3, nominal(), Vec3::Zero(), Vec3(0.05, 0.01, 0.0), tilt);
  EXPECT_EQ(trap.disarm(), 0u);
}

}  // namespace
