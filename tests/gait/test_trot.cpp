// The trot: the schedule's timing (duty factor, diagonal pairs, the four-feet
// overlap), the swing trajectory against finite differences and its end
// conditions, the foothold correction, the pattern's shift and the trunk's tilt,
// the static ZMP against moment balance, config errors, no allocation; touch-down
// detection on a recorded touch-down (early, and the same trace late) and the force ramps.
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>

#include <Eigen/Geometry>

#include <gtest/gtest.h>

#include "alloc_trap.hpp"
#include "springbok/dynamics/dynamics.hpp"
#include "springbok/gait/trot.hpp"

namespace {
using namespace springbok;

std::array<Vec3, kFeet> nominal() {
  return {Vec3(0.37, 0.3, -0.6), Vec3(0.37, -0.3, -0.6), Vec3(-0.37, 0.3, -0.6), Vec3(-0.37, -0.3, -0.6)};
}

// Trot parameters at step frequency `fs` and duty factor `df`; the swing's step height and
// touch-down depth given, or the defaults.
gait::TrotParams trot_params(double fs, double df, double step_height_m = gait::TrotParams{}.step_height_m,
                             double touchdown_depth_m = gait::TrotParams{}.touchdown_depth_m) {
  gait::TrotParams p;
  p.step_frequency_hz = fs;
  p.duty_factor = df;
  p.step_height_m = step_height_m;
  p.touchdown_depth_m = touchdown_depth_m;
  return p;
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
    gait::TrotGait trot(trot_params(fs, df));
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
  const gait::TrotParams p = trot_params(1.4, 0.6, 0.1, 0.004);
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
  const gait::TrotParams p = trot_params(1.4, 0.55, 0.08, 0.005);
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
  EXPECT_LT((dyn::static_zmp(com, weight, point, Vec3::Zero(), Vec3::Zero(), ground).head<2>() - com.head<2>()).norm(),
            1e-15);
  for (const auto& [force, torque] : {std::pair{Vec3(50, 0, 0), Vec3(0, 0, 0)}, std::pair{Vec3(-20, 35, 60), Vec3(3, -4, 1)},
                                      std::pair{Vec3(10, -5, -200), Vec3(-2, 0.5, 7)}}) {
    const Vec3 zmp = dyn::static_zmp(com, weight, point, force, torque, ground);
    EXPECT_EQ(zmp.z(), ground);
    const Vec3 moment = (com - zmp).cross(Vec3(0, 0, -weight)) + (point - zmp).cross(force) + torque;
    EXPECT_LT(moment.head<2>().norm(), 1e-9 * weight) << force.transpose();
  }
  // 50 N forward at 0.93 m above the ground moves it forward by 0.93 * 50 / W.
  EXPECT_NEAR(dyn::static_zmp(com, weight, point, Vec3(50, 0, 0), Vec3::Zero(), 0.02).x() - com.x(), 0.93 * 50 / weight,
              1e-12);
  // A load that lifts the robot (F_z >= W) has no ZMP: the COM's projection.
  EXPECT_TRUE((dyn::static_zmp(com, weight, point, Vec3(5, 5, weight), Vec3::Zero(), ground).head<2>() - com.head<2>()).isZero(0.0));
  // A force G at the centre of mass too (an unmeasured push): the same balance of moments.
  for (const auto& [force, g] : {std::pair{Vec3(0, 0, 0), Vec3(0, 120, 0)}, std::pair{Vec3(-20, 35, 60), Vec3(200, -40, 30)},
                                 std::pair{Vec3(10, -5, -200), Vec3(-80, 60, -100)}}) {
    const Vec3 torque(1, -2, 0.5);
    const Vec3 zmp = dyn::static_zmp(com, weight, point, force, torque, ground, g);
    const Vec3 moment = (com - zmp).cross(Vec3(0, 0, -weight) + g) + (point - zmp).cross(force) + torque;
    EXPECT_LT(moment.head<2>().norm(), 1e-9 * weight) << g.transpose();
  }
  // 120 N sideways at the COM moves it by the COM's height * 120 / W.
  EXPECT_NEAR(dyn::static_zmp(com, weight, point, Vec3::Zero(), Vec3::Zero(), 0.02, Vec3(0, 120, 0)).y() - com.y(),
              (0.63 - 0.02) * 120 / weight, 1e-12);
}

// ---- touch-down detection and force ramps ------------------------------------------

// The estimated normal force on a foot around a touch-down, recorded in the shipped
// trot_me10_gp1 (springbok-sim log, rf_fz_estimated_n, one value per 1 ms tick from the
// tick the sphere first touched): the impact, a dip as the leg rebounds, the load.
constexpr std::array<double, 19> kRecordedTouchdown_n{13.3, 41.0, 38.5, 32.9, 27.7, 24.5, 26.4, 30.8, 36.8, 44.1,
                                                      53.0, 63.2, 74.4, 86.4, 99.1, 112.3, 126.0, 140.0, 154.4};

// A trot driven tick by tick, with the evidence for foot 0 (lf) scripted: the other feet
// read 230 N from 3 ms before their scheduled touch-down (they land a little early, as
// in the simulator) to their lift-off, 0 in the air.
struct Scripted {
  gait::TrotParams params;
  gait::TrotGait trot;
  double t_s = 0.0;
  static constexpr double kDt = 1e-3;
  explicit Scripted(double fs = 1.4, double df = 0.55) : params(trot_params(fs, df)), trot(params) {
    trot.start(nominal());
  }
  bool scheduled_stance(int f, double t) const {
    static constexpr std::array<double, kFeet> offset{0.0, 0.5, 0.5, 0.0};
    double phase = t * params.step_frequency_hz - offset[f];
    phase -= std::floor(phase);
    return phase < params.duty_factor;
  }
  // One tick with `lf_n` on foot 0.
  const gait::ContactPlan& tick(double lf_n) {
    gait::ContactSense sense;
    sense.valid = true;
    for (int f = 1; f < kFeet; ++f) sense.normal_force_n[f] = on_ground(f, t_s) ? 230.0 : 0.0;
    sense.normal_force_n[0] = lf_n;
    const gait::ContactPlan& plan = trot.update(t_s, nominal(), Vec3::Zero(), Vec3::Zero(), Mat3::Identity(),
                                                Vec3::Zero(), 0.0, &sense);
    t_s += kDt;
    return plan;
  }
  bool on_ground(int f, double t) const { return scheduled_stance(f, t) || scheduled_stance(f, t + 0.003); }
  // Ticks until the time t (exclusive), lf reading as the others do.
  void run_until(double t) {
    while (t_s < t - kDt / 2) tick(on_ground(0, t_s) ? 230.0 : 0.0);
  }
  double liftoff_s(int cycle) const { return (cycle + params.duty_factor) / params.step_frequency_hz; }
  double touchdown_s(int cycle) const { return (cycle + 1.0) / params.step_frequency_hz; }
};

TEST(Touchdown, AnEarlyTouchDownIsStanceFromItsSecondTickAboveTheThreshold) {
  Scripted s;
  const double swing = s.trot.swing_duration_s();
  s.run_until(s.liftoff_s(1) + 0.9 * swing);  // lf at 90 % of its swing
  const std::uint64_t early_before = s.trot.plan().early_touchdowns;
  ASSERT_FALSE(s.trot.plan().stance[0]);
  ASSERT_EQ(s.trot.plan().foot[0], gait::FootPhase::swing);
  EXPECT_FALSE(s.tick(kRecordedTouchdown_n[0]).stance[0]);  // 13.3 N: below 25 N
  EXPECT_FALSE(s.tick(kRecordedTouchdown_n[1]).stance[0]);  // 41 N: the first tick above
  const gait::ContactPlan& plan = s.tick(kRecordedTouchdown_n[2]);  // 38.5 N: the second
  EXPECT_TRUE(plan.stance[0]);
  EXPECT_EQ(plan.foot[0], gait::FootPhase::landed_early);
  EXPECT_EQ(plan.early_touchdowns, early_before + 1);
  // The dip below the threshold (24.5 N) does not lift it again; the schedule's stance takes over.
  for (std::size_t i = 3; i < kRecordedTouchdown_n.size(); ++i) EXPECT_TRUE(s.tick(kRecordedTouchdown_n[i]).stance[0]);
  s.run_until(s.touchdown_s(1) + 0.01);
  EXPECT_EQ(s.trot.plan().foot[0], gait::FootPhase::stance);
  EXPECT_EQ(s.trot.plan().late_touchdowns, 0u);  // nobody was late
  // It lifts off by the schedule.
  s.run_until(s.liftoff_s(2) + 0.002);
  EXPECT_FALSE(s.trot.plan().stance[0]);
}

TEST(Touchdown, ForceInTheFirstHalfOfTheSwingIsNotATouchDown) {
  Scripted s;
  s.run_until(s.liftoff_s(1) + 0.3 * s.trot.swing_duration_s());
  for (double f : kRecordedTouchdown_n) {  // a scuff at 30-36 % of the swing
    EXPECT_FALSE(s.tick(f).stance[0]);
    EXPECT_EQ(s.trot.plan().foot[0], gait::FootPhase::swing);
  }
}

TEST(Touchdown, ALateFootReachesDownUntilItTouches) {
  Scripted s;
  // lf reads 0 N from its lift-off; its stance is due at touchdown_s(1).
  s.run_until(s.liftoff_s(1) + 0.01);
  while (s.t_s < s.touchdown_s(1) - Scripted::kDt / 2) s.tick(0.0);
  const gait::ContactPlan& due = s.tick(0.0);
  EXPECT_FALSE(due.stance[0]);
  EXPECT_EQ(due.foot[0], gait::FootPhase::late);
  EXPECT_EQ(due.late_touchdowns, 1u);  // lf's, the only one
  const Vec3 foothold = due.swing[0].position_m;  // the foothold itself on the first late tick
  EXPECT_LT((foothold - (nominal()[0] - Vec3(0, 0, s.params.touchdown_depth_m))).norm(), 1e-9);
  // Reaching down at kLateTouchdownSpeed_m_s, for 15 ms (the ground is lower than planned).
  for (int k = 1; k < 15; ++k) {
    const gait::ContactPlan& p = s.tick(0.0);
    ASSERT_FALSE(p.stance[0]);
    EXPECT_NEAR(p.swing[0].position_m.z(), foothold.z() - gait::kLateTouchdownSpeed_m_s * k * Scripted::kDt, 1e-9);
    EXPECT_NEAR(p.swing[0].velocity_m_s.z(), -gait::kLateTouchdownSpeed_m_s, 1e-12);
    EXPECT_EQ(p.swing[0].position_m.head<2>(), foothold.head<2>());
  }
  // Then it touches (the recorded trace, 15 ms late): stance from the second tick above 25 N.
  EXPECT_FALSE(s.tick(kRecordedTouchdown_n[0]).stance[0]);
  EXPECT_FALSE(s.tick(kRecordedTouchdown_n[1]).stance[0]);
  EXPECT_TRUE(s.tick(kRecordedTouchdown_n[2]).stance[0]);
  EXPECT_EQ(s.trot.plan().foot[0], gait::FootPhase::stance);
}

TEST(Touchdown, AFootThatNeverTouchesIsStanceAfterLateTouchdownSeconds) {
  Scripted s;
  s.run_until(s.liftoff_s(1) + 0.01);
  while (s.t_s < s.touchdown_s(1) - Scripted::kDt / 2) s.tick(0.0);
  int late_ticks = 0;
  while (!s.tick(0.0).stance[0]) ++late_ticks;
  // late_touchdown_s of 1 ms ticks (one more where the sum of the ticks rounds below it)
  EXPECT_NEAR(late_ticks, s.params.late_touchdown_s / Scripted::kDt, 1.0);
}

TEST(Touchdown, WithoutEvidenceTheScheduleAloneDecidesAndNothingIsCapped) {
  gait::TrotParams p;
  p.duty_factor = 0.55;
  gait::TrotGait with(p), without(p);
  p.touchdown_force_n = 0.0;  // detection off: the evidence is ignored
  gait::TrotGait off(p);
  for (gait::TrotGait* g : {&with, &without, &off}) g->start(nominal());
  gait::ContactSense nothing;  // valid = false
  gait::ContactSense zero;
  zero.valid = true;  // reads 0 N everywhere: would be late at every touch-down
  for (int k = 0; k < 3000; ++k) {
    const double t = k * 1e-3;
    const auto& a = without.update(t, nominal(), Vec3::Zero());
    const auto& b = with.update(t, nominal(), Vec3::Zero(), Vec3::Zero(), Mat3::Identity(), Vec3::Zero(), 0.0, &nothing);
    const auto& c = off.update(t, nominal(), Vec3::Zero(), Vec3::Zero(), Mat3::Identity(), Vec3::Zero(), 0.0, &zero);
    for (int f = 0; f < kFeet; ++f) {
      ASSERT_EQ(a.stance[f], b.stance[f]);
      ASSERT_EQ(a.stance[f], c.stance[f]);
      ASSERT_EQ(a.stance[f], (t * p.step_frequency_hz - (f == 1 || f == 2 ? 0.5 : 0.0)) -
                                     std::floor(t * p.step_frequency_hz - (f == 1 || f == 2 ? 0.5 : 0.0)) <
                                 p.duty_factor);
      ASSERT_TRUE(std::isinf(a.normal_force_cap_n[f]) && std::isinf(b.normal_force_cap_n[f]) &&
                  std::isinf(c.normal_force_cap_n[f]));
    }
  }
}

TEST(Touchdown, ForcesRampOverTheFourFeetPhase) {
  Scripted s(1.4, 0.55);
  const double ramp = std::min(s.params.force_ramp_s, (0.55 - 0.5) / 1.4);  // 30 ms < the 35.7 ms overlap
  // lf unloads from 230 N to 0 over the ramp before its lift-off, linearly in the time left.
  s.run_until(s.liftoff_s(1) - 0.05);
  for (double t = s.t_s; t < s.liftoff_s(1) - Scripted::kDt / 2; t = s.t_s) {
    const gait::ContactPlan& p = s.tick(230.0);
    ASSERT_TRUE(p.stance[0]);
    const double left = s.liftoff_s(1) - t;
    if (left >= ramp) {
      EXPECT_TRUE(std::isinf(p.normal_force_cap_n[0])) << t;
    } else {
      EXPECT_NEAR(p.normal_force_cap_n[0], 230.0 * left / ramp, 1e-6) << t;
    }
  }
  // rf (and lh) touch down: loaded from 0 to a diagonal foot's share over the ramp (half
  // the feet's summed force).
  Scripted u(1.4, 0.55);
  u.run_until(0.5 / 1.4 + 1.0 / 1.4 - 0.01);  // 10 ms before rf's second scheduled touch-down
  while (!u.tick(u.on_ground(0, u.t_s) ? 230.0 : 0.0).stance[1]) ASSERT_LT(u.t_s, 2.0);
  const double touched = u.t_s - Scripted::kDt;  // it became stance on the last tick
  EXPECT_NEAR(u.trot.plan().normal_force_cap_n[1], 0.0, 1e-9);
  for (int k = 1; k < 40; ++k) {
    const double now = u.t_s;
    const gait::ContactPlan& p = u.tick(u.on_ground(0, now) ? 230.0 : 0.0);
    int reading = 0;
    for (int f = 0; f < kFeet; ++f) reading += u.on_ground(f, now) ? 1 : 0;
    const double share = 0.5 * 230.0 * reading;
    const double up = (now - touched) / ramp;
    if (up < 1.0 - 1e-9) {
      EXPECT_NEAR(p.normal_force_cap_n[1], up * share, 1e-6) << k;
    } else if (up > 1.0 + 1e-9) {
      EXPECT_TRUE(std::isinf(p.normal_force_cap_n[1])) << k;
    }
  }
}

TEST(Touchdown, AFootIsNotUnloadedWhileTheOtherDiagonalIsInTheAir) {
  Scripted s(1.4, 0.55);
  // rf and lh late: they read 0 N through lf's last 30 ms; lf keeps its full force.
  s.run_until(s.liftoff_s(1) - 0.05);
  int checked = 0;
  while (s.t_s < s.liftoff_s(1) - Scripted::kDt / 2) {
    gait::ContactSense sense;
    sense.valid = true;
    sense.normal_force_n = {230.0, 0.0, 0.0, 230.0};
    const gait::ContactPlan& p = s.trot.update(s.t_s, nominal(), Vec3::Zero(), Vec3::Zero(), Mat3::Identity(),
                                                Vec3::Zero(), 0.0, &sense);
    s.t_s += Scripted::kDt;
    if (!p.stance[1]) {
      EXPECT_TRUE(std::isinf(p.normal_force_cap_n[0])) << s.t_s;
      ++checked;
    }
  }
  EXPECT_GT(checked, 30);  // rf stayed in the air (late) through lf's ramp window
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
