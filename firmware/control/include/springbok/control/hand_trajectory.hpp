// A moving rest point for the hand (issue 22's hand pose commands, position part): the
// template's hand rest point is the engaged one plus an offset that follows
//   - a scenario's waypoints (times from the controller's engagement, offsets in the
//     rest pose's horizontal frame): a clamped cubic spline through (0 s, 0) and them
//     (position, velocity and acceleration continuous between them; at rest at both ends,
//     where the acceleration steps from and to 0), or
//   - an operator's move: a minimum-jerk (quintic) path from where the offset is, with its
//     velocity and acceleration, to a target, at rest there, over a given duration.
// Limits, refused with a message: every offset within kHandMaxOffset_m of the engaged rest
// point, the path's speed at most kHandMaxSpeed_m_s.
#pragma once

#include <array>
#include <span>
#include <string>

#include "springbok/model/model.hpp"

namespace springbok::control {

inline constexpr int kMaxHandWaypoints = 128;
inline constexpr double kHandMaxOffset_m = 0.25;
inline constexpr double kHandMaxSpeed_m_s = 0.5;
inline constexpr double kHandMinMove_s = 0.1;

struct HandWaypoint {
  double at_s = 0.0;
  Vec3 offset_m = Vec3::Zero();
};

struct HandSample {
  Vec3 offset_m = Vec3::Zero();
  Vec3 velocity_m_s = Vec3::Zero();
  Vec3 acceleration_m_s2 = Vec3::Zero();
};

class HandTrajectory {
 public:
  // Start-up (allocates while it solves): the spline through (0, 0) and `waypoints` (times
  // increasing, the first after 0). "" or why not ("waypoint 3: ...").
  std::string set_waypoints(std::span<const HandWaypoint> waypoints);
  // A minimum-jerk move from the path's sample at t_now_s to `target_m` over duration_s,
  // replacing what follows t_now_s. nullptr or why not (nothing changes). rt: no alloc
  const char* move_to(double t_now_s, const Vec3& target_m, double duration_s) noexcept;
  // The offset at t_s (0 before the first segment, the last point after the last). rt: no alloc
  HandSample at(double t_s) const noexcept;
  // The largest speed along the path (sampled every millisecond; start-up and tests).
  double max_speed_m_s() const noexcept;
  bool empty() const noexcept { return segments_ == 0; }
  void clear() noexcept { segments_ = 0; }

 private:
  // p(tau) = c0 + c1 tau + ... + c5 tau^5 per axis, tau = t - start, on [start, start + length].
  struct Segment {
    double start_s = 0.0;
    double length_s = 0.0;
    std::array<Vec3, 6> c{};
  };
  std::array<Segment, kMaxHandWaypoints + 1> segment_{};
  int segments_ = 0;
  Vec3 end_m_ = Vec3::Zero();  // held after the last segment (exactly the last waypoint or target)
};

}  // namespace springbok::control
