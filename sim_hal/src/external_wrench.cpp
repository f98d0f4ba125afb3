#include "springbok/sim_hal/external_wrench.hpp"

#include <cmath>
#include <numbers>

namespace springbok::sim {

double profile_value(const ForceProfile& p, double t_s) noexcept {
  const double tau = t_s - p.start_s;
  if (tau < 0.0 || tau >= p.duration_s) return 0.0;
  switch (p.shape) {
    case ProfileShape::constant:
    case ProfileShape::step:
    case ProfileShape::impulse:
      return p.amplitude;
    case ProfileShape::chirp: {
      const double sweep_hz_per_s = (p.end_frequency_hz - p.start_frequency_hz) / p.duration_s;
      const double phase = 2.0 * std::numbers::pi * (p.start_frequency_hz * tau + 0.5 * sweep_hz_per_s * tau * tau);
      return p.amplitude * std::sin(phase);
    }
  }
  return 0.0;
}

namespace {
constexpr model::Transform kIdentity{{1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0}, {0.0, 0.0, 0.0}};
}  // namespace

std::optional<FrameRef> find_frame(std::string_view name) noexcept {
  if (name == robot::kBaseLink) return FrameRef{0, kIdentity};
  for (int j = 0; j < kNj; ++j) {
    if (robot::kJoints[j].child_link == name) return FrameRef{j + 1, robot::kLinkInBody[static_cast<std::size_t>(j) + 1]};
  }
  for (const auto& frame : robot::kFrames) {
    if (frame.name == name) return FrameRef{frame.body, frame.placement};
  }
  return std::nullopt;
}

}  // namespace springbok::sim
