#include "springbok/estimation/inertial_kinematic_ekf.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>

#include "springbok/dynamics/small_cholesky.hpp"

namespace springbok::est {
namespace {

using Vec3 = Eigen::Vector3d;
using Mat3 = Eigen::Matrix3d;
using Quat = Eigen::Quaterniond;
constexpr int kN = kEkfErrorDim;

Mat3 skew(const Vec3& a) noexcept {
  Mat3 m;
  m << 0.0, -a.z(), a.y(), a.z(), 0.0, -a.x(), -a.y(), a.x(), 0.0;
  return m;
}

// Exp of a rotation vector, as a unit quaternion.
Quat quat_exp(const Vec3& phi) noexcept {
  const double angle = phi.norm();
  // sin(angle / 2) / angle, its series below where the division loses digits.
  const double k = angle < 1e-4 ? 0.5 - angle * angle / 48.0 : std::sin(0.5 * angle) / angle;
  return Quat(std::cos(0.5 * angle), k * phi.x(), k * phi.y(), k * phi.z());
}

double wrap_pi(double a) noexcept { return std::remainder(a, 2.0 * std::numbers::pi); }

// R = Rz(yaw) Ry(pitch) Rx(roll).
Mat3 rotation_zyx(double yaw, double pitch, double roll) noexcept {
  return (Eigen::AngleAxisd(yaw, Vec3::UnitZ()) * Eigen::AngleAxisd(pitch, Vec3::UnitY()) *
          Eigen::AngleAxisd(roll, Vec3::UnitX()))
      .toRotationMatrix();
}

bool gate_enabled(double chi2) noexcept { return chi2 > 0.0 && std::isfinite(chi2); }

// During a tick only P's lower triangle is kept (the prediction and the updates write it
// alone); condition_covariance mirrors it at the tick's end. Columns c..c+2 of the symmetric
// matrix, from the lower triangle.
// Inlined (five feed each foot's update): for the state's fixed blocks the loops' lengths are constants.
[[gnu::always_inline]] inline void sym_cols3(const EkfCovariance& P, int c, Eigen::Matrix<double, kN, 3>& out) noexcept {
  for (int k = 0; k < 3; ++k) {
    const int col = c + k;
    for (int r = 0; r < col; ++r) out(r, k) = P(col, r);
    for (int r = col; r < kN; ++r) out(r, k) = P(r, col);
  }
}

// P -= U U^T on the lower triangle, by blocks of four rows 3 + 4m .. 6 + 4m: column j from the
// block that holds its diagonal on (the rows of that block above the diagonal land in the
// upper triangle, which the tick does not read); rows 0..2 of the first three columns one by
// one.
template <int M>
void lower_rank_update(EkfCovariance& P, const Eigen::Map<Eigen::Matrix<double, kN, M>>& u) noexcept {
  static_assert(kN % 4 == 3, "rows 3 .. kN-1 are whole blocks of four");
  const double* uc = u.data();
  for (int j = 0; j < kN; ++j) {
    double c[M];
    for (int k = 0; k < M; ++k) c[k] = uc[k * kN + j];
    double* col = P.data() + static_cast<std::ptrdiff_t>(j) * kN;
    for (int i = j; i < 3; ++i) {
      double sum = 0.0;
      for (int k = 0; k < M; ++k) sum += c[k] * uc[k * kN + i];
      col[i] -= sum;
    }
    for (int i = j < 3 ? 3 : 3 + ((j - 3) & ~3); i < kN; i += 4) {
      double acc[4] = {col[i], col[i + 1], col[i + 2], col[i + 3]};
      for (int k = 0; k < M; ++k)
        for (int r = 0; r < 4; ++r) acc[r] -= c[k] * uc[k * kN + i + r];
      for (int r = 0; r < 4; ++r) col[i + r] = acc[r];
    }
  }
}

}  // namespace

const char* to_string(EkfStatus s) noexcept {
  switch (s) {
    case EkfStatus::ok: return "ok";
    case EkfStatus::no_anchor: return "no_anchor";
    case EkfStatus::bad_input: return "bad_input";
    case EkfStatus::not_started: return "not_started";
    case EkfStatus::numerical_fault: return "numerical_fault";
  }
  return "?";
}

const char* to_string(CalibrationStatus s) noexcept {
  switch (s) {
    case CalibrationStatus::empty: return "empty";
    case CalibrationStatus::collecting: return "collecting";
    case CalibrationStatus::ready: return "ready";
    case CalibrationStatus::too_few_samples: return "too_few_samples";
    case CalibrationStatus::unstill: return "unstill";
    case CalibrationStatus::bad_gravity: return "bad_gravity";
    case CalibrationStatus::bad_sample: return "bad_sample";
  }
  return "?";
}

const char* to_string(FootMode m) noexcept {
  switch (m) {
    case FootMode::free: return "free";
    case FootMode::anchored: return "anchored";
    case FootMode::rejected: return "rejected";
  }
  return "?";
}

// rt: no alloc
Mat3 contact_point_covariance_b(const Mat3& leg_jacobian_b_m_per_rad, const Vec3& joint_std_rad,
                                double model_std_m) noexcept {
  const Vec3 var = joint_std_rad.cwiseProduct(joint_std_rad);
  return leg_jacobian_b_m_per_rad * var.asDiagonal() * leg_jacobian_b_m_per_rad.transpose() +
         model_std_m * model_std_m * Mat3::Identity();
}

InertialKinematicEkf::InertialKinematicEkf(const ImuMounting& mounting, const EkfParams& params) noexcept
    : mounting_(mounting), params_(params) {}

// ---- calibration ------------------------------------------------------------------------

// rt: no alloc
CalibrationStatus InertialKinematicEkf::calibrate_sample(const ImuSample& imu, double dt_s) noexcept {
  if (!imu.rate_i_rad_s.allFinite() || !imu.specific_force_i_m_s2.allFinite() || !(dt_s > 0.0) ||
      !(dt_s <= params_.max_dt_s)) {
    return CalibrationStatus::bad_sample;
  }
  ++cal_n_;
  cal_time_s_ += dt_s;
  cal_last_ = imu;
  const double n = cal_n_;
  const Vec3 dw = imu.rate_i_rad_s - cal_w_mean_;
  cal_w_mean_ += dw / n;
  cal_w_m2_ += dw.cwiseProduct(imu.rate_i_rad_s - cal_w_mean_);
  const Vec3 df = imu.specific_force_i_m_s2 - cal_f_mean_;
  cal_f_mean_ += df / n;
  cal_f_m2_ += df.cwiseProduct(imu.specific_force_i_m_s2 - cal_f_mean_);
  return cal_time_s_ >= params_.calibration_time_s ? CalibrationStatus::ready : CalibrationStatus::collecting;
}

void InertialKinematicEkf::restart_calibration() noexcept {
  cal_n_ = 0;
  cal_time_s_ = 0.0;
  cal_w_mean_.setZero();
  cal_w_m2_.setZero();
  cal_f_mean_.setZero();
  cal_f_m2_.setZero();
  calibration_ = CalibrationResult{};
}

// rt: no alloc
const CalibrationResult& InertialKinematicEkf::evaluate_calibration() noexcept {
  CalibrationResult& c = calibration_;
  c = CalibrationResult{};
  c.samples = cal_n_;
  c.duration_s = cal_time_s_;
  if (cal_n_ == 0) return c;  // empty
  c.gyro_bias_i_rad_s = cal_w_mean_;
  c.specific_force_i_m_s2 = cal_f_mean_;
  if (cal_n_ > 1) {
    c.gyro_spread_i_rad_s = (cal_w_m2_ / (cal_n_ - 1)).cwiseSqrt();
    c.specific_force_spread_i_m_s2 = (cal_f_m2_ / (cal_n_ - 1)).cwiseSqrt();
  }
  // The trunk's up direction in trunk axes: R^T e_z = (-sin pitch, cos pitch sin roll, cos pitch cos roll).
  const Vec3 up_b = mounting_.rotation_bi * cal_f_mean_;
  if (up_b.norm() > 0.0) {
    c.roll_rad = std::atan2(up_b.y(), up_b.z());
    c.pitch_rad = std::atan2(-up_b.x(), std::hypot(up_b.y(), up_b.z()));
  }
  if (cal_n_ < std::max(params_.min_calibration_samples, 2)) {
    c.status = CalibrationStatus::too_few_samples;
  } else if (c.gyro_spread_i_rad_s.maxCoeff() > params_.max_gyro_spread_rad_s ||
             c.specific_force_spread_i_m_s2.maxCoeff() > params_.max_accel_spread_m_s2) {
    c.status = CalibrationStatus::unstill;
  } else if (!(std::abs(cal_f_mean_.norm() - params_.gravity_m_s2) <= params_.max_gravity_error_m_s2)) {
    c.status = CalibrationStatus::bad_gravity;
  } else {
    c.status = cal_time_s_ >= params_.calibration_time_s ? CalibrationStatus::ready : CalibrationStatus::collecting;
  }
  return c;
}

// ---- start ------------------------------------------------------------------------------

namespace {
bool feet_ok(const FootMeasurements& feet, int& contacts) noexcept {
  contacts = 0;
  for (const FootMeasurement& m : feet) {
    if (!m.contact) continue;
    if (!m.contact_point_b_m.allFinite() || !m.covariance_b_m2.allFinite()) return false;
    ++contacts;
  }
  return true;
}
}  // namespace

// rt: no alloc
EkfStatus InertialKinematicEkf::start_from_calibration(const FootMeasurements& feet, const Eigen::Vector2d& xy_m,
                                                       double yaw_rad) noexcept {
  int contacts = 0;
  if (!feet_ok(feet, contacts) || !xy_m.allFinite() || !std::isfinite(yaw_rad)) return EkfStatus::bad_input;
  const CalibrationResult& c = evaluate_calibration();
  if (c.status != CalibrationStatus::ready && c.status != CalibrationStatus::collecting) return EkfStatus::not_started;
  if (contacts == 0) return EkfStatus::no_anchor;

  const Mat3 rot = rotation_zyx(yaw_rad, c.pitch_rad, c.roll_rad);
  double contact_z = 0.0;
  for (const FootMeasurement& m : feet) {
    if (m.contact) contact_z += (rot * m.contact_point_b_m).z();
  }
  contact_z /= contacts;

  Filter& x = x_;
  x = Filter{};
  x.p_b = Vec3(xy_m.x(), xy_m.y(), params_.ground_height_m - contact_z);
  x.v_b.setZero();
  x.q = Quat(rot).normalized();
  x.b_a.setZero();
  x.b_g = c.gyro_bias_i_rad_s;

  // Prior (p and v the trunk origin's here: finish_start maps them to the IMU point's).
  // Standing still, the recorded tilt is off by b_a's horizontal part over g:
  // dth = J db_a, J = [e_z]x C / g (R = Exp(dth) R^, C = R^ R_BI).
  const double g = params_.gravity_m_s2;
  const Mat3 c_wi = rot * mounting_.rotation_bi;
  const Mat3 jac = skew(Vec3::UnitZ()) * c_wi / g;
  const double var_ba = params_.initial_accel_bias_std_m_s2 * params_.initial_accel_bias_std_m_s2;
  // The mean specific force's own noise: sigma_a / sqrt(T) over g, in tilt.
  const double t = std::max(c.duration_s, 1e-3);
  const double tilt_noise = params_.accel_noise_m_s2_per_sqrt_hz / (g * std::sqrt(t));
  EkfCovariance& P = x.P;
  P.setZero();
  P.block<3, 3>(kEkfP, kEkfP) = Mat3::Identity() * params_.initial_position_std_m * params_.initial_position_std_m;
  P.block<3, 3>(kEkfV, kEkfV) = Mat3::Identity() * params_.initial_velocity_std_m_s * params_.initial_velocity_std_m_s;
  P.block<3, 3>(kEkfTh, kEkfTh) = var_ba * jac * jac.transpose();
  P(kEkfTh + 0, kEkfTh + 0) += tilt_noise * tilt_noise;
  P(kEkfTh + 1, kEkfTh + 1) += tilt_noise * tilt_noise;
  P(kEkfTh + 2, kEkfTh + 2) += params_.initial_yaw_std_rad * params_.initial_yaw_std_rad;
  P.block<3, 3>(kEkfTh, kEkfBa) = var_ba * jac;
  P.block<3, 3>(kEkfBa, kEkfTh) = var_ba * jac.transpose();
  P.block<3, 3>(kEkfBa, kEkfBa) = Mat3::Identity() * var_ba;
  // The mean rate's error: the samples' spread over sqrt(n), at least the datasheet's noise over sqrt(T).
  const double floor_bg = params_.gyro_noise_rad_s_per_sqrt_hz / std::sqrt(t);
  for (int k = 0; k < 3; ++k) {
    const double s = c.gyro_spread_i_rad_s[k];
    P(kEkfBg + k, kEkfBg + k) = std::max(s * s / c.samples, floor_bg * floor_bg);
  }
  const EkfStatus st = finish_start(feet, Vec3::Zero());  // at rest: w = 0
  x.last_imu = cal_last_;  // the first tick's previous sample
  x.have_last_imu = true;
  return st;
}

// rt: no alloc
EkfStatus InertialKinematicEkf::start_at(const EkfInitialState& s, const FootMeasurements& feet) noexcept {
  int contacts = 0;
  if (!feet_ok(feet, contacts) || !s.position_w_m.allFinite() || !s.velocity_w_m_s.allFinite() ||
      !s.orientation_wb.coeffs().allFinite() || !(s.orientation_wb.norm() > 0.5) || !s.accel_bias_i_m_s2.allFinite() ||
      !s.gyro_bias_i_rad_s.allFinite()) {
    return EkfStatus::bad_input;
  }
  if (contacts == 0) return EkfStatus::no_anchor;
  Filter& x = x_;
  x = Filter{};
  x.p_b = s.position_w_m;
  x.v_b = s.velocity_w_m_s;
  x.q = s.orientation_wb.normalized();
  x.b_a = s.accel_bias_i_m_s2;
  x.b_g = s.gyro_bias_i_rad_s;
  EkfVector sd;
  sd << Vec3::Constant(params_.initial_position_std_m), Vec3::Constant(params_.initial_velocity_std_m_s),
      params_.initial_tilt_std_rad, params_.initial_tilt_std_rad, params_.initial_yaw_std_rad,
      Eigen::Matrix<double, 12, 1>::Zero(), Vec3::Constant(params_.initial_accel_bias_std_m_s2),
      (s.gyro_bias_std_rad_s.array() > 0.0)
          .select(s.gyro_bias_std_rad_s, Vec3::Constant(params_.initial_gyro_bias_std_rad_s));
  x.P = sd.cwiseProduct(sd).asDiagonal();
  const bool imu = s.has_imu && s.imu.rate_i_rad_s.allFinite() && s.imu.specific_force_i_m_s2.allFinite();
  const Vec3 w_b = imu ? Vec3(mounting_.rotation_bi * (s.imu.rate_i_rad_s - x.b_g)) : Vec3::Zero();
  const EkfStatus st = finish_start(feet, w_b);
  if (imu) {
    x.last_imu = s.imu;
    x.have_last_imu = true;
  }
  return st;
}

// rt: no alloc
EkfStatus InertialKinematicEkf::finish_start(const FootMeasurements& feet, const Vec3& w_b) noexcept {
  Filter& x = x_;
  const Mat3 rot = x.q.toRotationMatrix();
  const Vec3& r = mounting_.position_bi_m;
  // x.P holds the prior of (p_B, v_B, th, -, b_a, b_g). The state's from it, to first order:
  //   p = p_B + R r:          dp = dp_B - [R r]x dth
  //   v = v_B + R (w x r):    dv = dv_B - [R (w x r)]x dth + R [r]x R_BI db_g
  //   d_i = p_B + R s_i:      dd_i = dp_B - [R s_i]x dth + R ds_i  (a free foot: decoupled, its reset std)
  x.p = x.p_b + rot * r;
  x.v = x.v_b + rot * w_b.cross(r);
  EkfCovariance map = EkfCovariance::Identity();
  map.block<3, 3>(kEkfP, kEkfTh) = -skew(rot * r);
  map.block<3, 3>(kEkfV, kEkfTh) = -skew(rot * w_b.cross(r));
  map.block<3, 3>(kEkfV, kEkfBg) = rot * skew(r) * mounting_.rotation_bi;
  for (int f = 0; f < kEkfFeet; ++f) {
    const FootMeasurement& m = feet[idx(f)];
    const int i = ekf_foot_index(f);
    x.d[idx(f)] = x.p_b + rot * (m.contact_point_b_m.allFinite() ? m.contact_point_b_m : Vec3::Zero());
    map.block<3, 3>(i, i).setZero();
    if (m.contact) {
      map.block<3, 3>(i, kEkfP).setIdentity();
      map.block<3, 3>(i, kEkfTh) = -skew(rot * m.contact_point_b_m);
    }
  }
  const EkfCovariance mp = map * x.P;
  x.P.noalias() = mp * map.transpose();
  const double reset_var = params_.foot_reset_std_m * params_.foot_reset_std_m;
  for (int f = 0; f < kEkfFeet; ++f) {
    const FootMeasurement& m = feet[idx(f)];
    const int i = ekf_foot_index(f);
    if (m.contact) {
      x.P.block<3, 3>(i, i) += rot * m.covariance_b_m2 * rot.transpose();
      x.mode[idx(f)] = FootMode::anchored;
    } else {
      x.P.block<3, 3>(i, i) = Mat3::Identity() * reset_var;
      x.mode[idx(f)] = FootMode::free;
    }
  }
  x.have_last_imu = false;
  condition_covariance();
  write_outputs(w_b);
  saved_ = x_;
  started_ = true;
  status_ = EkfStatus::ok;
  return status_;
}

// rt: no alloc
void InertialKinematicEkf::write_outputs(const Vec3& w_b) noexcept {
  Filter& x = x_;
  const Mat3 rot = x.q.toRotationMatrix();
  const Vec3& r = mounting_.position_bi_m;
  x.w_b = w_b;
  x.p_b = x.p - rot * r;
  x.v_b = x.v - rot * w_b.cross(r);
}

// rt: no alloc
Mat3 InertialKinematicEkf::trunk_position_covariance_w() const noexcept {
  const Mat3 x = skew(x_.q.toRotationMatrix() * mounting_.position_bi_m);  // dp_B = dp + [R r]x dth
  const EkfCovariance& P = x_.P;
  Mat3 c = P.block<3, 3>(kEkfP, kEkfP) + x * P.block<3, 3>(kEkfTh, kEkfP) + P.block<3, 3>(kEkfP, kEkfTh) * x.transpose() +
           x * P.block<3, 3>(kEkfTh, kEkfTh) * x.transpose();
  return 0.5 * (c + c.transpose());
}

// rt: no alloc
Mat3 InertialKinematicEkf::trunk_velocity_covariance_w() const noexcept {
  // dv_B = dv + [R (w x r)]x dth - R [r]x R_BI (db_g + n_g)
  const Mat3 rot = x_.q.toRotationMatrix();
  const Vec3& r = mounting_.position_bi_m;
  Eigen::Matrix<double, 3, kN> jac = Eigen::Matrix<double, 3, kN>::Zero();
  jac.block<3, 3>(0, kEkfV).setIdentity();
  jac.block<3, 3>(0, kEkfTh) = skew(rot * x_.w_b.cross(r));
  const Mat3 lever = rot * skew(r);
  jac.block<3, 3>(0, kEkfBg) = -lever * mounting_.rotation_bi;
  const double sample_var = params_.gyro_noise_rad_s_per_sqrt_hz * params_.gyro_noise_rad_s_per_sqrt_hz / x_.last_dt_s;
  const Mat3 c = jac * x_.P * jac.transpose() + sample_var * lever * lever.transpose();
  return 0.5 * (c + c.transpose());
}

// ---- the tick ---------------------------------------------------------------------------

bool InertialKinematicEkf::input_ok(const EkfInput& in, double dt_s) const noexcept {
  if (!(dt_s > 0.0) || !(dt_s <= params_.max_dt_s)) return false;
  if (!in.imu.rate_i_rad_s.allFinite() || !in.imu.specific_force_i_m_s2.allFinite()) return false;
  for (const FootMeasurement& m : in.feet) {
    if (m.contact && (!m.contact_point_b_m.allFinite() || !m.covariance_b_m2.allFinite() ||
                      !m.anchor_velocity_w_m_s.allFinite())) {
      return false;
    }
    if (m.contact && m.velocity_valid && params_.use_leg_velocity &&
        (!m.velocity_b_m_s.allFinite() || !m.velocity_covariance_b_m2_s2.allFinite())) {
      return false;
    }
  }
  if (params_.orientation_aid == OrientationAid::yaw && in.orientation_valid &&
      (!in.orientation_wi.coeffs().allFinite() || !(in.orientation_wi.norm() > 0.5))) {
    return false;
  }
  return true;
}

// rt: no alloc, no block
EkfStatus InertialKinematicEkf::update(const EkfInput& in, double dt_s) noexcept {
  if (!started_) {
    status_ = EkfStatus::not_started;
    return status_;
  }
  if (!input_ok(in, dt_s)) {
    status_ = EkfStatus::bad_input;
    return status_;
  }
  saved_ = x_;
  predict(in, dt_s);

  const bool gate = gate_enabled(params_.slip_gate_chi2);
  int fused = 0;
  for (int f = 0; f < kEkfFeet; ++f) {
    const FootMeasurement& m = in.feet[idx(f)];
    FootMode& mode = x_.mode[idx(f)];
    if (!m.contact) {
      mode = FootMode::free;
      x_.probe_count[idx(f)] = 0;
      x_.mahalanobis2[idx(f)] = 0.0;
      continue;
    }
    if (mode == FootMode::free) {  // touch-down
      reset_foot(f, m);
      mode = FootMode::anchored;
    } else if (mode == FootMode::rejected) {
      if (!retest_foot(f, m, dt_s)) continue;
      reset_foot(f, m);  // standing still again: a new anchor, as at a touch-down
      mode = FootMode::anchored;
    }
    switch (fuse_foot(f, m, mounting_.rotation_bi * (in.imu.rate_i_rad_s - x_.b_g), dt_s, gate)) {
      case Fused::yes: ++fused; break;
      case Fused::gated:
        mode = FootMode::rejected;
        x_.probe_count[idx(f)] = 0;
        (void)retest_foot(f, m, dt_s);  // this tick's position starts the stillness test
        break;
      case Fused::failed: break;
    }
  }
  if (params_.orientation_aid == OrientationAid::yaw && in.orientation_valid) fuse_yaw(in.orientation_wi);
  bool finite = condition_covariance();
  write_outputs(mounting_.rotation_bi * (in.imu.rate_i_rad_s - x_.b_g));
  x_.last_dt_s = dt_s;

  finite = finite && x_.p.allFinite() && x_.v.allFinite() && x_.q.coeffs().allFinite() && x_.b_a.allFinite() &&
           x_.b_g.allFinite() && x_.p_b.allFinite() && x_.v_b.allFinite();
  for (const Vec3& d : x_.d) finite = finite && d.allFinite();
  if (!finite) {
    x_ = saved_;
    status_ = EkfStatus::numerical_fault;
    return status_;
  }
  status_ = fused > 0 ? EkfStatus::ok : EkfStatus::no_anchor;
  return status_;
}

// rt: no alloc
void InertialKinematicEkf::predict(const EkfInput& in, double dt) noexcept {
  Filter& x = x_;
  const ImuSample& imu = in.imu;
  const Mat3& rbi = mounting_.rotation_bi;
  const ImuSample& prev = x.have_last_imu ? x.last_imu : imu;
  const Vec3 w0 = rbi * (prev.rate_i_rad_s - x.b_g);
  const Vec3 w1 = rbi * (imu.rate_i_rad_s - x.b_g);
  const Vec3 f0 = rbi * (prev.specific_force_i_m_s2 - x.b_a);
  const Vec3 f1 = rbi * (imu.specific_force_i_m_s2 - x.b_a);

  // ---- mean --------------------------------------------------------------------------
  const Mat3 r0 = x.q.toRotationMatrix();
  const Vec3 turn = 0.5 * dt * (w0 + w1) + (dt * dt / 12.0) * w0.cross(w1);
  x.q = (x.q * quat_exp(turn)).normalized();
  const Mat3 r1 = x.q.toRotationMatrix();
  const Vec3 g_w(0.0, 0.0, -params_.gravity_m_s2);
  const Vec3 fw0 = r0 * f0, fw1 = r1 * f1;
  const Vec3 a0 = fw0 + g_w, a1 = fw1 + g_w;
  x.p += dt * x.v + (dt * dt / 6.0) * (2.0 * a0 + a1);
  x.v += (0.5 * dt) * (a0 + a1);
  x.last_imu = imu;
  x.have_last_imu = true;
  for (int f = 0; f < kEkfFeet; ++f) {  // an anchored foot's known motion (a rolling contact)
    const FootMeasurement& m = in.feet[idx(f)];
    if (m.contact && x.mode[idx(f)] == FootMode::anchored) x.d[idx(f)] += dt * m.anchor_velocity_w_m_s;
  }

  // ---- covariance: P <- Phi P Phi^T + Q, Phi's nonzero blocks only -----------------------
  const Mat3 fx = skew(0.5 * (fw0 + fw1));
  const Mat3 c = r1 * rbi;
  const double dt2 = dt * dt;
  const Mat3 phi_pth = (-0.5 * dt2) * fx, phi_pba = (-0.5 * dt2) * c;
  const Mat3 phi_vth = -dt * fx, phi_vba = -dt * c, phi_vbg = (0.5 * dt2) * fx * c;
  const Mat3 phi_thbg = -dt * c;
  EkfCovariance& P = x.P;  // full (symmetric) at the tick's start
  // Phi = I + N with N nonzero in rows 0..8 only. G = P Phi^T differs from P in its first 9
  // columns, b = P_{:,0:9} + P N_{0:9,:}^T; P' = Phi G differs from G in its first 9 rows.
  // P' therefore differs from P in its first 9 columns (and rows): those are b with rows 0..8
  // plus N b. Only the lower triangle is written: the band P(0:9, 9:) is left stale.
  Eigen::Matrix<double, kN, 9> b = P.leftCols<9>();
  b.middleCols<3>(kEkfP) += dt * P.middleCols<3>(kEkfV);
  b.middleCols<3>(kEkfP).noalias() += P.middleCols<3>(kEkfTh) * phi_pth.transpose();
  b.middleCols<3>(kEkfP).noalias() += P.middleCols<3>(kEkfBa) * phi_pba.transpose();
  b.middleCols<3>(kEkfV).noalias() += P.middleCols<3>(kEkfTh) * phi_vth.transpose();
  b.middleCols<3>(kEkfV).noalias() += P.middleCols<3>(kEkfBa) * phi_vba.transpose();
  b.middleCols<3>(kEkfV).noalias() += P.middleCols<3>(kEkfBg) * phi_vbg.transpose();
  b.middleCols<3>(kEkfTh).noalias() += P.middleCols<3>(kEkfBg) * phi_thbg.transpose();
  Eigen::Matrix<double, 9, 9> top = b.topRows<9>();
  top.middleRows<3>(kEkfP) += dt * b.middleRows<3>(kEkfV);
  top.middleRows<3>(kEkfP).noalias() += phi_pth * b.middleRows<3>(kEkfTh);
  top.middleRows<3>(kEkfP).noalias() += phi_pba * b.middleRows<3>(kEkfBa);
  top.middleRows<3>(kEkfV).noalias() += phi_vth * b.middleRows<3>(kEkfTh);
  top.middleRows<3>(kEkfV).noalias() += phi_vba * b.middleRows<3>(kEkfBa);
  top.middleRows<3>(kEkfV).noalias() += phi_vbg * b.middleRows<3>(kEkfBg);
  top.middleRows<3>(kEkfTh).noalias() += phi_thbg * b.middleRows<3>(kEkfBg);
  b.topRows<9>() = top;
  P.leftCols<9>() = b;

  const double qa = params_.accel_noise_m_s2_per_sqrt_hz * params_.accel_noise_m_s2_per_sqrt_hz;
  const double qg = params_.gyro_noise_rad_s_per_sqrt_hz * params_.gyro_noise_rad_s_per_sqrt_hz;
  const double qba = params_.accel_bias_walk_m_s3_per_sqrt_hz * params_.accel_bias_walk_m_s3_per_sqrt_hz;
  const double qbg = params_.gyro_bias_walk_rad_s2_per_sqrt_hz * params_.gyro_bias_walk_rad_s2_per_sqrt_hz;
  const double qd_anchored = params_.foot_anchored_walk_m_s_per_sqrt_hz * params_.foot_anchored_walk_m_s_per_sqrt_hz;
  const double qd_free = params_.foot_free_walk_m_s_per_sqrt_hz * params_.foot_free_walk_m_s_per_sqrt_hz;
  for (int k = 0; k < 3; ++k) {
    P(kEkfP + k, kEkfP + k) += qa * dt2 * dt / 3.0;
    P(kEkfP + k, kEkfV + k) += qa * dt2 / 2.0;
    P(kEkfV + k, kEkfP + k) += qa * dt2 / 2.0;
    P(kEkfV + k, kEkfV + k) += qa * dt;
    P(kEkfTh + k, kEkfTh + k) += qg * dt;
    P(kEkfBa + k, kEkfBa + k) += qba * dt;
    P(kEkfBg + k, kEkfBg + k) += qbg * dt;
    for (int f = 0; f < kEkfFeet; ++f) {
      const int i = ekf_foot_index(f) + k;
      P(i, i) += (x.mode[idx(f)] == FootMode::anchored ? qd_anchored : qd_free) * dt;
    }
  }
}

// rt: no alloc
void InertialKinematicEkf::reset_foot(int foot, const FootMeasurement& m) noexcept {
  Filter& x = x_;
  const int i = ekf_foot_index(foot);
  x.d[idx(foot)] = x.p + x.q.toRotationMatrix() * (m.contact_point_b_m - mounting_.position_bi_m);
  x.P.middleRows<3>(i).setZero();
  x.P.middleCols<3>(i).setZero();
  x.P.block<3, 3>(i, i) = Mat3::Identity() * (params_.foot_reset_std_m * params_.foot_reset_std_m);
  x.probe_count[idx(foot)] = 0;
}

// rt: no alloc
InertialKinematicEkf::Fused InertialKinematicEkf::fuse_foot(int foot, const FootMeasurement& m, const Vec3& w_b,
                                                            double dt_s, bool gate) noexcept {
  const bool velocity = params_.use_leg_velocity && m.velocity_valid;
  if (params_.use_ground) {
    return velocity ? fuse_foot_rows<4, true>(foot, m, w_b, dt_s, gate) : fuse_foot_rows<4, false>(foot, m, w_b, dt_s, gate);
  }
  return velocity ? fuse_foot_rows<3, true>(foot, m, w_b, dt_s, gate) : fuse_foot_rows<3, false>(foot, m, w_b, dt_s, gate);
}

// rt: no alloc
template <int K, bool kVelocity>
InertialKinematicEkf::Fused InertialKinematicEkf::fuse_foot_rows(int foot, const FootMeasurement& m, const Vec3& w_b,
                                                                 double dt_s, bool gate) noexcept {
  constexpr int M = K + (kVelocity ? 3 : 0);
  Filter& x = x_;
  const EkfCovariance& P = x.P;  // its lower triangle (see sym_cols3)
  const int i = ekf_foot_index(foot);
  const Mat3 rot = x.q.toRotationMatrix();
  const Vec3 a = m.contact_point_b_m - mounting_.position_bi_m;
  const Vec3 rel = x.d[idx(foot)] - x.p;  // predicted R^ (s - r)
  const Mat3 hth = skew(rel);             // the kinematics' dth block

  // P H^T and S = H P H^T + N. Kinematics: H = [-I (p), [rel]x (th), I (d_i)]; the ground
  // row (K = 4): e_z on dd_i; the leg velocity (rows K..K+2): H = [I (v), -[R^ c]x (th),
  // R^ [a]x R_BI (b_g)].
  Eigen::Matrix<double, kN, 3> cols_p, cols_th, cols_d;
  sym_cols3(P, kEkfP, cols_p);
  sym_cols3(P, kEkfTh, cols_th);
  sym_cols3(P, i, cols_d);
  Eigen::Matrix<double, kN, M> pht;
  pht.template leftCols<3>() = cols_d - cols_p;
  pht.template leftCols<3>().noalias() += cols_th * hth.transpose();
  Eigen::Matrix<double, M, M> s;
  Mat3 s3 = pht.template middleRows<3>(i).template leftCols<3>() - pht.template middleRows<3>(kEkfP).template leftCols<3>();
  s3.noalias() += hth * pht.template middleRows<3>(kEkfTh).template leftCols<3>();
  s.template topLeftCorner<3, 3>() = 0.5 * (s3 + s3.transpose()) + rot * m.covariance_b_m2 * rot.transpose();
  Eigen::Matrix<double, M, 1> innovation;
  innovation.template head<3>() = rot * a - rel;
  if constexpr (K == 4) {
    pht.col(3) = cols_d.col(2);
    s.template block<1, 3>(3, 0) = pht.template leftCols<3>().row(i + 2);
    s.template block<3, 1>(0, 3) = s.template block<1, 3>(3, 0).transpose();
    s(3, 3) = cols_d(i + 2, 2) + params_.ground_std_m * params_.ground_std_m;
    innovation[3] = params_.ground_height_m - x.d[idx(foot)].z();
  }
  if constexpr (kVelocity) {
    const Vec3 c_w = rot * (w_b.cross(a) + m.velocity_b_m_s);
    const Mat3 hthv = -skew(c_w);
    const Mat3 ax = skew(a);
    const Mat3 hbg = rot * ax * mounting_.rotation_bi;
    const double qg = params_.gyro_noise_rad_s_per_sqrt_hz * params_.gyro_noise_rad_s_per_sqrt_hz / dt_s;
    const double model = params_.leg_velocity_std_m_s * params_.leg_velocity_std_m_s;
    Mat3 noise_b = m.velocity_covariance_b_m2_s2;
    noise_b.noalias() += qg * ax * ax.transpose();
    Eigen::Matrix<double, kN, 3> cols_v, cols_bg;
    sym_cols3(P, kEkfV, cols_v);
    sym_cols3(P, kEkfBg, cols_bg);
    auto pv = pht.template middleCols<3>(K);
    pv = cols_v;
    pv.noalias() += cols_th * hthv.transpose();
    pv.noalias() += cols_bg * hbg.transpose();
    Mat3 sv = pv.template middleRows<3>(kEkfV);
    sv.noalias() += hthv * pv.template middleRows<3>(kEkfTh);
    sv.noalias() += hbg * pv.template middleRows<3>(kEkfBg);
    s.template bottomRightCorner<3, 3>() =
        0.5 * (sv + sv.transpose()) + rot * noise_b * rot.transpose() + model * Mat3::Identity();
    // The velocity rows against the kinematic ones: H_v (P H_k^T).
    auto svk = s.template block<3, K>(K, 0);
    svk = pht.template middleRows<3>(kEkfV).template leftCols<K>();
    svk.noalias() += hthv * pht.template middleRows<3>(kEkfTh).template leftCols<K>();
    svk.noalias() += hbg * pht.template middleRows<3>(kEkfBg).template leftCols<K>();
    s.template block<K, 3>(0, K) = svk.transpose();
    innovation.template tail<3>() = -(x.v + c_w);
  }
  const dyn::SmallCholesky<M> llt(s);
  if (!llt.ok()) {
    if constexpr (kVelocity) return fuse_foot_rows<K, false>(foot, m, w_b, dt_s, gate);  // the kinematics alone
    return Fused::failed;
  }
  // The whitened innovation e = L^-1 y. Its first three entries are the kinematic rows' own
  // (the leading 3x3 of L is their S's factor): the slip gate. The velocity's three are its
  // innovation given the kinematic rows (what a sequential update's gate would see).
  const Eigen::Matrix<double, M, M>& l = llt.matrix_l();
  Eigen::Matrix<double, M, 1> e = innovation;
  for (int k = 0; k < M; ++k) {
    for (int j = 0; j < k; ++j) e[k] -= l(k, j) * e[j];
    e[k] /= l(k, k);
  }
  const double d2 = e.template head<3>().squaredNorm();
  x.mahalanobis2[idx(foot)] = d2;
  if (gate && d2 > params_.slip_gate_chi2) return Fused::gated;
  if constexpr (kVelocity) {
    if (gate && e.template tail<3>().squaredNorm() > params_.slip_gate_chi2) {
      fuse<K>(pht.data(), l.data(), M, e.data());  // the kinematic rows alone: U's leading columns
      return Fused::yes;
    }
  }
  fuse<M>(pht.data(), l.data(), M, e.data());
  return Fused::yes;
}

// rt: no alloc
template <int M>
void InertialKinematicEkf::fuse(double* pht, const double* l, int ld, const double* e) noexcept {
  // K y = P H^T S^-1 y = U (L^-1 y),  K S K^T = U U^T,  U = P H^T L^-T (forward substitution
  // on the columns, in place). Rows and columns 0..M-1 of an update of more rows are the
  // update by those rows alone: the substitution's first M columns read no later one.
  Eigen::Map<Eigen::Matrix<double, kN, M>> u(pht);
  for (int k = 0; k < M; ++k) {
    for (int j = 0; j < k; ++j) u.col(k) -= l[j * ld + k] * u.col(j);
    u.col(k) /= l[k * ld + k];
  }
  EkfVector dx;
  dx.noalias() = u * Eigen::Map<const Eigen::Matrix<double, M, 1>>(e);
  lower_rank_update<M>(x_.P, u);
  inject(dx);
}

// rt: no alloc
void InertialKinematicEkf::inject(const EkfVector& dx) noexcept {
  Filter& x = x_;
  x.p += dx.segment<3>(kEkfP);
  x.v += dx.segment<3>(kEkfV);
  x.q = (quat_exp(dx.segment<3>(kEkfTh)) * x.q).normalized();
  for (int f = 0; f < kEkfFeet; ++f) x.d[idx(f)] += dx.segment<3>(ekf_foot_index(f));
  x.b_a += dx.segment<3>(kEkfBa);
  x.b_g += dx.segment<3>(kEkfBg);
}

// rt: no alloc
bool InertialKinematicEkf::retest_foot(int foot, const FootMeasurement& m, double dt_s) noexcept {
  Filter& x = x_;
  const std::size_t f = idx(foot);
  const Mat3 rot = x.q.toRotationMatrix();
  const Vec3 w = x.p + rot * (m.contact_point_b_m - mounting_.position_bi_m);
  if (x.probe_count[f] == 0) {
    x.probe_mean_w_m[f] = w;
    x.probe_count[f] = 1;
    x.probe_passed_s[f] = 0.0;
    return false;
  }
  const double n = x.probe_count[f];
  const Vec3 e = w - x.probe_mean_w_m[f];
  const Mat3 s = (1.0 + 1.0 / n) * (rot * m.covariance_b_m2 * rot.transpose());
  const dyn::SmallCholesky<3> llt(s);
  const double d2 = llt.ok() ? llt.matrix_l().triangularView<Eigen::Lower>().solve(e).squaredNorm() : 0.0;
  x.mahalanobis2[f] = d2;
  if (!llt.ok() || d2 > params_.slip_gate_chi2) {  // moved: start again from here
    x.probe_mean_w_m[f] = w;
    x.probe_count[f] = 1;
    x.probe_passed_s[f] = 0.0;
    return false;
  }
  x.probe_mean_w_m[f] += e / (n + 1.0);
  x.probe_count[f] += 1;
  x.probe_passed_s[f] += dt_s;
  return x.probe_passed_s[f] >= params_.slip_accept_s;
}

// rt: no alloc
void InertialKinematicEkf::fuse_yaw(const Quat& orientation_wi) noexcept {
  Filter& x = x_;
  const Mat3 measured = orientation_wi.normalized().toRotationMatrix() * mounting_.rotation_bi.transpose();
  const Mat3 rot = x.q.toRotationMatrix();
  const double sin_pitch = -rot(2, 0);
  if (std::abs(sin_pitch) > std::sin(std::numbers::pi / 3.0)) return;  // yaw ill-defined near +-90 deg pitch
  const double yaw = std::atan2(rot(1, 0), rot(0, 0));
  const double innovation = wrap_pi(std::atan2(measured(1, 0), measured(0, 0)) - yaw);
  const double tan_pitch = sin_pitch / std::sqrt(1.0 - sin_pitch * sin_pitch);
  const Vec3 h(std::cos(yaw) * tan_pitch, std::sin(yaw) * tan_pitch, 1.0);  // d yaw / d dth (world)
  Eigen::Matrix<double, kN, 3> cols_th;
  sym_cols3(x.P, kEkfTh, cols_th);
  Eigen::Matrix<double, kN, 1> pht;
  pht.noalias() = cols_th * h;
  const double s = h.dot(pht.segment<3>(kEkfTh)) + params_.yaw_std_rad * params_.yaw_std_rad;
  if (!(s > 0.0)) return;
  const double l = std::sqrt(s);
  const double e = innovation / l;
  fuse<1>(pht.data(), &l, 1, &e);
}

// rt: no alloc
bool InertialKinematicEkf::condition_covariance() noexcept {
  EkfCovariance& P = x_.P;
  // The lower triangle mirrored to the upper (symmetric by construction); its sum is finite
  // if and only if every entry is (short of overflow, itself a fault).
  double sum = 0.0;
  for (int j = 0; j < kN; ++j) {
    sum += P(j, j);
    for (int i = j + 1; i < kN; ++i) {
      P(j, i) = P(i, j);
      sum += P(i, j);
    }
  }
  if (!std::isfinite(sum)) return false;
  const double max_std[] = {params_.max_position_std_m, params_.max_velocity_std_m_s, params_.max_angle_std_rad,
                            params_.foot_reset_std_m,   params_.foot_reset_std_m,     params_.foot_reset_std_m,
                            params_.foot_reset_std_m,   params_.max_accel_bias_std_m_s2, params_.max_gyro_bias_std_rad_s};
  constexpr double kMinVar = 1e-18;  // keeps the diagonal positive
  for (int i = 0; i < kN; ++i) {
    const double bound = max_std[i / 3] * max_std[i / 3];
    if (P(i, i) > bound) {  // scale row and column i: D P D stays positive semidefinite
      const double k = std::sqrt(bound / P(i, i));
      P.row(i) *= k;
      P.col(i) *= k;
    } else if (!(P(i, i) >= kMinVar)) {
      P(i, i) = kMinVar;
    }
  }
  return true;
}

}  // namespace springbok::est
