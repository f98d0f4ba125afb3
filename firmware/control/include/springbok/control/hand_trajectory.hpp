// A moving rest pose for the hand (issue 22's hand pose commands): the template's hand
// rest point is the engaged one plus an offset, and its rest orientation the engaged one
// turned by a rotation vector (both in the rest pose's horizontal frame; the orientation
// matters with the rotational template, which renders about it). Offset and rotation
// vector, six numbers, follow
//   - a scenario's waypoints (times from the controller's engagement, offsets in the
//     rest pose's horizontal frame): a clamped cubic spline through (0 s, 0) and them
//     (position, velocity and acceleration continuous between them; at rest at both ends,
//     where the acceleration steps from and to 0), or
//   - an operator's move: a minimum-jerk (quintic) path from where the offset is, with its
//     velocity and acceleration, to a target, at rest there, over a given duration.
// Limits, refused with a message: every offset within kHandMaxOffset_m of the engaged rest
// point and every rotation within kHandMaxRotation_rad of the engaged orientation, the
// path's speed at most kHandMaxSpeed_m_s and its rotation vector's rate at most
// kHandMaxRotationRate_rad_s.
#pragma once

#include <array>
#include <span>
#include <string>

#include "springbok/model/model.hpp"

namespace springbok::control {

inline constexpr int kMaxHandWaypoints = 128;
inline constexpr double kHandMaxOffset_m = 0.25;
inline constexpr double kHandMaxSpeed_m_s = 0.5;
inline constexpr double kHandMaxRotation_rad = 0.6;
inline constexpr double kHandMaxRotationRate_rad_s = 1.0;  // below the Gen3's 1.22 rad/s wrist joints
inline constexpr double kHandMinMove_s = 0.1;

struct HandWaypoint {
  double at_s = 0.0;
  Vec3 offset_m = Vec3::Zero();
  Vec3 rotation_rad = Vec3::Zero();  // rotation vector from the engaged orientation
};

struct HandSample {
  Vec3 offset_m = Vec3::Zero();
  Vec3 velocity_m_s = Vec3::Zero();
  Vec3 acceleration_m_s2 = Vec3::Zero();
  Vec3 rotation_rad = Vec3::Zero();       // the rotation vector phi
  Vec3 rotation_rate_rad_s = Vec3::Zero();  // d phi / dt (the angular velocity is J_l(phi) d phi / dt: wbc::so3_left_jacobian)
  Vec3 rotation_acceleration_rad_s2 = Vec3::Zero();
};

class HandTrajectory {
 public:
  // Start-up (allocates while it solves): the spline through (0, 0) and `waypoints` (times
  // increasing, the first after 0). "" or why not ("waypoint 3: ...").
  std::string set_waypoints(std::span<const HandWaypoint> waypoints);
  // A minimum-jerk move from the path's sample at t_now_s to `target_m` and
  // `target_rotation_rad` over duration_s, replacing what follows t_now_s. nullptr or why
  // not (nothing changes). rt: no alloc
  const char* move_to(double t_now_s, const Vec3& target_m, const Vec3& target_rotation_rad, double duration_s) noexcept;
  // The offset at t_s (0 before the first segment, the last point after the last). rt: no alloc
  HandSample at(double t_s) const noexcept;
  // The largest speed along the path (sampled every millisecond; start-up and tests).
  double max_speed_m_s() const noexcept;
  // Whether some point of the path turns the hand (a rotation vector not zero).
  bool turns() const noexcept { return turns_; }
  bool empty() const noexcept { return segments_ == 0; }
  void clear() noexcept { segments_ = 0; }

 private:
  // p(tau) = c0 + c1 tau + ... + c5 tau^5 per coordinate (offset x y z, rotation vector x y z),
  // tau = t - start, on [start, start + length].
  struct Segment {
    double start_s = 0.0;
    double length_s = 0.0;
    std::array<Vec6, 6> c{};
  };
  std::array<Segment, kMaxHandWaypoints + 1> segment_{};
  int segments_ = 0;
  Vec6 end_ = Vec6::Zero();  // held after the last segment (exactly the last waypoint or target)
  bool turns_ = false;
};

}  // namespace springbok::control
