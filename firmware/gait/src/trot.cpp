#include "springbok/gait/trot.hpp"

#include <cmath>

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

Vec3 static_zmp(const Vec3& com_m, double weight_n, const Vec3& point_m, const Vec3& force_n, const Vec3& torque_nm,
                double ground_z_m) noexcept {
  const double normal = weight_n - force_n.z();
  if (!(normal > 0.0)) return Vec3(com_m.x(), com_m.y(), ground_z_m);
  const double height = point_m.z() - ground_z_m;
  return Vec3((com_m.x() * weight_n + height * force_n.x() - point_m.x() * force_n.z() + torque_nm.y()) / normal,
              (com_m.y() * weight_n + height * force_n.y() - point_m.y() * force_n.z() - torque_nm.x()) / normal,
              ground_z_m);
}

TrotGait::TrotGait(const TrotParams& params) noexcept : params_(params) {}

void TrotGait::start(const std::array<Vec3, kFeet>& nominal_feet_h) noexcept {
  nominal_h_ = nominal_feet_h;
  nominal_centre_h_.setZero();
  for (const Vec3& foot : nominal_feet_h) nominal_centre_h_ += foot / static_cast<double>(kFeet);
  liftoff_h_ = nominal_feet_h;
  touchdown_h_ = nominal_feet_h;
  swinging_.fill(false);
  plan_ = ContactPlan{};
}

// rt: no alloc
const ContactPlan& TrotGait::update(double t_s, const std::array<Vec3, kFeet>& feet_h, const Vec3& base_velocity_h,
                                    const Vec3& pattern_shift_h, const Mat3& tilt, const Vec3& commanded_velocity_h,
                                    double yaw_rate_rad_s) noexcept {
  const double cycles = std::max(0.0, t_s) * params_.step_frequency_hz;
  const double swing_s = swing_duration_s();
  for (int f = 0; f < kFeet; ++f) {
    double phase = cycles - kOffset[f];
    phase -= std::floor(phase);
    plan_.phase[f] = phase;
    const bool stance = phase < params_.duty_factor;
    plan_.stance[f] = stance;
    if (stance) {
      swinging_[f] = false;
      continue;
    }
    if (!swinging_[f]) {  // lift-off: from here to the foothold
      swinging_[f] = true;
      liftoff_h_[f] = feet_h[f];
    }
    // The foothold, re-planned every tick of the swing from this tick's velocity and shift
    // (fixed at lift-off it answered a lateral sway a third of a second late).
    Vec3 correction = pattern_shift_h;
    const Vec3 hip_velocity_h = base_velocity_h + yaw_rate_rad_s * Vec3::UnitZ().cross(nominal_h_[f]);
    correction.head<2>() += 0.5 * stance_duration_s() * hip_velocity_h.head<2>() +
                            params_.velocity_gain_s * (base_velocity_h - commanded_velocity_h).head<2>();
    touchdown_h_[f] = nominal_h_[f] + correction - Vec3(0.0, 0.0, params_.touchdown_depth_m);
    const double s = (phase - params_.duty_factor) / (1.0 - params_.duty_factor);
    const Profile blend = quintic_blend(s), bump = swing_bump(s);
    const Vec3 span = touchdown_h_[f] - liftoff_h_[f];
    const Vec3 up = Vec3::UnitZ() * params_.step_height_m;
    SwingReference& r = plan_.swing[f];
    r.position_m = tilt.transpose() * (liftoff_h_[f] + blend.value * span + bump.value * up);
    r.velocity_m_s = tilt.transpose() * ((blend.rate * span + bump.rate * up) / swing_s);
    r.acceleration_m_s2 = tilt.transpose() * ((blend.curvature * span + bump.curvature * up) / (swing_s * swing_s));
  }
  return plan_;
}

}  // namespace springbok::gait
