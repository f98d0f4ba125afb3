#include "springbok/can/sensors.hpp"

#include <algorithm>
#include <cmath>

#include "springbok/model/model.hpp"  // kGravity_m_s2

namespace springbok::can {

namespace {

std::int16_t get_i16(const Frame& f, int at) noexcept {
  const auto u = static_cast<std::uint16_t>(f.data[static_cast<std::size_t>(at)] |
                                            (f.data[static_cast<std::size_t>(at + 1)] << 8));
  return static_cast<std::int16_t>(u);
}

void put_i16(Frame& f, int at, std::int16_t v) noexcept {
  const auto u = static_cast<std::uint16_t>(v);
  f.data[static_cast<std::size_t>(at)] = static_cast<std::uint8_t>(u & 0xFF);
  f.data[static_cast<std::size_t>(at + 1)] = static_cast<std::uint8_t>(u >> 8);
}

// Round to nearest and saturate; true when saturated (or not finite).
bool to_count(double x, std::int16_t& out) noexcept {
  if (!std::isfinite(x)) {
    out = 0;
    return true;
  }
  const double r = std::round(x);
  if (r > 32767.0) {
    out = 32767;
    return true;
  }
  if (r < -32768.0) {
    out = -32768;
    return true;
  }
  out = static_cast<std::int16_t>(r);
  return false;
}

}  // namespace

const char* to_string(SensorEvent e) noexcept {
  switch (e) {
    case SensorEvent::stored: return "stored";
    case SensorEvent::accepted: return "accepted";
    case SensorEvent::wrong_dlc: return "wrong DLC";
    case SensorEvent::reserved_bits: return "reserved status bits set";
    case SensorEvent::status_invalid: return "status not valid";
    case SensorEvent::bad_quaternion: return "quaternion norm above 1 + 2^-10";
    case SensorEvent::counter_jump: return "counter jump";
    case SensorEvent::stale_counter: return "stale counter";
    case SensorEvent::late_frame: return "late frame";
  }
  return "?";
}

FrameStatus decode_sensor_frame(const Frame& f, SensorFrameFields& out) noexcept {
  if (f.error) return FrameStatus::error_frame;
  if (f.fd || f.len != kSensorFrameLen) return FrameStatus::wrong_dlc;
  for (int i = 0; i < 3; ++i) out.v[static_cast<std::size_t>(i)] = get_i16(f, 2 * i);
  out.counter = f.data[6];
  out.status = f.data[7];
  return FrameStatus::ok;
}

void encode_sensor_frame(std::uint32_t id, const SensorFrameFields& in, Frame& out) noexcept {
  out = Frame{};
  out.id = id & kStandardIdMask;
  out.len = kSensorFrameLen;
  for (int i = 0; i < 3; ++i) put_i16(out, 2 * i, in.v[static_cast<std::size_t>(i)]);
  out.data[6] = in.counter;
  out.data[7] = in.status;
}

Eigen::Vector3d decode_scaled(const std::array<std::int16_t, 3>& v, double unit_per_count) noexcept {
  return Eigen::Vector3d(v[0] * unit_per_count, v[1] * unit_per_count, v[2] * unit_per_count);
}

bool encode_scaled(const Eigen::Vector3d& x, double unit_per_count, std::array<std::int16_t, 3>& out) noexcept {
  bool clipped = false;
  for (int i = 0; i < 3; ++i) clipped = to_count(x[i] / unit_per_count, out[static_cast<std::size_t>(i)]) || clipped;
  return clipped;
}

Eigen::Vector3d decode_counts(const std::array<std::int16_t, 3>& v, double counts_per_unit) noexcept {
  return Eigen::Vector3d(v[0] / counts_per_unit, v[1] / counts_per_unit, v[2] / counts_per_unit);
}

bool encode_counts(const Eigen::Vector3d& x, double counts_per_unit, std::array<std::int16_t, 3>& out) noexcept {
  bool clipped = false;
  for (int i = 0; i < 3; ++i) clipped = to_count(x[i] * counts_per_unit, out[static_cast<std::size_t>(i)]) || clipped;
  return clipped;
}

bool decode_quaternion(const std::array<std::int16_t, 3>& xyz, double per_count, Eigen::Quaterniond& q) noexcept {
  const Eigen::Vector3d v = decode_scaled(xyz, per_count);
  const double squares = v.squaredNorm();
  if (!(squares <= kMaxQuaternionSquares)) return false;
  q = Eigen::Quaterniond(std::sqrt(std::max(0.0, 1.0 - squares)), v.x(), v.y(), v.z());
  return true;
}

namespace {

// The q_w for which the quaternion (q_w, v) sees the specific force `a` (sensor frame) as
// gravity: u(w) = R^T e_z = (w^2 - |v|^2) e_z + 2 v_z v - 2 w (v x e_z) fitted to a / |a| by two
// Gauss-Newton steps from `w`. False where `a` is not gravity alone (|a| not within 10 % of g)
// or q_w hardly moves u (|du/dw| = 2 |(v_x, v_y, w)| < 0.5: an upright sensor, whose q_w the
// wire gives exactly anyway).
bool q_w_from_gravity(const Eigen::Vector3d& v, const Eigen::Vector3d& a, double& w) noexcept {
  const double n = a.norm();
  if (!(std::isfinite(n) && std::abs(n - kGravity_m_s2) < 0.1 * kGravity_m_s2)) return false;
  const Eigen::Vector3d m = a / n;
  const Eigen::Vector3d v_cross_z(v.y(), -v.x(), 0.0);
  for (int it = 0; it < 2; ++it) {
    const Eigen::Vector3d u = (w * w - v.squaredNorm()) * Eigen::Vector3d::UnitZ() + 2.0 * v.z() * v - 2.0 * w * v_cross_z;
    const Eigen::Vector3d du = 2.0 * w * Eigen::Vector3d::UnitZ() - 2.0 * v_cross_z;
    const double info = du.squaredNorm();
    if (!(info > 0.25)) return false;
    w -= du.dot(u - m) / info;
  }
  return std::isfinite(w);
}

}  // namespace

Eigen::Quaterniond OrientationTrack::update(const std::array<std::int16_t, 3>& xyz, double per_count,
                                            const Eigen::Vector3d& rate_rad_s, const Eigen::Vector3d& accel_m_s2,
                                            double dt_s) noexcept {
  Eigen::Vector3d v = decode_scaled(xyz, per_count);
  // |q_xyz| within the counts +- half a count each.
  const double h = 0.5 * per_count;
  double near2 = 0.0, far2 = 0.0;
  for (int i = 0; i < 3; ++i) {
    const double a = std::abs(v[i]);
    near2 += std::max(0.0, a - h) * std::max(0.0, a - h);
    far2 += (a + h) * (a + h);
  }
  double m_lo = std::sqrt(std::max(0.0, 1.0 - far2));
  double m_hi = std::sqrt(std::max(0.0, 1.0 - near2));
  const bool fresh = !started_ || !(dt_s > 0.0) || !std::isfinite(dt_s);
  if (!fresh && v.dot(q_.vec()) < 0.0) {  // the sender's q_w >= 0 flipped the sign: q_w < 0 here
    v = -v;
    const double t = m_lo;
    m_lo = -m_hi;
    m_hi = -t;
  }
  double w = std::sqrt(std::max(0.0, 1.0 - v.squaredNorm()));  // a fresh start: CAN.md 6.1's q_w
  if (fresh) {
    lo_ = m_lo;
    hi_ = m_hi;
  } else {
    // q (x) [1, w dt / 2]: q_w changes by -q_xyz . w dt / 2 (the rate at the interval's middle).
    const Eigen::Vector3d rate_mid = 0.5 * (rate_rad_s + rate_rad_s_);
    const double dw = -0.5 * dt_s * q_.vec().dot(rate_mid);
    const double widen = 0.5 * dt_s * kRateUncertainty_rad_s;
    const double p_lo = lo_ + dw - widen, p_hi = hi_ + dw + widen;
    lo_ = std::max(p_lo, m_lo);
    hi_ = std::min(p_hi, m_hi);
    if (lo_ > hi_) {  // the rate and the sample disagree: trust the sample
      lo_ = m_lo;
      hi_ = m_hi;
    }
    // Gravity pulls the gyro's prediction, slowly: a trunk accelerating forwards looks pitched.
    double predicted = q_.w() + dw;
    if (double from_gravity = predicted; q_w_from_gravity(v, accel_m_s2, from_gravity)) {
      predicted += std::min(1.0, dt_s / kAccelTimeConstant_s) * (from_gravity - predicted);
    }
    w = std::clamp(predicted, lo_, hi_);
  }
  started_ = true;
  rate_rad_s_ = rate_rad_s;
  // q_xyz as sent, not normalised (as decode_quaternion): where q_w ~ 0 and the rounded |q_xyz|
  // exceeds 1, normalising would move them by more than half a count (the fuzzer found it).
  // Its users normalise (the estimator's trunk_rotation).
  q_ = Eigen::Quaterniond(w, v.x(), v.y(), v.z());
  return q_.w() < 0.0 ? Eigen::Quaterniond(-q_.w(), -q_.x(), -q_.y(), -q_.z()) : q_;
}

bool encode_quaternion(const Eigen::Quaterniond& q, double per_count, std::array<std::int16_t, 3>& out) noexcept {
  const double n = q.norm();
  if (!(std::isfinite(n) && n > 0.0)) {
    out = {};
    return true;
  }
  const double sign = q.w() < 0.0 ? -1.0 : 1.0;
  // A unit quaternion's component never leaves [-1, 1]; 1 itself is one count past the int16
  // range and is sent as 32767 (within the resolution): no clipping, nothing was out of range.
  (void)encode_scaled(Eigen::Vector3d(q.x(), q.y(), q.z()) * (sign / n), per_count, out);
  return false;
}

WrenchTransform wrench_transform(const SensorOffset& o) noexcept {
  WrenchTransform t;
  t.rotation = (Eigen::AngleAxisd(o.rpy_rad[2], Eigen::Vector3d::UnitZ()) *
                Eigen::AngleAxisd(o.rpy_rad[1], Eigen::Vector3d::UnitY()) *
                Eigen::AngleAxisd(o.rpy_rad[0], Eigen::Vector3d::UnitX()))
                   .toRotationMatrix();
  t.translation_m = Eigen::Vector3d(o.xyz_m[0], o.xyz_m[1], o.xyz_m[2]);
  return t;
}

void wrench_sensor_to_ee(const WrenchTransform& t, const Eigen::Vector3d& force_s_n, const Eigen::Vector3d& torque_s_nm,
                         Eigen::Vector3d& force_ee_n, Eigen::Vector3d& torque_ee_nm) noexcept {
  force_ee_n.noalias() = t.rotation * force_s_n;
  torque_ee_nm.noalias() = t.rotation * torque_s_nm;
  torque_ee_nm += t.translation_m.cross(force_ee_n);
}

void wrench_ee_to_sensor(const WrenchTransform& t, const Eigen::Vector3d& force_ee_n, const Eigen::Vector3d& torque_ee_nm,
                         Eigen::Vector3d& force_s_n, Eigen::Vector3d& torque_s_nm) noexcept {
  const Eigen::Vector3d about_sensor = torque_ee_nm - t.translation_m.cross(force_ee_n);
  force_s_n.noalias() = t.rotation.transpose() * force_ee_n;
  torque_s_nm.noalias() = t.rotation.transpose() * about_sensor;
}

// ---- IMU -----------------------------------------------------------------------------------
// Start-up. Every field but the bus name (a string: the backend knows the bus by index).
namespace {
// Which frame of a sensor an id is (its index in the configured ids), or -1.
template <std::size_t N>
int index_of(const std::array<std::uint32_t, N>& ids, std::uint32_t id) noexcept {
  for (std::size_t i = 0; i < N; ++i) {
    if (ids[i] == id) return static_cast<int>(i);
  }
  return -1;
}
}  // namespace

// Start-up (the bus name is copied too).
void ImuAssembler::configure(const ImuConfig& cfg, std::uint64_t tick) {
  cfg_ = cfg;
  // The quaternion is no ranged measurement (SampleAssembler::configure).
  asm_.configure(cfg.stale_ticks, cfg.clip_streak, tick, (1u << imu_frame::rate) | (1u << imu_frame::accel));
  track_.reset();
  orientation_ = Eigen::Quaterniond::Identity();
  track_tick_ = tick;
}

int ImuAssembler::frame_index(std::uint32_t id) const noexcept { return index_of(cfg_.ids, id); }

SensorEvent ImuAssembler::push(const Frame& f, std::uint64_t tick) noexcept {
  const int index = frame_index(f.id);
  bool corrupt = false;
  if (index == imu_frame::orientation) {
    SensorFrameFields ff;
    Eigen::Quaterniond q;
    corrupt = decode_sensor_frame(f, ff) == FrameStatus::ok &&
              !decode_quaternion(ff.v, cfg_.scales.orientation_per_count, q);
  }
  const SensorEvent e = asm_.push(index, f, corrupt, tick);
  if (e == SensorEvent::accepted) {
    const auto& s = asm_.newest();
    // Samples since the last accepted one; after a gap the track starts afresh (dt 0).
    const auto samples = static_cast<std::uint8_t>(s.counter - track_counter_);
    const bool continuous = asm_.diagnostics().samples_accepted > 1 && samples <= cfg_.stale_ticks &&
                            tick - track_tick_ <= cfg_.stale_ticks + 1u && cfg_.rate_hz > 0.0;
    const double dt_s = continuous ? samples / cfg_.rate_hz : 0.0;
    track_counter_ = s.counter;
    track_tick_ = tick;
    orientation_ = track_.update(s.fields[imu_frame::orientation], cfg_.scales.orientation_per_count,
                                 decode_scaled(s.fields[imu_frame::rate], cfg_.scales.rate_rad_s_per_count),
                                 decode_scaled(s.fields[imu_frame::accel], cfg_.scales.accel_m_s2_per_count), dt_s);
  }
  return e;
}

ImuReading ImuAssembler::reading() const noexcept {
  const auto& s = asm_.newest();
  ImuReading r;
  r.orientation = orientation_;
  r.angular_rate_rad_s = decode_scaled(s.fields[imu_frame::rate], cfg_.scales.rate_rad_s_per_count);
  r.linear_accel_m_s2 = decode_scaled(s.fields[imu_frame::accel], cfg_.scales.accel_m_s2_per_count);
  return r;
}

// ---- F/T -----------------------------------------------------------------------------------
// Start-up.
void FtAssembler::configure(const FtConfig& cfg, std::uint64_t tick) {
  cfg_ = cfg;
  to_ee_ = cfg.has_offset ? wrench_transform(cfg.offset) : WrenchTransform{};
  asm_.configure(cfg.stale_ticks, cfg.clip_streak, tick);
}

int FtAssembler::frame_index(std::uint32_t id) const noexcept { return index_of(cfg_.ids, id); }

SensorEvent FtAssembler::push(const Frame& f, std::uint64_t tick) noexcept {
  return asm_.push(frame_index(f.id), f, false, tick);
}

FtReading FtAssembler::reading() const noexcept {
  const auto& s = asm_.newest();
  const Eigen::Vector3d force_s = decode_counts(s.fields[ft_frame::force], cfg_.counts_per_n);
  const Eigen::Vector3d torque_s = decode_counts(s.fields[ft_frame::torque], cfg_.counts_per_nm);
  FtReading r;
  if (cfg_.has_offset) {
    wrench_sensor_to_ee(to_ee_, force_s, torque_s, r.force_n, r.torque_nm);
  } else {
    r.force_n = force_s;
    r.torque_nm = torque_s;
  }
  return r;
}

// ---- sensor side -----------------------------------------------------------------------------
namespace {
// The frames of one sample: the fields of each, the counter and status (plus the
// clipping bit when a field saturated) in all. rt: no alloc
template <std::size_t N>
void emit_sample(const std::array<std::uint32_t, N>& ids, std::array<SensorFrameFields, N>& ff, std::uint8_t counter,
                 std::uint8_t status, bool clipped, std::array<Frame, N>& out) noexcept {
  const auto st = static_cast<std::uint8_t>(status | (clipped ? sensor_status::clipping : 0));
  for (std::size_t i = 0; i < N; ++i) {
    ff[i].counter = counter;
    ff[i].status = st;
    encode_sensor_frame(ids[i], ff[i], out[i]);
  }
}
}  // namespace

bool encode_imu_sample(const ImuConfig& cfg, const ImuReading& r, std::uint8_t counter, std::uint8_t status,
                       std::array<Frame, kImuFrames>& out) noexcept {
  if (!r.orientation.coeffs().allFinite() || !r.angular_rate_rad_s.allFinite() || !r.linear_accel_m_s2.allFinite()) {
    return false;
  }
  std::array<SensorFrameFields, kImuFrames> ff{};
  bool clipped = encode_quaternion(r.orientation, cfg.scales.orientation_per_count, ff[imu_frame::orientation].v);
  clipped = encode_scaled(r.angular_rate_rad_s, cfg.scales.rate_rad_s_per_count, ff[imu_frame::rate].v) || clipped;
  clipped = encode_scaled(r.linear_accel_m_s2, cfg.scales.accel_m_s2_per_count, ff[imu_frame::accel].v) || clipped;
  emit_sample(cfg.ids, ff, counter, status, clipped, out);
  return true;
}

bool encode_ft_sample(const FtConfig& cfg, const Eigen::Vector3d& force_n, const Eigen::Vector3d& torque_nm,
                      std::uint8_t counter, std::uint8_t status, std::array<Frame, kFtFrames>& out) noexcept {
  if (!force_n.allFinite() || !torque_nm.allFinite()) return false;
  std::array<SensorFrameFields, kFtFrames> ff{};
  bool clipped = encode_counts(force_n, cfg.counts_per_n, ff[ft_frame::force].v);
  clipped = encode_counts(torque_nm, cfg.counts_per_nm, ff[ft_frame::torque].v) || clipped;
  emit_sample(cfg.ids, ff, counter, status, clipped, out);
  return true;
}

}  // namespace springbok::can
