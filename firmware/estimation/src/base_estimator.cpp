#include "springbok/estimation/base_estimator.hpp"

#include <algorithm>
#include <cmath>

namespace springbok::est {
namespace {

bool finite(const auto& m) noexcept { return m.allFinite(); }

}  // namespace

const char* to_string(EstimateStatus s) noexcept {
  switch (s) {
    case EstimateStatus::ok: return "ok";
    case EstimateStatus::no_stance: return "no_stance";
    case EstimateStatus::bad_input: return "bad_input";
    case EstimateStatus::not_reset: return "not_reset";
  }
  return "?";
}

const char* to_string(BaseFilter f) noexcept {
  switch (f) {
    case BaseFilter::complementary: return "complementary";
    case BaseFilter::ekf: return "ekf";
  }
  return "?";
}

namespace {
EkfParams ekf_params(const EstimatorParams& p) noexcept {
  EkfParams e = p.ekf;
  e.ground_height_m = p.ground_height_m;
  e.gravity_m_s2 = kGravity_m_s2;
  return e;
}
// q's quaternion coefficients (xyzw) with w >= 0 (q and -q are one orientation).
Eigen::Vector4d with_positive_w(Quat quat) noexcept {
  quat.normalize();
  if (quat.w() < 0.0) quat.coeffs() = -quat.coeffs();
  return quat.coeffs();
}
ImuMounting imu_mounting(const dyn::Model& model) noexcept {
  const dyn::Placement& imu = model.frame_placement[kImuFrame];
  return ImuMounting{imu.rotation, imu.translation};
}
}  // namespace

BaseEstimator::BaseEstimator(const EstimatorParams& params) noexcept
    : params_(params), ekf_(imu_mounting(model_), ekf_params(params)) {
  q_identity_[6] = 1.0;  // quaternion w
}

Mat3 BaseEstimator::trunk_rotation(const Eigen::Quaterniond& world_from_imu) const noexcept {
  return world_from_imu.normalized().toRotationMatrix() * model_.frame_placement[kImuFrame].rotation.transpose();
}

Vec3 BaseEstimator::trunk_angular_rate(const Vec3& imu_rate_rad_s) const noexcept {
  return model_.frame_placement[kImuFrame].rotation * imu_rate_rad_s;
}

void BaseEstimator::kinematics(const VecNj& q_rad) noexcept {
  q_identity_.tail<kNj>() = q_rad;
  dyn::point_jacobians(model_, data_, q_identity_);  // also forward kinematics
}

Vec3 BaseEstimator::contact_point_b(int foot, const Mat3& rot_wb) const noexcept {
  const Vec3 down_b = -rot_wb.row(2).transpose();  // world -z in trunk axes
  return data_.frames[kFootFrames[foot]].translation + params_.foot_radius_m * down_b;
}

// rt: no alloc
Vec3 BaseEstimator::shin_angular_velocity_b(int foot, const Vec3& omega_b, const VecNj& qd) const noexcept {
  const int first = leg_first_joint(foot);
  Vec3 omega = omega_b;
  for (int k = 0; k < kLegJoints; ++k) omega += data_.joint_axis[first + k] * qd[first + k];
  return omega;
}

// rt: no alloc
Vec3 BaseEstimator::leg_odometry_velocity(int foot, const Mat3& rot_wb, const Vec3& omega_b,
                                          const VecNj& qd) const noexcept {
  // At the identity base pose the foot Jacobian's base columns are [I, -[p_f]x] and its
  // joint columns give the centre's velocity in trunk axes.
  const Vec3 down_b = -rot_wb.row(2).transpose();
  const Vec3 trunk_part = data_.J_feet[foot].block<3, 3>(0, 3) * omega_b + omega_b.cross(params_.foot_radius_m * down_b);
  return -(trunk_part + leg_contact_velocity_b(foot, down_b, qd));  // v_B + the contact point's velocity = 0
}

// rt: no alloc
Vec3 BaseEstimator::leg_contact_velocity_b(int foot, const Vec3& down_b, const VecNj& qd) const noexcept {
  const int first = leg_first_joint(foot);
  return data_.J_feet[foot].block<3, kLegJoints>(0, 6 + first) * qd.segment<kLegJoints>(first) +
         shin_angular_velocity_b(foot, Vec3::Zero(), qd).cross(params_.foot_radius_m * down_b);
}

bool BaseEstimator::measurement_ok(const hal::Measurements& m) const noexcept {
  return m.imu.valid && finite(m.imu.orientation.coeffs()) && m.imu.orientation.norm() > 0.5 &&
         finite(m.imu.angular_rate_rad_s) && finite(m.imu.linear_accel_m_s2) && finite(m.q_rad) && finite(m.qd_rad_s);
}

void BaseEstimator::write_state(const hal::Measurements& m, const Mat3& rot_wb, const Vec3& omega_b) noexcept {
  out_.q.head<3>() = position_w_;
  out_.q.segment<4>(3) = with_positive_w(Quat(rot_wb));
  out_.q.tail<kNj>() = m.q_rad;
  out_.v.head<3>() = rot_wb.transpose() * velocity_w_;
  out_.v.segment<3>(3) = omega_b;
  out_.v.tail<kNj>() = m.qd_rad_s;
}

// rt: no alloc
EstimateStatus BaseEstimator::reset(const hal::Measurements& m, const Stance& stance,
                                    const Eigen::Vector2d& xy_m) noexcept {
  int feet = 0;
  for (bool s : stance) feet += s ? 1 : 0;
  if (!measurement_ok(m) || feet == 0) return EstimateStatus::bad_input;
  const Mat3 rot = trunk_rotation(m.imu.orientation);
  kinematics(m.q_rad);
  // The trunk origin above the mean contact point of the stance feet.
  Vec3 mean_contact_w = Vec3::Zero();
  for (int f = 0; f < kFeet; ++f) {
    if (stance[f]) mean_contact_w += rot * contact_point_b(f, rot);
  }
  mean_contact_w /= feet;
  const Vec3 start_w(xy_m.x(), xy_m.y(), params_.ground_height_m - mean_contact_w.z());
  if (params_.filter == BaseFilter::ekf) return reset_ekf(m, stance, rot, start_w);
  position_w_ = start_w;
  velocity_w_.setZero();
  for (int f = 0; f < kFeet; ++f) {
    out_.anchor_world_m[f] = position_w_ + rot * contact_point_b(f, rot);
  }
  stance_prev_ = stance;
  reset_ = true;
  write_state(m, rot, trunk_angular_rate(m.imu.angular_rate_rad_s));
  out_.status = EstimateStatus::ok;
  return out_.status;
}

// rt: no alloc, no block
const BaseEstimate& BaseEstimator::update_kernel(const hal::Measurements& m, const Stance& stance, double dt_s) noexcept {
  if (params_.filter == BaseFilter::ekf) return update_ekf(m, stance, dt_s);
  if (!reset_) {
    out_.status = EstimateStatus::not_reset;
    return out_;
  }
  if (!measurement_ok(m) || !(dt_s > 0.0 && dt_s < 1.0)) {
    out_.status = EstimateStatus::bad_input;  // hold the last estimate
    return out_;
  }
  const Mat3 rot = trunk_rotation(m.imu.orientation);
  const Vec3 omega_b = trunk_angular_rate(m.imu.angular_rate_rad_s);
  kinematics(m.q_rad);

  // Prediction: the IMU's acceleration, moved from the IMU to the trunk origin
  // (centripetal term; the angular-acceleration term is left to the correction).
  if (params_.use_accelerometer) {
    const dyn::Placement& imu = model_.frame_placement[kImuFrame];
    const Vec3 specific_force_w = rot * (imu.rotation * m.imu.linear_accel_m_s2);
    const Vec3 accel_imu_w = specific_force_w + model_.gravity_world_m_s2;
    const Vec3 centripetal_w = rot * omega_b.cross(omega_b.cross(imu.translation));
    velocity_w_ += dt_s * (accel_imu_w - centripetal_w);
  }
  // Correction: leg odometry over the stance feet.
  int feet = 0;
  Vec3 odometry_w = Vec3::Zero();
  Vec3 anchored_w = Vec3::Zero();
  for (int f = 0; f < kFeet; ++f) {
    const Vec3 contact_w = rot * contact_point_b(f, rot);
    if (!stance[f]) continue;
    if (!stance_prev_[f]) {
      out_.anchor_world_m[f] = position_w_ + contact_w;  // touch-down
    } else {
      // Rolling without slipping: the contact point on the ground follows the sphere's
      // centre, d/dt anchor = w_shin x (r z).
      const Vec3 omega_shin_w = rot * shin_angular_velocity_b(f, omega_b, m.qd_rad_s);
      out_.anchor_world_m[f] += dt_s * omega_shin_w.cross(Vec3(0.0, 0.0, params_.foot_radius_m));
    }
    odometry_w += rot * leg_odometry_velocity(f, rot, omega_b, m.qd_rad_s);
    anchored_w += out_.anchor_world_m[f] - contact_w;
    ++feet;
  }
  stance_prev_ = stance;
  if (feet > 0) {
    odometry_w /= feet;
    anchored_w /= feet;
    if (params_.use_accelerometer) {
      const double k = std::min(1.0, params_.velocity_gain_per_s * dt_s);
      velocity_w_ += k * (odometry_w - velocity_w_);
    } else {
      velocity_w_ = odometry_w;
    }
    position_w_ += dt_s * velocity_w_;
    position_w_ += std::min(1.0, params_.position_gain_per_s * dt_s) * (anchored_w - position_w_);
    out_.status = EstimateStatus::ok;
  } else {
    position_w_ += dt_s * velocity_w_;
    out_.status = EstimateStatus::no_stance;
  }
  write_state(m, rot, omega_b);
  return out_;
}

// ---- filter ekf -------------------------------------------------------------------------

// rt: no alloc
void BaseEstimator::ekf_feet(const hal::Measurements& m, const Stance& stance, const Mat3& rot_wb,
                             const Vec3& omega_b, FootMeasurements& feet) const noexcept {
  const Vec3 joint_std = Vec3::Constant(params_.encoder_std_rad);
  const Vec3 down_b = -rot_wb.row(2).transpose();
  for (int f = 0; f < kFeet; ++f) {
    FootMeasurement& fm = feet[static_cast<std::size_t>(f)];
    fm.contact = stance[f];
    fm.contact_point_b_m = contact_point_b(f, rot_wb);
    const auto leg_jacobian = data_.J_feet[f].block<3, kLegJoints>(0, 6 + leg_first_joint(f));
    fm.covariance_b_m2 = contact_point_covariance_b(leg_jacobian, joint_std, params_.kinematics_std_m);
    const Vec3 omega_shin_w = rot_wb * shin_angular_velocity_b(f, omega_b, m.qd_rad_s);
    fm.anchor_velocity_w_m_s = omega_shin_w.cross(Vec3(0.0, 0.0, params_.foot_radius_m));
    // Leg odometry's joint part (the EKF adds the trunk's rate, w x s).
    fm.velocity_valid = true;
    fm.velocity_b_m_s = leg_contact_velocity_b(f, down_b, m.qd_rad_s);
    fm.velocity_covariance_b_m2_s2 =
        contact_point_covariance_b(leg_jacobian, Vec3::Constant(params_.encoder_rate_std_rad_s), 0.0);
  }
}

void BaseEstimator::write_ekf_state(const hal::Measurements& m) noexcept {
  out_.q.head<3>() = ekf_.position_w_m();
  out_.q.segment<4>(3) = with_positive_w(ekf_.orientation_wb());
  out_.q.tail<kNj>() = m.q_rad;
  out_.v.head<3>() = ekf_.velocity_b_m_s();
  out_.v.segment<3>(3) = ekf_.angular_rate_b_rad_s();
  out_.v.tail<kNj>() = m.qd_rad_s;
  for (int f = 0; f < kFeet; ++f) out_.anchor_world_m[f] = ekf_.foot_position_w_m(f);
}

// rt: no alloc
EstimateStatus BaseEstimator::reset_ekf(const hal::Measurements& m, const Stance& stance, const Mat3& rot_wb,
                                        const Vec3& position_w) noexcept {
  FootMeasurements fm{};
  ekf_feet(m, stance, rot_wb, trunk_angular_rate(m.imu.angular_rate_rad_s), fm);
  EkfInitialState start;  // at rest
  start.position_w_m = position_w;
  start.orientation_wb = Quat(rot_wb).normalized();
  // The biases: what the filter learnt when it ran before (a restart after a gap), else the
  // start-up calibration's gyro bias.
  if (ekf_.started()) {
    start.gyro_bias_i_rad_s = ekf_.gyro_bias_i_rad_s();
    start.accel_bias_i_m_s2 = ekf_.accel_bias_i_m_s2();
  } else if (gyro_calibrated_) {
    start.gyro_bias_i_rad_s = calibrated_gyro_bias_;
    start.gyro_bias_std_rad_s = calibrated_gyro_bias_std_rad_s();
  }
  start.has_imu = true;
  start.imu.rate_i_rad_s = m.imu.angular_rate_rad_s;
  start.imu.specific_force_i_m_s2 = m.imu.linear_accel_m_s2;
  if (ekf_.start_at(start, fm) != EkfStatus::ok) return EstimateStatus::bad_input;
  stance_prev_ = stance;
  reset_ = true;
  write_ekf_state(m);
  out_.status = EstimateStatus::ok;
  return out_.status;
}

// rt: no alloc, no block
void BaseEstimator::calibrate(const hal::Measurements& m, double dt_s) noexcept {
  if (params_.filter != BaseFilter::ekf || reset_) return;
  // A gap (no sample, a non-finite one, a bad dt): the recording is no longer one still stretch.
  const ImuSample sample{m.imu.angular_rate_rad_s, m.imu.linear_accel_m_s2};
  const CalibrationStatus s = m.imu.valid ? ekf_.calibrate_sample(sample, dt_s) : CalibrationStatus::bad_sample;
  if (s == CalibrationStatus::bad_sample) {
    ekf_.restart_calibration();
    return;
  }
  if (s != CalibrationStatus::ready) return;
  const CalibrationResult& r = ekf_.evaluate_calibration();
  if (r.status == CalibrationStatus::ready && r.duration_s > 0.0) {
    // Still: into the average of the newest kCalibrationMemory_s of still recordings.
    const double held_s = std::clamp(kCalibrationMemory_s - r.duration_s, 0.0, calibrated_time_s_);
    const double a = r.duration_s / (held_s + r.duration_s);
    calibrated_gyro_bias_ += a * (r.gyro_bias_i_rad_s - calibrated_gyro_bias_);
    calibrated_rate_variance_ += a * (r.gyro_spread_i_rad_s.cwiseAbs2() - calibrated_rate_variance_);
    calibrated_rate_hz_ += a * (r.samples / r.duration_s - calibrated_rate_hz_);
    calibrated_time_s_ = held_s + r.duration_s;
    gyro_calibrated_ = true;
  }
  ekf_.restart_calibration();
}

Vec3 BaseEstimator::calibrated_gyro_bias_std_rad_s() const noexcept {
  if (!gyro_calibrated_) return Vec3::Constant(params_.ekf.initial_gyro_bias_std_rad_s);
  const double samples = calibrated_time_s_ * calibrated_rate_hz_;
  const double floor = params_.ekf.gyro_noise_rad_s_per_sqrt_hz / std::sqrt(calibrated_time_s_);
  return (calibrated_rate_variance_ / samples).cwiseSqrt().cwiseMax(floor);
}

// rt: no alloc, no block
const BaseEstimate& BaseEstimator::update_ekf(const hal::Measurements& m, const Stance& stance, double dt_s) noexcept {
  if (!reset_) {
    out_.status = EstimateStatus::not_reset;
    return out_;
  }
  if (!measurement_ok(m)) {
    out_.status = EstimateStatus::bad_input;  // hold the last estimate
    return out_;
  }
  kinematics(m.q_rad);
  EkfInput in;
  in.imu.rate_i_rad_s = m.imu.angular_rate_rad_s;
  in.imu.specific_force_i_m_s2 = m.imu.linear_accel_m_s2;
  in.orientation_valid = true;
  in.orientation_wi = m.imu.orientation;
  // The feet at the filter's last orientation and rate (this tick's are what it computes).
  ekf_feet(m, stance, ekf_.rotation_wb(), ekf_.angular_rate_b_rad_s(), in.feet);
  stance_prev_ = stance;
  switch (ekf_.update(in, dt_s)) {
    case EkfStatus::ok: out_.status = EstimateStatus::ok; break;
    case EkfStatus::no_anchor: out_.status = EstimateStatus::no_stance; break;
    case EkfStatus::not_started: out_.status = EstimateStatus::not_reset; return out_;
    case EkfStatus::bad_input:
    case EkfStatus::numerical_fault: out_.status = EstimateStatus::bad_input; return out_;  // held
  }
  write_ekf_state(m);
  return out_;
}

}  // namespace springbok::est
