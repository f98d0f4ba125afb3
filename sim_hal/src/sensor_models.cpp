#include "springbok/sim_hal/sensor_models.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>

namespace springbok::sim {
namespace {

constexpr double kDeg = std::numbers::pi / 180.0;
constexpr double kG = 9.80665;  // the datasheets' g (ug, mg)
constexpr double kHour_s = 3600.0;
// A bias instability B read as the random walk that reaches it in this time: K = B / sqrt(T).
constexpr double kInstabilityTime_s = 100.0;

std::uint64_t splitmix64(std::uint64_t x) noexcept {
  x += 0x9E3779B97F4A7C15ULL;
  x = (x ^ (x >> 30)) * 0xBF58476D1CE4E5B9ULL;
  x = (x ^ (x >> 27)) * 0x94D049BB133111EBULL;
  return x ^ (x >> 31);
}

// y clamped to +-range per axis (range 0: none), then quantised to lsb (0: none).
// Returns whether an axis saturated.
template <int N>
bool saturate_and_quantise(Eigen::Matrix<double, N, 1>& y, const Eigen::Matrix<double, N, 1>& range, double lsb) noexcept {
  bool clip = false;
  for (int i = 0; i < N; ++i) {
    if (range[i] > 0.0 && std::abs(y[i]) >= range[i]) {
      clip = true;
      y[i] = std::clamp(y[i], -range[i], range[i]);
    }
    if (lsb > 0.0) y[i] = lsb * std::round(y[i] / lsb);
  }
  return clip;
}

Quat small_rotation(const Vec3& e) noexcept {
  const double angle = e.norm();
  if (!(angle > 0.0)) return Quat::Identity();
  return Quat(Eigen::AngleAxisd(angle, e / angle));
}

bool finite_nonnegative(double v) { return std::isfinite(v) && v >= 0.0; }

std::string check_triad(const InertialTriadConfig& c, const char* name) {
  const std::string p = std::string("imu.") + name + ".";
  const std::pair<const char*, double> fields[] = {
      {"noise_per_sqrt_hz", c.noise_per_sqrt_hz}, {"bias_walk_per_sqrt_hz", c.bias_walk_per_sqrt_hz},
      {"turn_on_bias", c.turn_on_bias},           {"scale_factor_std", c.scale_factor_std},
      {"lsb", c.lsb},                             {"range", c.range},
      {"sample_rate_hz", c.sample_rate_hz}};
  for (const auto& [field, v] : fields) {
    if (!finite_nonnegative(v)) return p + field + " must be finite and >= 0";
  }
  if (!c.bias_offset.allFinite()) return p + "bias_offset must be finite";
  if (c.delay_ticks < 0 || c.delay_ticks > kMaxSensorDelayTicks) {
    return p + "delay_ticks must be in [0, " + std::to_string(kMaxSensorDelayTicks) + "]";
  }
  return {};
}

}  // namespace

// ---- presets --------------------------------------------------------------------------------

ImuModelConfig imu_preset(ImuPreset p) noexcept {
  ImuModelConfig c;
  switch (p) {
    case ImuPreset::ideal:
      break;
    case ImuPreset::mems:  // Bosch BMI088 class (the header's table says which figures are checked)
      c.gyro.noise_per_sqrt_hz = 0.014 * kDeg;                                  // 2.44e-4 rad/s/sqrt(Hz)
      c.gyro.bias_walk_per_sqrt_hz = 2.0 * kDeg / kHour_s / std::sqrt(kInstabilityTime_s);
      c.gyro.turn_on_bias = 1.0 * kDeg / 3.0;                                   // +-1 deg/s as 3 sigma
      c.gyro.scale_factor_std = 0.01 / 3.0;
      c.gyro.range = 2000.0 * kDeg;
      c.gyro.lsb = kDeg / 16.384;                                               // 16.384 LSB/(deg/s)
      c.gyro.sample_rate_hz = 1000.0;
      c.gyro.delay_ticks = 1;
      c.accel.noise_per_sqrt_hz = 175e-6 * kG;                                  // 1.72e-3 m/s^2/sqrt(Hz)
      c.accel.bias_walk_per_sqrt_hz = 40e-6 * kG / std::sqrt(kInstabilityTime_s);
      c.accel.turn_on_bias = 20e-3 * kG / 3.0;                                  // +-20 mg as 3 sigma
      c.accel.scale_factor_std = 0.01 / 3.0;
      c.accel.range = 24.0 * kG;
      c.accel.lsb = 24.0 * kG / 32768.0;
      c.accel.sample_rate_hz = 800.0;
      c.accel.delay_ticks = 1;
      break;
    case ImuPreset::tactical:  // KVH 1775 class
      c.gyro.noise_per_sqrt_hz = 0.012 * kDeg / std::sqrt(kHour_s);             // ARW 0.012 deg/sqrt(h)
      c.gyro.bias_walk_per_sqrt_hz = 0.05 * kDeg / kHour_s / std::sqrt(kInstabilityTime_s);
      c.gyro.turn_on_bias = 0.5 * kDeg / kHour_s;
      c.gyro.scale_factor_std = 50e-6;
      c.gyro.range = 490.0 * kDeg;
      c.gyro.sample_rate_hz = 1000.0;
      c.gyro.delay_ticks = 1;
      c.accel.noise_per_sqrt_hz = 0.12e-3 * kG;
      c.accel.bias_walk_per_sqrt_hz = 0.05e-3 * kG / std::sqrt(kInstabilityTime_s);
      c.accel.turn_on_bias = 0.3e-3 * kG;
      c.accel.scale_factor_std = 100e-6;
      c.accel.range = 10.0 * kG;
      c.accel.sample_rate_hz = 1000.0;
      c.accel.delay_ticks = 1;
      break;
  }
  return c;
}

EncoderConfig encoder_preset(PartPreset p) noexcept {
  EncoderConfig c;
  if (p == PartPreset::realistic) {
    c.counts_per_rev = 16384.0;
    c.gear_ratio.setConstant(10.0);
    c.velocity = EncoderVelocity::difference;
  }
  return c;
}

JointTorqueConfig joint_torque_preset(PartPreset p) noexcept {
  JointTorqueConfig c;
  if (p == PartPreset::realistic) {
    for (int j = 0; j < kNj; ++j) {
      const double effort_nm = robot::kJoints[static_cast<std::size_t>(j)].limits.effort_nm;
      c.noise_std_nm[j] = 0.005 * effort_nm;
      c.offset_std_nm[j] = 0.01 * effort_nm;
    }
  }
  return c;
}

WristFtConfig wrist_ft_preset(PartPreset p) noexcept {
  WristFtConfig c;
  if (p == PartPreset::realistic) {  // ATI Mini45 class, SI-145-5
    c.force_range_n = Vec3(145.0, 145.0, 290.0);
    c.torque_range_nm = Vec3::Constant(5.0);
    c.force_lsb_n = 1.0 / 16.0;
    c.torque_lsb_nm = 1.0 / 752.0;
    c.force_noise_std_n = c.force_lsb_n;
    c.torque_noise_std_nm = c.torque_lsb_nm;
    c.force_offset_std_n = 1.0;
    c.torque_offset_std_nm = 0.02;
    c.force_offset_walk_n_per_sqrt_s = 0.005;
    c.torque_offset_walk_nm_per_sqrt_s = 1e-4;
  }
  return c;
}

SensorModelConfig sensor_preset(ImuPreset p) noexcept {
  SensorModelConfig c;
  c.imu = imu_preset(p);
  const PartPreset part = p == ImuPreset::ideal ? PartPreset::ideal : PartPreset::realistic;
  c.encoders = encoder_preset(part);
  c.joint_torque = joint_torque_preset(part);
  c.wrist_ft = wrist_ft_preset(part);
  return c;
}

// ---- ideal / legacy / checks ----------------------------------------------------------------

namespace {
bool is_ideal(const InertialTriadConfig& c) noexcept {
  return c.noise_per_sqrt_hz == 0.0 && c.bias_walk_per_sqrt_hz == 0.0 && c.turn_on_bias == 0.0 &&
         c.bias_offset.isZero(0.0) &&
         c.scale_factor_std == 0.0 && c.lsb == 0.0 && c.range == 0.0 && c.sample_rate_hz == 0.0 && c.delay_ticks == 0;
}
}  // namespace

bool is_ideal(const ImuModelConfig& c) noexcept {
  return is_ideal(c.gyro) && is_ideal(c.accel) && c.orientation.drift_rad_per_sqrt_s == 0.0 &&
         c.orientation.noise_rad == 0.0;
}
bool is_ideal(const EncoderConfig& c) noexcept {
  return c.counts_per_rev == 0.0 && c.velocity == EncoderVelocity::exact;
}
bool is_ideal(const JointTorqueConfig& c) noexcept {
  return c.noise_std_nm.isZero(0.0) && c.offset_std_nm.isZero(0.0);
}
bool is_ideal(const WristFtConfig& c) noexcept {
  return c.force_noise_std_n == 0.0 && c.torque_noise_std_nm == 0.0 && c.force_offset_std_n == 0.0 &&
         c.torque_offset_std_nm == 0.0 && c.force_offset_walk_n_per_sqrt_s == 0.0 &&
         c.torque_offset_walk_nm_per_sqrt_s == 0.0 && c.force_range_n.isZero(0.0) && c.torque_range_nm.isZero(0.0) &&
         c.force_lsb_n == 0.0 && c.torque_lsb_nm == 0.0;
}
bool is_ideal(const SensorModelConfig& c) noexcept {
  return is_ideal(c.imu) && is_ideal(c.encoders) && is_ideal(c.joint_torque) && is_ideal(c.wrist_ft);
}

void apply_legacy_imu(double gyro_noise_rad_s, double accel_noise_m_s2, double gyro_bias_rad_s,
                      double accel_bias_m_s2, double step_s, ImuModelConfig& out) noexcept {
  const double root_dt = std::sqrt(step_s);
  out.gyro.noise_per_sqrt_hz = gyro_noise_rad_s * root_dt;
  out.accel.noise_per_sqrt_hz = accel_noise_m_s2 * root_dt;
  out.gyro.turn_on_bias = gyro_bias_rad_s;
  out.accel.turn_on_bias = accel_bias_m_s2;
}

std::string check_sensor_model(const SensorModelConfig& c, double step_s) {
  if (!(std::isfinite(step_s) && step_s > 0.0)) return "step_s must be finite and > 0";
  if (std::string e = check_triad(c.imu.gyro, "gyro"); !e.empty()) return e;
  if (std::string e = check_triad(c.imu.accel, "accel"); !e.empty()) return e;
  if (!finite_nonnegative(c.imu.orientation.drift_rad_per_sqrt_s)) {
    return "imu.orientation.drift_rad_per_sqrt_s must be finite and >= 0";
  }
  if (!finite_nonnegative(c.imu.orientation.noise_rad)) return "imu.orientation.noise_rad must be finite and >= 0";
  const EncoderConfig& e = c.encoders;
  if (!finite_nonnegative(e.counts_per_rev)) return "encoders.counts_per_rev must be finite and >= 0";
  for (int j = 0; j < kNj; ++j) {
    if (!(std::isfinite(e.gear_ratio[j]) && e.gear_ratio[j] > 0.0)) {
      return "encoders.gear_ratio[" + std::to_string(j) + "] must be finite and > 0";
    }
  }
  if (e.velocity != EncoderVelocity::exact && e.velocity != EncoderVelocity::difference &&
      e.velocity != EncoderVelocity::lowpass) {
    return "encoders.velocity is not a known mode";
  }
  if (e.velocity == EncoderVelocity::lowpass && !(std::isfinite(e.velocity_cutoff_hz) && e.velocity_cutoff_hz > 0.0)) {
    return "encoders.velocity_cutoff_hz must be finite and > 0 with velocity lowpass";
  }
  for (int j = 0; j < kNj; ++j) {
    if (!finite_nonnegative(c.joint_torque.noise_std_nm[j]) || !finite_nonnegative(c.joint_torque.offset_std_nm[j])) {
      return "joint_torque[" + std::to_string(j) + "]: noise and offset std must be finite and >= 0";
    }
  }
  const WristFtConfig& f = c.wrist_ft;
  const std::pair<const char*, double> ft_fields[] = {
      {"force_noise_std_n", f.force_noise_std_n},
      {"torque_noise_std_nm", f.torque_noise_std_nm},
      {"force_offset_std_n", f.force_offset_std_n},
      {"torque_offset_std_nm", f.torque_offset_std_nm},
      {"force_offset_walk_n_per_sqrt_s", f.force_offset_walk_n_per_sqrt_s},
      {"torque_offset_walk_nm_per_sqrt_s", f.torque_offset_walk_nm_per_sqrt_s},
      {"force_lsb_n", f.force_lsb_n},
      {"torque_lsb_nm", f.torque_lsb_nm}};
  for (const auto& [field, v] : ft_fields) {
    if (!finite_nonnegative(v)) return std::string("wrist_ft.") + field + " must be finite and >= 0";
  }
  for (int i = 0; i < 3; ++i) {
    if (!finite_nonnegative(f.force_range_n[i])) return "wrist_ft.force_range_n must be finite and >= 0";
    if (!finite_nonnegative(f.torque_range_nm[i])) return "wrist_ft.torque_range_nm must be finite and >= 0";
  }
  return {};
}

// ---- the model ------------------------------------------------------------------------------

std::string SensorModel::configure(const SensorModelConfig& c, double step_s, std::uint64_t imu_seed) {
  if (std::string e = check_sensor_model(c, step_s); !e.empty()) return e;
  config_ = c;
  step_s_ = step_s;
  // The per-sample white noise std: density / sqrt(T), T the sample period (a faster sensor's
  // newest sample carries its own rate's noise).
  const auto white_std = [step_s](const InertialTriadConfig& t) {
    const double period_s = t.sample_rate_hz > 0.0 ? 1.0 / t.sample_rate_hz : step_s;
    return t.noise_per_sqrt_hz / std::sqrt(period_s);
  };
  gyro_white_std_ = white_std(c.imu.gyro);
  accel_white_std_ = white_std(c.imu.accel);

  // The IMU's stream: the legacy ImuNoise's engine, seed and draw order (turn-on biases, then
  // per tick the gyro's noise and the accelerometer's); what it did not have draws after.
  imu_rng_.seed(imu_seed);
  torque_rng_.seed(splitmix64(c.seed ^ 0x746F727175650000ULL));
  ft_rng_.seed(splitmix64(c.seed ^ 0x6674000000000000ULL));
  gyro_ = Triad{};
  accel_ = Triad{};
  gyro_.bias0 = c.imu.gyro.bias_offset + imu_rng_.gaussian3(c.imu.gyro.turn_on_bias);
  accel_.bias0 = c.imu.accel.bias_offset + imu_rng_.gaussian3(c.imu.accel.turn_on_bias);
  if (c.imu.gyro.scale_factor_std > 0.0) gyro_.scale = imu_rng_.gaussian3(c.imu.gyro.scale_factor_std);
  if (c.imu.accel.scale_factor_std > 0.0) accel_.scale = imu_rng_.gaussian3(c.imu.accel.scale_factor_std);
  orientation_ = Orientation{};
  orientation_drift_.setZero();

  counts_to_rad_.setZero();
  if (c.encoders.counts_per_rev > 0.0) {
    for (int j = 0; j < kNj; ++j) counts_to_rad_[j] = 2.0 * std::numbers::pi / (c.encoders.counts_per_rev * c.encoders.gear_ratio[j]);
  }
  lowpass_gain_ = c.encoders.velocity == EncoderVelocity::lowpass
                      ? 1.0 - std::exp(-2.0 * std::numbers::pi * c.encoders.velocity_cutoff_hz * step_s)
                      : 0.0;
  previous_q_.setZero();
  filtered_qd_.setZero();

  tau_offset_nm_.setZero();
  for (int j = 0; j < kNj; ++j) {
    if (c.joint_torque.offset_std_nm[j] > 0.0) tau_offset_nm_[j] = c.joint_torque.offset_std_nm[j] * torque_rng_();
  }
  ft_ = WristFtErrorState{};
  if (c.wrist_ft.force_offset_std_n > 0.0) ft_.force_offset_n = ft_rng_.gaussian3(c.wrist_ft.force_offset_std_n);
  if (c.wrist_ft.torque_offset_std_nm > 0.0) ft_.torque_offset_nm = ft_rng_.gaussian3(c.wrist_ft.torque_offset_std_nm);
  return {};
}

// Whether this tick takes a new sample: every tick at or above the tick rate, else when
// floor(k rate dt) steps (k the ticks since the hold restarted; tick 0 always samples).
bool SensorModel::due(const InertialTriadConfig& c, Triad& t, bool first) const noexcept {
  if (first) {
    t.ticks = 0;
    t.last_sample_tick = 0;
    return true;
  }
  ++t.ticks;
  const double per_tick = c.sample_rate_hz > 0.0 ? c.sample_rate_hz * step_s_ : 1.0;
  if (per_tick >= 1.0 - 1e-9) return true;
  constexpr double kEps = 1e-9;  // a rate that divides the tick rate samples on its ticks exactly
  const double now = std::floor(static_cast<double>(t.ticks) * per_tick + kEps);
  const double before = std::floor(static_cast<double>(t.ticks - 1) * per_tick + kEps);
  return now > before;
}

void SensorModel::sample(const InertialTriadConfig& c, double white_std, Triad& t, const Vec3& truth) noexcept {
  // The legacy order of operations, (x + b0) + noise, so that the ideal and the legacy
  // model give today's bits; the new terms only where configured.
  const Vec3 white = imu_rng_.gaussian3(white_std);
  if (c.bias_walk_per_sqrt_hz > 0.0) {
    const double elapsed_s = static_cast<double>(t.ticks - t.last_sample_tick) * step_s_;
    if (elapsed_s > 0.0) t.walk += imu_rng_.gaussian3(c.bias_walk_per_sqrt_hz * std::sqrt(elapsed_s));
  }
  Vec3 y = truth;
  if (c.scale_factor_std > 0.0) y = truth + t.scale.cwiseProduct(truth);
  y += t.bias0;
  if (c.bias_walk_per_sqrt_hz > 0.0) y += t.walk;
  y += white;
  t.held_clip = saturate_and_quantise<3>(y, Vec3::Constant(c.range), c.lsb);
  t.held = y;
  t.last_sample_tick = t.ticks;
}

// Writes this tick's held sample into the delay line and reads the one delay_ticks ago.
void SensorModel::delay(const InertialTriadConfig& c, Triad& t, bool first, Vec3& value, bool& clip,
                        std::uint32_t& age) noexcept {
  constexpr std::int64_t n = kMaxSensorDelayTicks + 1;
  const Triad::Slot now{t.held, t.held_clip, static_cast<std::uint32_t>(t.ticks - t.last_sample_tick)};
  if (first) {
    t.line.fill(now);
  } else {
    t.line[static_cast<std::size_t>(t.written % n)] = now;
  }
  const Triad::Slot& out = t.line[static_cast<std::size_t>(((t.written - c.delay_ticks) % n + n) % n)];
  ++t.written;
  value = out.value;
  clip = out.clip;
  age = out.age;
}

void SensorModel::imu(const ImuTruth& in, bool first, hal::Imu& out) noexcept {
  const ImuModelConfig& c = config_.imu;
  const bool gyro_due = due(c.gyro, gyro_, first);
  const bool accel_due = due(c.accel, accel_, first);
  const std::int64_t gyro_elapsed_ticks = gyro_.ticks - gyro_.last_sample_tick;  // since its previous sample
  if (gyro_due) sample(c.gyro, gyro_white_std_, gyro_, in.angular_rate_rad_s);
  if (accel_due) sample(c.accel, accel_white_std_, accel_, in.specific_force_m_s2);
  if (gyro_due) {
    const OrientationErrorConfig& o = c.orientation;
    if (o.drift_rad_per_sqrt_s > 0.0 || o.noise_rad > 0.0) {
      if (o.drift_rad_per_sqrt_s > 0.0 && gyro_elapsed_ticks > 0) {
        orientation_drift_ +=
            imu_rng_.gaussian3(o.drift_rad_per_sqrt_s * std::sqrt(static_cast<double>(gyro_elapsed_ticks) * step_s_));
      }
      Vec3 e = orientation_drift_;
      if (o.noise_rad > 0.0) e += imu_rng_.gaussian3(o.noise_rad);
      orientation_.held = (small_rotation(e) * in.orientation).normalized();
    } else {
      orientation_.held = in.orientation;
    }
  }
  // delay lines
  bool gyro_clip = false, accel_clip = false;
  std::uint32_t gyro_age = 0, accel_age = 0;
  const std::int64_t gyro_slot = gyro_.written;
  delay(c.gyro, gyro_, first, out.angular_rate_rad_s, gyro_clip, gyro_age);
  delay(c.accel, accel_, first, out.linear_accel_m_s2, accel_clip, accel_age);
  constexpr std::int64_t n = kMaxSensorDelayTicks + 1;
  if (first) {
    orientation_.line.fill(orientation_.held);
  } else {
    orientation_.line[static_cast<std::size_t>(gyro_slot % n)] = orientation_.held;
  }
  out.orientation = orientation_.line[static_cast<std::size_t>(((gyro_slot - c.gyro.delay_ticks) % n + n) % n)];
  out.clipping = gyro_clip || accel_clip;
  out.age_ticks = std::min(gyro_age, accel_age);
}

void SensorModel::joints(const VecNj& q_rad, const VecNj& qd_rad_s, const VecNj& tau_nm, bool first, VecNj& q_out,
                         VecNj& qd_out, VecNj& tau_out) noexcept {
  const EncoderConfig& e = config_.encoders;
  const bool quantised = e.counts_per_rev > 0.0;
  const auto quantise = [&](int j, double q) { return quantised ? counts_to_rad_[j] * std::round(q / counts_to_rad_[j]) : q; };
  for (int j = 0; j < kNj; ++j) {
    const double q = quantise(j, q_rad[j]);
    double qd = qd_rad_s[j];
    if (e.velocity != EncoderVelocity::exact) {
      // After a restart the previous position is where the joint was a tick ago at this speed.
      if (first) previous_q_[j] = quantise(j, q_rad[j] - qd_rad_s[j] * step_s_);
      const double difference = (q - previous_q_[j]) / step_s_;
      previous_q_[j] = q;
      if (e.velocity == EncoderVelocity::difference) {
        qd = difference;
      } else {
        filtered_qd_[j] = first ? qd_rad_s[j] : filtered_qd_[j] + lowpass_gain_ * (difference - filtered_qd_[j]);
        qd = filtered_qd_[j];
      }
    }
    q_out[j] = q;
    qd_out[j] = qd;
    double tau = tau_nm[j];
    if (config_.joint_torque.offset_std_nm[j] > 0.0) tau += tau_offset_nm_[j];
    if (config_.joint_torque.noise_std_nm[j] > 0.0) tau += config_.joint_torque.noise_std_nm[j] * torque_rng_();
    tau_out[j] = tau;
  }
}

void SensorModel::wrist(const Vec3& force_n, const Vec3& torque_nm, hal::Wrench& out) noexcept {
  const WristFtConfig& c = config_.wrist_ft;
  const double root_dt = std::sqrt(step_s_);
  if (c.force_offset_walk_n_per_sqrt_s > 0.0) ft_.force_offset_n += ft_rng_.gaussian3(c.force_offset_walk_n_per_sqrt_s * root_dt);
  if (c.torque_offset_walk_nm_per_sqrt_s > 0.0) {
    ft_.torque_offset_nm += ft_rng_.gaussian3(c.torque_offset_walk_nm_per_sqrt_s * root_dt);
  }
  Vec3 f = force_n, t = torque_nm;
  if (c.force_offset_std_n > 0.0 || c.force_offset_walk_n_per_sqrt_s > 0.0) f += ft_.force_offset_n;
  if (c.torque_offset_std_nm > 0.0 || c.torque_offset_walk_nm_per_sqrt_s > 0.0) t += ft_.torque_offset_nm;
  if (c.force_noise_std_n > 0.0) f += ft_rng_.gaussian3(c.force_noise_std_n);
  if (c.torque_noise_std_nm > 0.0) t += ft_rng_.gaussian3(c.torque_noise_std_nm);
  const bool clip_f = saturate_and_quantise<3>(f, c.force_range_n, c.force_lsb_n);
  const bool clip_t = saturate_and_quantise<3>(t, c.torque_range_nm, c.torque_lsb_nm);
  out.force_n = f;
  out.torque_nm = t;
  out.clipping = clip_f || clip_t;
}

ImuErrorState SensorModel::imu_errors() const noexcept {
  ImuErrorState s;
  s.gyro_bias_rad_s = gyro_.bias0 + gyro_.walk;
  s.accel_bias_m_s2 = accel_.bias0 + accel_.walk;
  s.gyro_scale_factor = gyro_.scale;
  s.accel_scale_factor = accel_.scale;
  s.orientation_drift_rad = orientation_drift_;
  return s;
}

}  // namespace springbok::sim
