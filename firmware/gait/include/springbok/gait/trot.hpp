// Trotting in place (SPEC section 5): the diagonal pairs {lf, rh} and {rf, lh}
// alternate, half a cycle apart, at step frequency f_s with duty factor d_f
// (stance time over cycle time); with d_f > 0.5 all four feet are on the ground
// for (d_f - 0.5) / f_s twice per cycle.
//
// Footholds: under the hip, i.e. the foot's nominal position relative to the
// trunk (taken at start()), moved by the base velocity as in the Reactive
// Control Framework's heuristic (Barasuol et al., ICRA 2013):
//     rho_td = rho_nominal + (T_stance / 2) v_xy + k_v (v_xy - v_xy^d),   v^d = 0 in place.
// Swing: from the lift-off point to the foothold in T_swing = (1 - d_f) / f_s,
// horizontally along a quintic (zero velocity and acceleration at both ends),
// vertically the same plus a bump of height h, 64 s^3 (1 - s)^3 (peak h at
// mid-swing, zero velocity and acceleration at both ends). Everything relative
// to the trunk origin in trunk axes (the WBC's swing task's coordinates).
#pragma once

#include <array>

#include <Eigen/Core>

#include "springbok/model/model.hpp"

namespace springbok::config {
class Fields;
}

namespace springbok::gait {

struct TrotParams {
  double step_frequency_hz = 1.4;
  double duty_factor = 0.65;
  double step_height_m = 0.08;
  double velocity_gain_s = 0.0;      // k_v of the foothold correction
  double touchdown_depth_m = 0.005;  // the foothold this far below the nominal (the foot lands, not hovers)
};

// Reads a `gait:` map: step_frequency (0.1..5 Hz), duty_factor ([0.5, 0.95]), step_height
// (0..0.3 m), velocity_gain, touchdown_depth; missing keys keep the defaults. Throws
// config::ConfigError naming the field. Start-up only.
TrotParams read_trot_params(const config::Fields& f);

struct SwingReference {
  Vec3 position_m = Vec3::Zero();      // foot relative to the trunk origin, trunk axes
  Vec3 velocity_m_s = Vec3::Zero();
  Vec3 acceleration_m_s2 = Vec3::Zero();
};

struct ContactPlan {
  std::array<bool, kFeet> stance{true, true, true, true};
  std::array<SwingReference, kFeet> swing{};  // meaningful where !stance
  std::array<double, kFeet> phase{};          // the foot's phase in its cycle, [0, 1): stance below d_f
};

// Quintic blend 10 s^3 - 15 s^4 + 6 s^5 and the bump 64 s^3 (1 - s)^3 with their
// first two derivatives in s, for s in [0, 1].
struct Profile {
  double value, rate, curvature;
};
Profile quintic_blend(double s) noexcept;
Profile swing_bump(double s) noexcept;

class TrotGait {
 public:
  explicit TrotGait(const TrotParams& params) noexcept;

  // Starts the cycle at time 0 with every foot in stance at `nominal_feet_b`
  // (foot positions relative to the trunk, trunk axes: the footholds' centre).
  void start(const std::array<Vec3, kFeet>& nominal_feet_b) noexcept;

  // The plan at time t_s since start(), given the feet's current positions and
  // the trunk's linear velocity (trunk axes). A foot's lift-off point is its
  // position on its first swing tick. rt: no alloc
  const ContactPlan& update(double t_s, const std::array<Vec3, kFeet>& feet_b, const Vec3& base_velocity_b) noexcept;

  const ContactPlan& plan() const noexcept { return plan_; }
  const TrotParams& params() const noexcept { return params_; }
  double stance_duration_s() const noexcept { return params_.duty_factor / params_.step_frequency_hz; }
  double swing_duration_s() const noexcept { return (1.0 - params_.duty_factor) / params_.step_frequency_hz; }

 private:
  TrotParams params_;
  std::array<Vec3, kFeet> nominal_b_{};
  std::array<Vec3, kFeet> liftoff_b_{};
  std::array<Vec3, kFeet> touchdown_b_{};
  std::array<bool, kFeet> swinging_{};
  ContactPlan plan_;
};

}  // namespace springbok::gait
