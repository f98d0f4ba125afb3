#include "springbok/control/hand_trajectory.hpp"

#include <algorithm>
#include <cmath>
#include <vector>

namespace springbok::control {
namespace {

HandSample sample(const Vec6& p, const Vec6& v, const Vec6& a) noexcept {
  HandSample s;
  s.offset_m = p.head<3>();
  s.velocity_m_s = v.head<3>();
  s.acceleration_m_s2 = a.head<3>();
  s.rotation_rad = p.tail<3>();
  s.rotation_rate_rad_s = v.tail<3>();
  s.rotation_acceleration_rad_s2 = a.tail<3>();
  return s;
}

HandSample evaluate(const std::array<Vec6, 6>& c, double tau) noexcept {
  const Vec6 p = c[0] + tau * (c[1] + tau * (c[2] + tau * (c[3] + tau * (c[4] + tau * c[5]))));
  const Vec6 v = c[1] + tau * (2.0 * c[2] + tau * (3.0 * c[3] + tau * (4.0 * c[4] + tau * 5.0 * c[5])));
  const Vec6 a = 2.0 * c[2] + tau * (6.0 * c[3] + tau * (12.0 * c[4] + tau * 20.0 * c[5]));
  return sample(p, v, a);
}

Vec6 pose(const Vec3& offset_m, const Vec3& rotation_rad) noexcept {
  Vec6 p;
  p.head<3>() = offset_m;
  p.tail<3>() = rotation_rad;
  return p;
}

// Why `s` is outside the limits (with its value), or "" (start-up: allocates).
std::string outside_limits(const HandSample& s) {
  if (s.offset_m.norm() > kHandMaxOffset_m + 1e-9) {
    return std::to_string(s.offset_m.norm()) + " m from the rest point (at most " + std::to_string(kHandMaxOffset_m) + ")";
  }
  if (s.rotation_rad.norm() > kHandMaxRotation_rad + 1e-9) {
    return "turned " + std::to_string(s.rotation_rad.norm()) + " rad from the rest orientation (at most " +
           std::to_string(kHandMaxRotation_rad) + ")";
  }
  if (s.velocity_m_s.norm() > kHandMaxSpeed_m_s) {
    return "at " + std::to_string(s.velocity_m_s.norm()) + " m/s (at most " + std::to_string(kHandMaxSpeed_m_s) + ")";
  }
  if (s.rotation_rate_rad_s.norm() > kHandMaxRotationRate_rad_s) {
    return "turning faster than its limit: " + std::to_string(s.rotation_rate_rad_s.norm()) + " rad/s (at most " +
           std::to_string(kHandMaxRotationRate_rad_s) + ")";
  }
  return "";
}

std::string waypoint_error(std::size_t i, const std::string& what) {
  return "waypoint " + std::to_string(i) + ": " + what;
}

}  // namespace

std::string HandTrajectory::set_waypoints(std::span<const HandWaypoint> waypoints) {
  if (waypoints.empty()) {
    segments_ = 0;
    return "";
  }
  if (waypoints.size() > static_cast<std::size_t>(kMaxHandWaypoints)) {
    return "at most " + std::to_string(kMaxHandWaypoints) + " waypoints, got " + std::to_string(waypoints.size());
  }
  // The knots: (0, 0), then the waypoints.
  std::vector<double> t{0.0};
  std::vector<Vec6> p{Vec6::Zero()};
  for (std::size_t i = 0; i < waypoints.size(); ++i) {
    const HandWaypoint& w = waypoints[i];
    if (!std::isfinite(w.at_s) || !w.offset_m.allFinite() || !w.rotation_rad.allFinite()) {
      return waypoint_error(i, "not finite");
    }
    if (!(w.at_s > t.back())) return waypoint_error(i, "at_s must be after the previous one's (and after 0)");
    if (w.offset_m.norm() > kHandMaxOffset_m) {
      return waypoint_error(i, "more than " + std::to_string(kHandMaxOffset_m) + " m from the hand's rest point");
    }
    if (w.rotation_rad.norm() > kHandMaxRotation_rad) {
      return waypoint_error(i, "turned more than " + std::to_string(kHandMaxRotation_rad) +
                                   " rad from the hand's rest orientation");
    }
    t.push_back(w.at_s);
    p.push_back(pose(w.offset_m, w.rotation_rad));
  }
  // Clamped cubic spline (at rest at both ends): the knots' second derivatives M from the
  // tridiagonal system, solved by the Thomas algorithm (the same matrix for the six coordinates).
  const std::size_t n = t.size();
  std::vector<double> h(n - 1), diag(n), upper(n), lower(n);
  std::vector<Vec6> rhs(n, Vec6::Zero()), m(n, Vec6::Zero());
  for (std::size_t i = 0; i + 1 < n; ++i) h[i] = t[i + 1] - t[i];
  diag[0] = 2.0 * h[0];
  upper[0] = h[0];
  rhs[0] = 6.0 * ((p[1] - p[0]) / h[0]);
  for (std::size_t i = 1; i + 1 < n; ++i) {
    lower[i] = h[i - 1];
    diag[i] = 2.0 * (h[i - 1] + h[i]);
    upper[i] = h[i];
    rhs[i] = 6.0 * ((p[i + 1] - p[i]) / h[i] - (p[i] - p[i - 1]) / h[i - 1]);
  }
  lower[n - 1] = h[n - 2];
  diag[n - 1] = 2.0 * h[n - 2];
  rhs[n - 1] = 6.0 * (-(p[n - 1] - p[n - 2]) / h[n - 2]);
  for (std::size_t i = 1; i < n; ++i) {
    const double w = lower[i] / diag[i - 1];
    diag[i] -= w * upper[i - 1];
    rhs[i] -= w * rhs[i - 1];
  }
  m[n - 1] = rhs[n - 1] / diag[n - 1];
  for (std::size_t i = n - 1; i-- > 0;) m[i] = (rhs[i] - upper[i] * m[i + 1]) / diag[i];

  bool turns = false;
  for (std::size_t i = 0; i + 1 < n; ++i) {
    Segment& s = segment_[i];
    s.start_s = t[i];
    s.length_s = h[i];
    s.c = {p[i], Vec6((p[i + 1] - p[i]) / h[i] - h[i] * (2.0 * m[i] + m[i + 1]) / 6.0), Vec6(0.5 * m[i]),
           Vec6((m[i + 1] - m[i]) / (6.0 * h[i])), Vec6::Zero(), Vec6::Zero()};
    turns = turns || p[i + 1].tail<3>().norm() > 0.0;
  }
  segments_ = static_cast<int>(n - 1);
  end_ = p[n - 1];
  turns_ = turns;
  // The path between the waypoints: within the workspace, no faster than the limits.
  for (double time = 0.0; time <= t.back(); time += 1e-3) {
    if (const std::string why = outside_limits(at(time)); !why.empty()) {
      segments_ = 0;
      turns_ = false;
      return "the path between the waypoints at " + std::to_string(time) + " s is " + why;
    }
  }
  return "";
}

const char* HandTrajectory::move_to(double t_now_s, const Vec3& target_m, const Vec3& target_rotation_rad,
                                   double duration_s) noexcept {
  if (!target_m.allFinite() || !target_rotation_rad.allFinite() || !std::isfinite(t_now_s)) return "not finite";
  if (target_m.norm() > kHandMaxOffset_m) return "target more than 0.25 m from the hand's rest point";
  if (target_rotation_rad.norm() > kHandMaxRotation_rad) return "target turned more than 0.6 rad from the hand's rest orientation";
  if (!(duration_s >= kHandMinMove_s && duration_s <= 60.0)) return "duration outside [0.1, 60] s";
  const HandSample from = at(t_now_s);
  const double T = duration_s;
  const Vec6 p0 = pose(from.offset_m, from.rotation_rad);
  const Vec6 d = pose(target_m, target_rotation_rad) - p0;
  const Vec6 v0 = pose(from.velocity_m_s, from.rotation_rate_rad_s);
  const Vec6 a0 = pose(from.acceleration_m_s2, from.rotation_acceleration_rad_s2);
  Segment s;
  s.start_s = t_now_s;
  s.length_s = T;
  s.c = {p0, v0, Vec6(0.5 * a0), Vec6((20.0 * d - 12.0 * v0 * T - 3.0 * a0 * T * T) / (2.0 * T * T * T)),
         Vec6((-30.0 * d + 16.0 * v0 * T + 3.0 * a0 * T * T) / (2.0 * T * T * T * T)),
         Vec6((12.0 * d - 6.0 * v0 * T - a0 * T * T) / (2.0 * T * T * T * T * T))};
  for (int k = 0; k <= 50; ++k) {
    const HandSample e = evaluate(s.c, T * k / 50.0);
    if (e.velocity_m_s.norm() > kHandMaxSpeed_m_s) return "too fast: more than 0.5 m/s on the way (a longer duration)";
    if (e.rotation_rate_rad_s.norm() > kHandMaxRotationRate_rad_s) {
      return "too fast: turning more than 1 rad/s on the way (a longer duration)";
    }
    if (e.offset_m.norm() > kHandMaxOffset_m + 1e-9) return "the way leaves 0.25 m around the hand's rest point";
    if (e.rotation_rad.norm() > kHandMaxRotation_rad + 1e-9) return "the way turns more than 0.6 rad";
  }
  segment_[0] = s;
  segments_ = 1;
  end_ = pose(target_m, target_rotation_rad);
  turns_ = from.rotation_rad.norm() > 0.0 || target_rotation_rad.norm() > 0.0;
  return nullptr;
}

HandSample HandTrajectory::at(double t_s) const noexcept {
  if (segments_ == 0 || !(t_s > segment_[0].start_s)) {
    return segments_ > 0 ? sample(segment_[0].c[0], Vec6::Zero(), Vec6::Zero()) : HandSample{};
  }
  const Segment& last = segment_[static_cast<std::size_t>(segments_ - 1)];
  if (t_s >= last.start_s + last.length_s) {
    return sample(end_, Vec6::Zero(), Vec6::Zero());
  }
  // The segment holding t_s (binary search on the start times).
  int lo = 0, hi = segments_ - 1;
  while (lo < hi) {
    const int mid = (lo + hi + 1) / 2;
    if (segment_[static_cast<std::size_t>(mid)].start_s <= t_s) lo = mid;
    else hi = mid - 1;
  }
  const Segment& s = segment_[static_cast<std::size_t>(lo)];
  return evaluate(s.c, t_s - s.start_s);
}

double HandTrajectory::max_speed_m_s() const noexcept {
  if (segments_ == 0) return 0.0;
  const Segment& last = segment_[static_cast<std::size_t>(segments_ - 1)];
  double fastest = 0.0;
  for (double t = segment_[0].start_s; t <= last.start_s + last.length_s; t += 1e-3) {
    fastest = std::max(fastest, at(t).velocity_m_s.norm());
  }
  return fastest;
}

}  // namespace springbok::control
