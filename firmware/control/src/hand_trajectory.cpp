#include "springbok/control/hand_trajectory.hpp"

#include <algorithm>
#include <cmath>
#include <vector>

namespace springbok::control {
namespace {

HandSample evaluate(const std::array<Vec3, 6>& c, double tau) noexcept {
  HandSample s;
  s.offset_m = c[0] + tau * (c[1] + tau * (c[2] + tau * (c[3] + tau * (c[4] + tau * c[5]))));
  s.velocity_m_s = c[1] + tau * (2.0 * c[2] + tau * (3.0 * c[3] + tau * (4.0 * c[4] + tau * 5.0 * c[5])));
  s.acceleration_m_s2 = 2.0 * c[2] + tau * (6.0 * c[3] + tau * (12.0 * c[4] + tau * 20.0 * c[5]));
  return s;
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
  std::vector<Vec3> p{Vec3::Zero()};
  for (std::size_t i = 0; i < waypoints.size(); ++i) {
    const HandWaypoint& w = waypoints[i];
    if (!std::isfinite(w.at_s) || !w.offset_m.allFinite()) return waypoint_error(i, "not finite");
    if (!(w.at_s > t.back())) return waypoint_error(i, "at_s must be after the previous one's (and after 0)");
    if (w.offset_m.norm() > kHandMaxOffset_m) {
      return waypoint_error(i, "more than " + std::to_string(kHandMaxOffset_m) + " m from the hand's rest point");
    }
    t.push_back(w.at_s);
    p.push_back(w.offset_m);
  }
  // Clamped cubic spline (at rest at both ends): the knots' second derivatives M from the
  // tridiagonal system, solved by the Thomas algorithm (the same matrix for the three axes).
  const std::size_t n = t.size();
  std::vector<double> h(n - 1), diag(n), upper(n), lower(n);
  std::vector<Vec3> rhs(n, Vec3::Zero()), m(n, Vec3::Zero());
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

  for (std::size_t i = 0; i + 1 < n; ++i) {
    Segment& s = segment_[i];
    s.start_s = t[i];
    s.length_s = h[i];
    s.c = {p[i], Vec3((p[i + 1] - p[i]) / h[i] - h[i] * (2.0 * m[i] + m[i + 1]) / 6.0), Vec3(0.5 * m[i]),
           Vec3((m[i + 1] - m[i]) / (6.0 * h[i])), Vec3::Zero(), Vec3::Zero()};
  }
  segments_ = static_cast<int>(n - 1);
  end_m_ = p[n - 1];
  // The path between the waypoints: within the workspace, no faster than the limit.
  for (double time = 0.0; time <= t.back(); time += 1e-3) {
    const HandSample s = at(time);
    if (s.offset_m.norm() > kHandMaxOffset_m + 1e-9 || s.velocity_m_s.norm() > kHandMaxSpeed_m_s) {
      segments_ = 0;
      return "the path between the waypoints at " + std::to_string(time) + " s is " +
             (s.offset_m.norm() > kHandMaxOffset_m + 1e-9
                  ? std::to_string(s.offset_m.norm()) + " m from the rest point (at most " +
                        std::to_string(kHandMaxOffset_m) + ")"
                  : "at " + std::to_string(s.velocity_m_s.norm()) + " m/s (at most " +
                        std::to_string(kHandMaxSpeed_m_s) + ")");
    }
  }
  return "";
}

const char* HandTrajectory::move_to(double t_now_s, const Vec3& target_m, double duration_s) noexcept {
  if (!target_m.allFinite() || !std::isfinite(t_now_s)) return "not finite";
  if (target_m.norm() > kHandMaxOffset_m) return "target more than 0.25 m from the hand's rest point";
  if (!(duration_s >= kHandMinMove_s && duration_s <= 60.0)) return "duration outside [0.1, 60] s";
  const HandSample from = at(t_now_s);
  const double T = duration_s;
  const Vec3 d = target_m - from.offset_m;
  const Vec3& v0 = from.velocity_m_s;
  const Vec3& a0 = from.acceleration_m_s2;
  Segment s;
  s.start_s = t_now_s;
  s.length_s = T;
  s.c = {from.offset_m, v0, Vec3(0.5 * a0), Vec3((20.0 * d - 12.0 * v0 * T - 3.0 * a0 * T * T) / (2.0 * T * T * T)),
         Vec3((-30.0 * d + 16.0 * v0 * T + 3.0 * a0 * T * T) / (2.0 * T * T * T * T)),
         Vec3((12.0 * d - 6.0 * v0 * T - a0 * T * T) / (2.0 * T * T * T * T * T))};
  for (int k = 0; k <= 50; ++k) {
    const HandSample e = evaluate(s.c, T * k / 50.0);
    if (e.velocity_m_s.norm() > kHandMaxSpeed_m_s) return "too fast: more than 0.5 m/s on the way (a longer duration)";
    if (e.offset_m.norm() > kHandMaxOffset_m + 1e-9) return "the way leaves 0.25 m around the hand's rest point";
  }
  segment_[0] = s;
  segments_ = 1;
  end_m_ = target_m;
  return nullptr;
}

HandSample HandTrajectory::at(double t_s) const noexcept {
  if (segments_ == 0 || !(t_s > segment_[0].start_s)) {
    HandSample s;
    if (segments_ > 0) s.offset_m = segment_[0].c[0];
    return s;
  }
  const Segment& last = segment_[static_cast<std::size_t>(segments_ - 1)];
  if (t_s >= last.start_s + last.length_s) {
    HandSample s;
    s.offset_m = end_m_;
    return s;
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
