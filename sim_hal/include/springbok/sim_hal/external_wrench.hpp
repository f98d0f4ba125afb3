// External forces and torques applied to the simulated robot at a named frame
// with a time profile (the paper's experiments push the hand).
#pragma once

#include <limits>
#include <optional>
#include <string_view>

#include "springbok/model/model.hpp"

namespace springbok::sim {

enum class ProfileShape { constant, step, chirp, impulse };
enum class WrenchKind { force, torque };

// A scalar time profile s(t); the applied vector is s(t) * axis.
//  constant: amplitude for all t in [start, start + duration)   (duration may be infinite)
//  step:     0 before start, amplitude in [start, start + duration)
//  impulse:  amplitude in [start, start + duration), so the impulse is amplitude * duration
//  chirp:    amplitude * sin(2 pi (f0 tau + (f1 - f0) tau^2 / (2 duration))), tau = t - start,
//            in [start, start + duration): a linear sweep from f0 to f1
struct ForceProfile {
  ProfileShape shape = ProfileShape::step;
  double amplitude = 0.0;                  // N (force) or N m (torque)
  double start_s = 0.0;
  double duration_s = std::numeric_limits<double>::infinity();
  double start_frequency_hz = 0.0;         // chirp only
  double end_frequency_hz = 0.0;           // chirp only
};

// rt: no alloc
double profile_value(const ForceProfile& profile, double t_s) noexcept;

// A place on the robot: a body and a frame rigidly attached to it.
struct FrameRef {
  int body = 0;                            // 0 = trunk, i + 1 = moved by joint i
  model::Transform placement{};            // frame in the body frame
};

// Named frames: every link of the model (trunk, hip assemblies, ... arm links)
// and every fixed frame of springbok::robot::kFrames (feet, EE, IMU, arm base).
std::optional<FrameRef> find_frame(std::string_view name) noexcept;

struct ExternalWrench {
  FrameRef frame;                          // applied at this frame's origin
  WrenchKind kind = WrenchKind::force;
  Vec3 axis_world = Vec3::UnitX();         // unit direction, world axes
  ForceProfile profile;
};

}  // namespace springbok::sim
