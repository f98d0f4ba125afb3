#include "springbok/gait/trot.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace springbok::gait {
namespace {

// Phase offset of each foot (lf, rf, lh, rh): the diagonals {lf, rh} and {rf, lh}.
constexpr std::array<double, kFeet> kOffset{0.0, 0.5, 0.5, 0.0};

}  // namespace

const char* trot_params_error(const TrotParams& p) noexcept {
  for (const TrotField& field : kTrotFields) {
    const double v = p.*field.member;
    if (!(v >= field.lo && v <= field.hi)) return field.key;  // NaN fails too
  }
  return nullptr;
}

Profile quintic_blend(double s) noexcept {
  return {s * s * s * (10.0 - 15.0 * s + 6.0 * s * s), 30.0 * s * s * (1.0 - s) * (1.0 - s),
          60.0 * s * (1.0 - s) * (1.0 - 2.0 * s)};
}

Profile swing_bump(double s) noexcept {
  const double u = 1.0 - s;
  return {64.0 * s * s * s * u * u * u, 192.0 * s * s * u * u * (1.0 - 2.0 * s),
          384.0 * s * u * (1.0 - 5.0 * s + 5.0 * s * s)};
}

TrotGait::TrotGait(const TrotParams& params) noexcept : params_(params) {}

void TrotGait::start(const std::array<Vec3, kFeet>& nominal_feet_h) noexcept {
  nominal_h_ = nominal_feet_h;
  nominal_centre_h_.setZero();
  for (const Vec3& foot : nominal_feet_h) nominal_centre_h_ += foot / static_cast<double>(kFeet);
  liftoff_h_ = nominal_feet_h;
  touchdown_h_ = nominal_feet_h;
  touchdown_s_.fill(-1e9);
  late_since_s_.fill(0.0);
  touching_ticks_.fill(0);
  ramp_from_n_.fill(std::numeric_limits<double>::quiet_NaN());
  plan_ = ContactPlan{};
}

// rt: no alloc
const ContactPlan& TrotGait::update(double t_s, const std::array<Vec3, kFeet>& feet_h, const Vec3& base_velocity_h,
                                    const Vec3& pattern_shift_h, const Mat3& tilt, const Vec3& commanded_velocity_h,
                                    double yaw_rate_rad_s, const ContactSense* sense) noexcept {
  const double cycles = std::max(0.0, t_s) * params_.step_frequency_hz;
  const double cycle_s = 1.0 / params_.step_frequency_hz;
  const double swing_s = swing_duration_s();
  const bool sensing = sense != nullptr && sense->valid && params_.touchdown_force_n > 0.0;
  for (int f = 0; f < kFeet; ++f) {
    double phase = cycles - kOffset[f];
    phase -= std::floor(phase);
    plan_.phase[f] = phase;
    const bool scheduled_stance = phase < params_.duty_factor;
    const double s = scheduled_stance ? 0.0 : (phase - params_.duty_factor) / (1.0 - params_.duty_factor);
    const bool above = sensing && sense->normal_force_n[f] > params_.touchdown_force_n;
    touching_ticks_[f] = above ? touching_ticks_[f] + 1 : 0;
    const bool touching = touching_ticks_[f] >= kTouchdownConfirmTicks;
    FootPhase& foot = plan_.foot[f];
    switch (foot) {
      case FootPhase::stance:
        if (!scheduled_stance) {  // lift-off: from here to the foothold
          foot = FootPhase::swing;
          liftoff_h_[f] = feet_h[f];
        }
        break;
      case FootPhase::swing:
        if (scheduled_stance) {
          if (sensing && !touching) {
            foot = FootPhase::late;
            late_since_s_[f] = t_s;
            ++plan_.late_touchdowns;
          } else {
            foot = FootPhase::stance;
            touchdown_s_[f] = t_s;
          }
        } else if (touching && s >= kTouchdownWindow) {
          foot = FootPhase::landed_early;
          touchdown_s_[f] = t_s;
          ++plan_.early_touchdowns;
        }
        break;
      case FootPhase::landed_early:
        if (scheduled_stance) foot = FootPhase::stance;
        break;
      case FootPhase::late:
        if (touching || t_s - late_since_s_[f] >= params_.late_touchdown_s || !scheduled_stance) {
          foot = FootPhase::stance;
          touchdown_s_[f] = t_s;
        }
        break;
    }
    plan_.stance[f] = foot == FootPhase::stance || foot == FootPhase::landed_early;
    if (plan_.stance[f]) continue;

    SwingReference& r = plan_.swing[f];
    if (foot == FootPhase::late) {  // the foothold, and on down
      const double depth = kLateTouchdownSpeed_m_s * (t_s - late_since_s_[f]);
      r.position_m = tilt.transpose() * (touchdown_h_[f] - Vec3(0.0, 0.0, depth));
      r.velocity_m_s = tilt.transpose() * Vec3(0.0, 0.0, -kLateTouchdownSpeed_m_s);
      r.acceleration_m_s2.setZero();
      continue;
    }
    // The foothold, re-planned every tick of the swing from this tick's velocity and shift
    // (fixed at lift-off it answered a lateral sway a third of a second late).
    Vec3 correction = pattern_shift_h;
    const Vec3 hip_velocity_h = base_velocity_h + yaw_rate_rad_s * Vec3::UnitZ().cross(nominal_h_[f]);
    correction.head<2>() += 0.5 * stance_duration_s() * hip_velocity_h.head<2>() +
                            params_.velocity_gain_s * (base_velocity_h - commanded_velocity_h).head<2>();
    touchdown_h_[f] = nominal_h_[f] + correction - Vec3(0.0, 0.0, params_.touchdown_depth_m);
    const Profile blend = quintic_blend(s), bump = swing_bump(s);
    const Vec3 span = touchdown_h_[f] - liftoff_h_[f];
    const Vec3 up = Vec3::UnitZ() * params_.step_height_m;
    r.position_m = tilt.transpose() * (liftoff_h_[f] + blend.value * span + bump.value * up);
    r.velocity_m_s = tilt.transpose() * ((blend.rate * span + bump.rate * up) / swing_s);
    r.acceleration_m_s2 = tilt.transpose() * ((blend.curvature * span + bump.curvature * up) / (swing_s * swing_s));
  }

  // Force ramps over the four-feet phase: up from touch-down, down to lift-off once the
  // other diagonal is down, in newtons from the estimated forces (none without them).
  const double ramp_s = std::min(params_.force_ramp_s, (params_.duty_factor - 0.5) * cycle_s);
  double share_n = 0.0;  // one diagonal foot's share of the load now
  if (sensing) {
    for (int f = 0; f < kFeet; ++f) share_n += 0.5 * std::max(0.0, sense->normal_force_n[f]);
  }
  for (int f = 0; f < kFeet; ++f) {
    double cap = kNoCap;
    if (plan_.stance[f] && ramp_s > 0.0 && sensing) {
      const double up = (t_s - touchdown_s_[f]) / ramp_s;
      if (up < 1.0) cap = std::max(0.0, up) * share_n;
      bool other_down = true;
      for (int o = 0; o < kFeet; ++o) other_down = other_down && (kOffset[o] == kOffset[f] || plan_.stance[o]);
      const double phase = plan_.phase[f];
      const double to_liftoff_s = (phase < params_.duty_factor ? params_.duty_factor - phase
                                                                : 1.0 - phase + params_.duty_factor) * cycle_s;
      if (other_down && to_liftoff_s < ramp_s) {
        if (std::isnan(ramp_from_n_[f])) ramp_from_n_[f] = std::max(0.0, sense->normal_force_n[f]);
        cap = std::min(cap, ramp_from_n_[f] * to_liftoff_s / ramp_s);
      } else {
        ramp_from_n_[f] = std::numeric_limits<double>::quiet_NaN();
      }
    } else {
      ramp_from_n_[f] = std::numeric_limits<double>::quiet_NaN();
    }
    plan_.normal_force_cap_n[f] = cap;
  }
  return plan_;
}

}  // namespace springbok::gait
