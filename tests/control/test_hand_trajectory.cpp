// The hand's moving rest point: the clamped cubic spline through the waypoints (through
// every one, at rest at both ends, position, velocity and acceleration continuous, its
// derivatives those of its position by finite differences), the operator's minimum-jerk
// move (from a moving state, at rest on the target after its duration), and the limits.
#include <cmath>
#include <numbers>
#include <vector>

#include <gtest/gtest.h>

#include "alloc_trap.hpp"
#include "springbok/control/hand_trajectory.hpp"

namespace {
using namespace springbok;
using control::HandSample;
using control::HandTrajectory;
using control::HandWaypoint;

// A 10 cm circle at 0.5 Hz in the y-z plane through the rest point, 16 waypoints a turn.
std::vector<HandWaypoint> circle(int turns) {
  std::vector<HandWaypoint> w;
  const double r = 0.05, f = 0.5;
  for (int k = 1; k <= 16 * turns; ++k) {
    const double t = k / (16.0 * f), phase = 2.0 * std::numbers::pi * f * t;
    w.push_back({0.5 + t, Vec3(0.0, r * std::sin(phase), r * (1.0 - std::cos(phase)))});
  }
  return w;
}

void expect_consistent(const HandTrajectory& h, double t0, double t1) {
  const double d = 1e-6;
  for (double t = t0 + 1e-3; t < t1 - 1e-3; t += 0.0137) {
    const HandSample s = h.at(t), lo = h.at(t - d), hi = h.at(t + d);
    EXPECT_LT((s.velocity_m_s - (hi.offset_m - lo.offset_m) / (2 * d)).norm(), 1e-6) << t;
    EXPECT_LT((s.acceleration_m_s2 - (hi.velocity_m_s - lo.velocity_m_s) / (2 * d)).norm(), 1e-4) << t;
    EXPECT_LT((s.rotation_rate_rad_s - (hi.rotation_rad - lo.rotation_rad) / (2 * d)).norm(), 1e-6) << t;
    EXPECT_LT((s.rotation_acceleration_rad_s2 - (hi.rotation_rate_rad_s - lo.rotation_rate_rad_s) / (2 * d)).norm(), 1e-4)
        << t;
  }
}

TEST(HandTrajectory, TheSplineGoesThroughEveryWaypointSmoothlyFromRestToRest) {
  HandTrajectory h;
  const auto w = circle(3);
  ASSERT_EQ(h.set_waypoints(w), "");
  for (const HandWaypoint& p : w) EXPECT_LT((h.at(p.at_s).offset_m - p.offset_m).norm(), 1e-12) << p.at_s;
  EXPECT_EQ(h.at(0.0).offset_m, Vec3::Zero());
  EXPECT_LT(h.at(1e-9).velocity_m_s.norm(), 1e-6);  // from rest
  const HandSample end = h.at(w.back().at_s - 1e-9);
  EXPECT_LT(end.velocity_m_s.norm(), 1e-6);  // to rest
  EXPECT_EQ(h.at(w.back().at_s + 5.0).offset_m, w.back().offset_m);  // held
  EXPECT_EQ(h.at(w.back().at_s + 5.0).velocity_m_s, Vec3::Zero());
  expect_consistent(h, 0.0, w.back().at_s);
  // Continuity across the knots (position, velocity, acceleration; at the last the
  // acceleration steps to 0: at rest there).
  for (std::size_t i = 0; i + 1 < w.size(); ++i) {
    const HandWaypoint& p = w[i];
    const HandSample a = h.at(p.at_s - 1e-9), b = h.at(p.at_s + 1e-9);
    EXPECT_LT((a.velocity_m_s - b.velocity_m_s).norm(), 1e-6);
    EXPECT_LT((a.acceleration_m_s2 - b.acceleration_m_s2).norm(), 1e-5);
  }
  // In the middle turn it is the circle: radius 5 cm about (0, 0, 0.05) within 0.5 mm, at
  // the circle's speed 2 pi r f = 0.157 m/s within 5 %.
  for (double t = 2.5; t < 4.5; t += 0.01) {
    const HandSample s = h.at(t);
    EXPECT_NEAR((s.offset_m - Vec3(0.0, 0.0, 0.05)).norm(), 0.05, 5e-4) << t;
    EXPECT_NEAR(s.velocity_m_s.norm(), 2 * std::numbers::pi * 0.05 * 0.5, 0.05 * 0.157) << t;
  }
}

TEST(HandTrajectory, WaypointsOutsideTheLimitsAreRefusedNamingTheWaypoint) {
  HandTrajectory h;
  EXPECT_EQ(h.set_waypoints(std::vector<HandWaypoint>{{1.0, Vec3(0.3, 0, 0)}}).rfind("waypoint 0: more than", 0), 0u);
  EXPECT_EQ(h.set_waypoints(std::vector<HandWaypoint>{{1.0, Vec3(0.1, 0, 0)}, {1.0, Vec3(0, 0, 0)}}),
            "waypoint 1: at_s must be after the previous one's (and after 0)");
  EXPECT_EQ(h.set_waypoints(std::vector<HandWaypoint>{{0.0, Vec3(0.1, 0, 0)}}),
            "waypoint 0: at_s must be after the previous one's (and after 0)");
  EXPECT_EQ(h.set_waypoints(std::vector<HandWaypoint>{{1.0, Vec3(NAN, 0, 0)}}), "waypoint 0: not finite");
  // 20 cm in 0.2 s: too fast between the waypoints.
  const std::string fast = h.set_waypoints(std::vector<HandWaypoint>{{0.2, Vec3(0.2, 0, 0)}});
  EXPECT_NE(fast.find("m/s (at most 0.5"), std::string::npos) << fast;
  EXPECT_TRUE(h.empty());
  std::vector<HandWaypoint> many(control::kMaxHandWaypoints + 1);
  for (std::size_t i = 0; i < many.size(); ++i) many[i].at_s = 1.0 + static_cast<double>(i);
  EXPECT_EQ(h.set_waypoints(many).rfind("at most 128 waypoints", 0), 0u);
}

TEST(HandTrajectory, AMoveGoesFromTheMovingStateToRestOnTheTargetWithoutAllocating) {
  HandTrajectory h;
  ASSERT_EQ(h.set_waypoints(circle(1)), "");
  const double t0 = 1.3;  // mid-circle: moving
  const HandSample from = h.at(t0);
  ASSERT_GT(from.velocity_m_s.norm(), 0.1);
  const Vec3 target(0.1, -0.05, 0.02);
  springbok::test::AllocationTrap trap;
  EXPECT_EQ(h.move_to(t0, target, Vec3::Zero(), 1.0), nullptr);
  EXPECT_EQ(trap.disarm(), 0u);
  const HandSample start = h.at(t0 + 1e-9);
  EXPECT_LT((start.offset_m - from.offset_m).norm(), 1e-9);
  EXPECT_LT((start.velocity_m_s - from.velocity_m_s).norm(), 1e-6);
  EXPECT_LT((start.acceleration_m_s2 - from.acceleration_m_s2).norm(), 1e-5);
  const HandSample end = h.at(t0 + 1.0 - 1e-9);
  EXPECT_LT((end.offset_m - target).norm(), 1e-9);
  EXPECT_LT(end.velocity_m_s.norm(), 1e-6);
  EXPECT_LT(end.acceleration_m_s2.norm(), 1e-4);
  expect_consistent(h, t0, t0 + 1.0);
  EXPECT_EQ(h.at(t0 + 3.0).offset_m, target);
  // Refused: out of the workspace, too fast, too short; nothing changes.
  EXPECT_NE(h.move_to(t0 + 2.0, Vec3(0.3, 0, 0), Vec3::Zero(), 2.0), nullptr);
  EXPECT_NE(h.move_to(t0 + 2.0, Vec3(-0.1, 0.05, 0), Vec3::Zero(), 0.2), nullptr);  // 0.22 m in 0.2 s
  EXPECT_NE(h.move_to(t0 + 2.0, Vec3::Zero(), Vec3::Zero(), 0.05), nullptr);
  EXPECT_NE(h.move_to(t0 + 2.0, Vec3(NAN, 0, 0), Vec3::Zero(), 1.0), nullptr);
  EXPECT_EQ(h.at(t0 + 3.0).offset_m, target);
  // From rest: the minimum-jerk peak speed, 1.875 distance / duration.
  HandTrajectory rest;
  ASSERT_EQ(rest.move_to(0.0, Vec3(0.1, 0, 0), Vec3::Zero(), 1.0), nullptr);
  EXPECT_NEAR(rest.max_speed_m_s(), 1.875 * 0.1, 1e-4);
}

// The hand's rest orientation: rotation vectors through the same spline, with their limits.
TEST(HandTrajectory, TheRestOrientationTurnsThroughItsWaypointsWithinItsLimits) {
  HandTrajectory h;
  const std::vector<HandWaypoint> turn{{1.0, Vec3(0.02, 0, 0), Vec3(0.3, 0, 0)},
                                       {2.0, Vec3(0.02, 0, 0), Vec3(0.3, -0.2, 0.1)},
                                       {3.0, Vec3::Zero(), Vec3::Zero()}};
  ASSERT_EQ(h.set_waypoints(turn), "");
  EXPECT_TRUE(h.turns());
  for (const HandWaypoint& w : turn) {
    EXPECT_LT((h.at(w.at_s).rotation_rad - w.rotation_rad).norm(), 1e-12);
    EXPECT_LT((h.at(w.at_s).offset_m - w.offset_m).norm(), 1e-12);
  }
  expect_consistent(h, 0.0, 3.0);
  EXPECT_EQ(h.at(3.5).rotation_rate_rad_s, Vec3::Zero());
  // Refused: beyond 0.6 rad, or turning faster than 1 rad/s between the waypoints.
  HandTrajectory bad;
  EXPECT_NE(bad.set_waypoints(std::vector<HandWaypoint>{{1.0, Vec3::Zero(), Vec3(0.7, 0, 0)}}).find("0.6"),
            std::string::npos);
  EXPECT_NE(bad.set_waypoints(std::vector<HandWaypoint>{{0.3, Vec3::Zero(), Vec3(0.5, 0, 0)}}).find("rad/s (at most 1"),
            std::string::npos);
  EXPECT_FALSE(bad.turns());
  // An operator's turn: minimum jerk to the target rotation, at rest there; refused too fast.
  HandTrajectory op;
  EXPECT_NE(op.move_to(0.0, Vec3::Zero(), Vec3(0.5, 0, 0), 0.5), nullptr);  // 1.875 rad/s peak
  EXPECT_NE(op.move_to(0.0, Vec3::Zero(), Vec3(0.0, 0.65, 0), 2.0), nullptr);
  ASSERT_EQ(op.move_to(0.0, Vec3::Zero(), Vec3(0.0, 0.4, 0.0), 1.0), nullptr);
  EXPECT_TRUE(op.turns());
  EXPECT_LT((op.at(1.0 - 1e-9).rotation_rad - Vec3(0.0, 0.4, 0.0)).norm(), 1e-9);
  EXPECT_NEAR(op.at(0.5).rotation_rate_rad_s.y(), 1.875 * 0.4, 1e-9);
  expect_consistent(op, 0.0, 1.0);
}

}  // namespace
