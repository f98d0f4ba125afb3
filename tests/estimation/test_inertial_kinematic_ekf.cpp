// InertialKinematicEkf against a closed-form trajectory (no simulator): a trunk that sways
// and turns (1 - cos sinusoids in position, roll, pitch and yaw, their derivatives exact),
// its 4 feet on flat ground at known world points, an IMU mounted upside down, turned and
// off the trunk origin. The IMU's rate and specific force are computed exactly at its point
// (lever arm included), then given constant biases and seeded white noise of stated
// densities; the contact points s_i = R^T (d_i - p) get seeded white noise of a stated std.
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <functional>
#include <limits>
#include <memory>
#include <numbers>
#include <random>
#include <vector>

#include <Eigen/Cholesky>
#include <gtest/gtest.h>

#include "alloc_trap.hpp"
#include "springbok/estimation/inertial_kinematic_ekf.hpp"

namespace {
using namespace springbok::est;
using Vec3 = Eigen::Vector3d;
using Mat3 = Eigen::Matrix3d;
using Quat = Eigen::Quaterniond;
constexpr double kG = 9.81;
constexpr double kDt = 1e-3;

Mat3 rz(double a) { return Eigen::AngleAxisd(a, Vec3::UnitZ()).toRotationMatrix(); }
Mat3 ry(double a) { return Eigen::AngleAxisd(a, Vec3::UnitY()).toRotationMatrix(); }
Mat3 rx(double a) { return Eigen::AngleAxisd(a, Vec3::UnitX()).toRotationMatrix(); }

// Log of a rotation matrix (rotation vector).
Vec3 log_so3(const Mat3& r) {
  const Eigen::AngleAxisd aa(r);
  return aa.angle() * aa.axis();
}

// ---- the truth -------------------------------------------------------------------------

// x(t) = x0 + A (1 - cos(2 pi f t)): at rest at t = 0 (velocity zero), derivatives exact.
struct Wave {
  double x0 = 0.0, amp = 0.0, hz = 1.0;
  double x(double t) const { return x0 + amp * (1.0 - std::cos(2 * std::numbers::pi * hz * t)); }
  double d1(double t) const {
    const double w = 2 * std::numbers::pi * hz;
    return amp * w * std::sin(w * t);
  }
  double d2(double t) const {
    const double w = 2 * std::numbers::pi * hz;
    return amp * w * w * std::cos(w * t);
  }
};

struct Truth {
  Vec3 p, v, a;      // trunk origin, world
  Mat3 rot;          // R_WB
  Vec3 w_b, wdot_b;  // trunk angular rate and its derivative, trunk axes
};

struct Motion {
  std::array<Wave, 3> pos{{{0.1, 0.04, 0.8}, {-0.05, 0.03, 1.1}, {0.55, 0.02, 1.5}}};
  Wave roll{0.02, 0.08, 0.9}, pitch{-0.03, 0.06, 1.3}, yaw{0.3, 0.15, 0.5};
  bool still = false;  // the pose at t = 0 held

  Truth at(double t_in) const {
    const double t = still ? 0.0 : t_in;
    Truth s;
    for (int k = 0; k < 3; ++k) {
      s.p[k] = pos[k].x(t);
      s.v[k] = still ? 0.0 : pos[k].d1(t);
      s.a[k] = still ? 0.0 : pos[k].d2(t);
    }
    const double ps = yaw.x(t), th = pitch.x(t), ph = roll.x(t);
    const double dps = still ? 0 : yaw.d1(t), dth = still ? 0 : pitch.d1(t), dph = still ? 0 : roll.d1(t);
    const double ddps = still ? 0 : yaw.d2(t), ddth = still ? 0 : pitch.d2(t), ddph = still ? 0 : roll.d2(t);
    const Mat3 z = rz(ps), zy = z * ry(th);
    s.rot = zy * rx(ph);
    // w_W = yaw' e_z + pitch' Rz e_y + roll' Rz Ry e_x (ZYX Euler rates).
    const Vec3 ey = z * Vec3::UnitY(), ex = zy * Vec3::UnitX();
    const Vec3 w_zy = dps * Vec3::UnitZ() + dth * ey;  // the angular velocity of Rz Ry
    const Vec3 w_w = w_zy + dph * ex;
    const Vec3 wdot_w = ddps * Vec3::UnitZ() + ddth * ey + dth * (dps * Vec3::UnitZ()).cross(ey) + ddph * ex +
                        dph * w_zy.cross(ex);
    s.w_b = s.rot.transpose() * w_w;
    s.wdot_b = s.rot.transpose() * wdot_w;  // d/dt (R^T w_W) = R^T w_W' (the w x w term vanishes)
    return s;
  }
};

ImuMounting test_mounting() {
  ImuMounting m;
  m.rotation_bi = rx(std::numbers::pi) * rz(std::numbers::pi / 2);  // upside down, turned 90 degrees
  m.position_bi_m = Vec3(0.12, -0.04, 0.07);
  return m;
}

// The exact IMU sample at the truth (no bias, no noise).
ImuSample exact_imu(const Truth& s, const ImuMounting& m) {
  const Vec3& r = m.position_bi_m;
  const Vec3 a_imu = s.a + s.rot * (s.wdot_b.cross(r) + s.w_b.cross(s.w_b.cross(r)));
  ImuSample imu;
  imu.rate_i_rad_s = m.rotation_bi.transpose() * s.w_b;
  imu.specific_force_i_m_s2 = m.rotation_bi.transpose() * (s.rot.transpose() * (a_imu - Vec3(0, 0, -kG)));
  return imu;
}

// ---- the scenario ---------------------------------------------------------------------

struct Sensors {
  Vec3 gyro_bias = Vec3::Zero(), accel_bias = Vec3::Zero();
  double gyro_noise = 0.0;   // rad/s/sqrt(Hz)
  double accel_noise = 0.0;  // m/s^2/sqrt(Hz)
  double kin_std_m = 0.0;    // per axis, trunk axes
  double leg_velocity_std_m_s = 0.0;  // per axis, trunk axes; 0: no leg velocity measured
};

Sensors noisy_biased() {
  Sensors s;
  s.gyro_bias = Vec3(0.01, -0.01, 0.01);
  s.accel_bias = Vec3(0.1, -0.1, 0.1);
  s.gyro_noise = 5e-4;
  s.accel_noise = 2e-3;
  s.kin_std_m = 1.5e-3;
  return s;
}

// The feet's world ground points and contact flags at time t.
struct Feet {
  std::array<Vec3, kEkfFeet> point;
  std::array<bool, kEkfFeet> contact{true, true, true, true};
  std::array<Vec3, kEkfFeet> told_velocity{Vec3::Zero(), Vec3::Zero(), Vec3::Zero(), Vec3::Zero()};  // u_i given
};
using FeetPath = std::function<Feet(double t)>;

Feet standing_feet() {
  Feet f;
  const double x = 0.1, y = -0.05;
  f.point = {Vec3(x + 0.36, y + 0.22, 0), Vec3(x + 0.36, y - 0.22, 0), Vec3(x - 0.36, y + 0.22, 0),
             Vec3(x - 0.36, y - 0.22, 0)};
  return f;
}

class Sim {
 public:
  Sim(const Motion& motion, const Sensors& sensors, std::uint64_t seed, FeetPath feet = {})
      : motion_(motion), sensors_(sensors), mounting_(test_mounting()), rng_(seed),
        feet_(feet ? std::move(feet) : FeetPath([](double) { return standing_feet(); })) {}

  Truth truth(double t) const { return motion_.at(t); }
  Feet feet(double t) const { return feet_(t); }
  const ImuMounting& mounting() const { return mounting_; }

  ImuSample imu(double t) {
    ImuSample s = exact_imu(motion_.at(t), mounting_);
    const double sg = sensors_.gyro_noise / std::sqrt(kDt), sa = sensors_.accel_noise / std::sqrt(kDt);
    for (int k = 0; k < 3; ++k) {
      s.rate_i_rad_s[k] += sensors_.gyro_bias[k] + sg * n_(rng_);
      s.specific_force_i_m_s2[k] += sensors_.accel_bias[k] + sa * n_(rng_);
    }
    return s;
  }

  FootMeasurements foot_measurements(double t) {
    const Truth s = motion_.at(t);
    const Feet f = feet_(t);
    FootMeasurements out;
    const double sd = std::max(sensors_.kin_std_m, 1e-4);  // the filter is told at least 0.1 mm
    for (int i = 0; i < kEkfFeet; ++i) {
      FootMeasurement& m = out[static_cast<std::size_t>(i)];
      m.contact = f.contact[static_cast<std::size_t>(i)];
      m.contact_point_b_m = s.rot.transpose() * (f.point[static_cast<std::size_t>(i)] - s.p);
      if (sensors_.leg_velocity_std_m_s > 0.0) {  // a point standing in the world: e = d/dt s = -w x s - R^T v
        m.velocity_valid = true;
        m.velocity_b_m_s = -s.w_b.cross(m.contact_point_b_m) - s.rot.transpose() * s.v;
        for (int k = 0; k < 3; ++k) m.velocity_b_m_s[k] += sensors_.leg_velocity_std_m_s * n_(rng_);
        m.velocity_covariance_b_m2_s2 = Mat3::Identity() * sensors_.leg_velocity_std_m_s * sensors_.leg_velocity_std_m_s;
      }
      for (int k = 0; k < 3; ++k) m.contact_point_b_m[k] += sensors_.kin_std_m * n_(rng_);
      m.covariance_b_m2 = Mat3::Identity() * sd * sd;
      m.anchor_velocity_w_m_s = f.told_velocity[static_cast<std::size_t>(i)];
    }
    return out;
  }

  EkfInput input(double t) {
    EkfInput in;
    in.imu = imu(t);
    in.feet = foot_measurements(t);
    const Truth s = motion_.at(t);
    in.orientation_valid = true;
    in.orientation_wi = Quat(s.rot * mounting_.rotation_bi);
    return in;
  }

 private:
  Motion motion_;
  Sensors sensors_;
  ImuMounting mounting_;
  std::mt19937_64 rng_;
  std::normal_distribution<double> n_{0.0, 1.0};
  FeetPath feet_;
};

// The true pose and velocity at t = 0, the given bias estimates, and the IMU's sample at that
// instant (its biases and noise, as the next ones).
EkfInitialState truth_start(Sim& sim, const Vec3& accel_bias = Vec3::Zero(), const Vec3& gyro_bias = Vec3::Zero()) {
  const Truth s = sim.truth(0.0);
  EkfInitialState init;
  init.has_imu = true;
  init.imu = sim.imu(0.0);
  init.position_w_m = s.p;
  init.velocity_w_m_s = s.v;
  init.orientation_wb = Quat(s.rot);
  init.accel_bias_i_m_s2 = accel_bias;
  init.gyro_bias_i_rad_s = gyro_bias;
  return init;
}

// World-axes rotation error: R_true = Exp(e) R_est.
Vec3 rotation_error(const Truth& s, const InertialKinematicEkf& ekf) {
  return log_so3(s.rot * ekf.rotation_wb().transpose());
}
double tilt_error(const Truth& s, const InertialKinematicEkf& ekf) { return rotation_error(s, ekf).head<2>().norm(); }

// The error state (truth less estimate), in the filter's order.
EkfVector error_state(const Truth& s, const Feet& feet, const Sensors& sensors, const InertialKinematicEkf& ekf) {
  EkfVector e;
  const Vec3& r = ekf.mounting().position_bi_m;  // the state's p, v are the IMU point's
  e.segment<3>(kEkfP) = s.p + s.rot * r - ekf.imu_position_w_m();
  e.segment<3>(kEkfV) = s.v + s.rot * s.w_b.cross(r) - ekf.imu_velocity_w_m_s();
  e.segment<3>(kEkfTh) = rotation_error(s, ekf);
  for (int f = 0; f < kEkfFeet; ++f) {
    e.segment<3>(ekf_foot_index(f)) = feet.point[static_cast<std::size_t>(f)] - ekf.foot_position_w_m(f);
  }
  e.segment<3>(kEkfBa) = sensors.accel_bias - ekf.accel_bias_i_m_s2();
  e.segment<3>(kEkfBg) = sensors.gyro_bias - ekf.gyro_bias_i_rad_s();
  return e;
}

double rms(const std::vector<double>& x) {
  double s = 0;
  for (double v : x) s += v * v;
  return x.empty() ? 0.0 : std::sqrt(s / static_cast<double>(x.size()));
}

// The first time from which |err| stays within bound to the end (the end if never).
double settle_time(const std::vector<double>& t, const std::vector<double>& err, double bound) {
  double settled = t.empty() ? 0.0 : t.back();
  for (std::size_t k = err.size(); k-- > 0;) {
    if (std::abs(err[k]) > bound) break;
    settled = t[k];
  }
  return settled;
}

// Runs the filter from t = 0 for `ticks` of dt_s, calling `each(t, truth, ekf)` after each tick.
void run(Sim& sim, InertialKinematicEkf& ekf, int ticks,
         const std::function<void(double, const Truth&, const InertialKinematicEkf&)>& each, double dt_s = kDt) {
  for (int k = 1; k <= ticks; ++k) {
    const double t = k * dt_s;
    const EkfStatus st = ekf.update(sim.input(t), dt_s);
    ASSERT_TRUE(st == EkfStatus::ok || st == EkfStatus::no_anchor) << to_string(st) << " at t = " << t;
    each(t, sim.truth(t), ekf);
  }
}

// ---- the oracle's own check ---------------------------------------------------------------

TEST(InertialKinematicEkfTruth, TheTrajectorysDerivativesAreItsFiniteDifferences) {
  const Motion m;
  const double h = 1e-5;
  for (double t : {0.0, 0.37, 1.21, 2.9}) {
    const Truth s = m.at(t), a = m.at(t - h), b = m.at(t + h);
    EXPECT_LT(((b.p - a.p) / (2 * h) - s.v).norm(), 1e-7);
    EXPECT_LT(((b.v - a.v) / (2 * h) - s.a).norm(), 1e-6);
    // R' = R [w]x
    const Mat3 rdot = (b.rot - a.rot) / (2 * h);
    const Mat3 wx = s.rot.transpose() * rdot;
    EXPECT_LT((Vec3(wx(2, 1), wx(0, 2), wx(1, 0)) - s.w_b).norm(), 1e-7);
    EXPECT_LT(((b.w_b - a.w_b) / (2 * h) - s.wdot_b).norm(), 1e-6);
    // The IMU's specific force is the second derivative of its point's position, less g.
    const ImuMounting mount = test_mounting();
    const auto imu_point = [&](double tt) {
      const Truth q = m.at(tt);
      return Vec3(q.p + q.rot * mount.position_bi_m);
    };
    const double h2 = 1e-4;
    const Vec3 acc = (imu_point(t + h2) - 2 * imu_point(t) + imu_point(t - h2)) / (h2 * h2);
    const ImuSample imu = exact_imu(s, mount);
    EXPECT_LT((s.rot * mount.rotation_bi * imu.specific_force_i_m_s2 - (acc - Vec3(0, 0, -kG))).norm(), 1e-5);
  }
}

// ---- 1. tracking and bias convergence -----------------------------------------------------

// With no bias and no noise the filter follows the truth to the discretisation's error: the
// IMU's samples are taken linear over a tick (second order), so halving the tick divides the
// error by about 4; an error of the model (a lever arm, a frame, a sign) would not shrink.
struct MaxErrors {
  double p = 0, v = 0, th = 0, ba = 0, bg = 0;
};
MaxErrors noiseless_run(double dt_s, double duration_s) {
  Sim sim(Motion{}, Sensors{}, 1);  // kin_std 0: the filter is told 0.1 mm
  InertialKinematicEkf ekf(sim.mounting());
  EXPECT_EQ(ekf.start_at(truth_start(sim), sim.foot_measurements(0)), EkfStatus::ok);
  MaxErrors m;
  run(
      sim, ekf, static_cast<int>(std::lround(duration_s / dt_s)),
      [&](double, const Truth& s, const InertialKinematicEkf& e) {
        m.p = std::max(m.p, (s.p - e.position_w_m()).norm());
        m.v = std::max(m.v, (s.v - e.velocity_w_m_s()).norm());
        m.th = std::max(m.th, rotation_error(s, e).norm());
        m.ba = std::max(m.ba, e.accel_bias_i_m_s2().norm());
        m.bg = std::max(m.bg, e.gyro_bias_i_rad_s().norm());
      },
      dt_s);
  std::printf("noiseless, dt %.2g s: max |dp| %.3g m, |dv| %.3g m/s, |dth| %.3g rad, |b_a| %.3g m/s^2, |b_g| %.3g rad/s\n",
              dt_s, m.p, m.v, m.th, m.ba, m.bg);
  return m;
}

TEST(InertialKinematicEkf, WithoutNoiseOrBiasItTracksTheTruthToTheDiscretisationsError) {
  const MaxErrors a = noiseless_run(kDt, 3.0), b = noiseless_run(kDt / 2, 3.0);
  // At 1 kHz:
  EXPECT_LT(a.p, 2e-6);
  EXPECT_LT(a.v, 1e-5);
  EXPECT_LT(a.th, 5e-6);
  EXPECT_LT(a.ba, 5e-5);
  EXPECT_LT(a.bg, 5e-6);
  // Second order: half the tick, a quarter of the error (3 allows for the filter's mixing).
  std::printf("dt halved: error ratios p %.2f v %.2f th %.2f b_a %.2f b_g %.2f\n", a.p / b.p, a.v / b.v, a.th / b.th,
              a.ba / b.ba, a.bg / b.bg);
  EXPECT_GT(a.v / b.v, 3.0);
  EXPECT_GT(a.th / b.th, 3.0);
  EXPECT_GT(a.ba / b.ba, 3.0);
}

struct ConvergenceRun {
  std::vector<double> t, v_err, tilt, yaw;
  std::array<std::vector<double>, 3> bg_err, ba_err;
};

ConvergenceRun converge(const EkfParams& params, int ticks, std::uint64_t seed, double leg_velocity_std_m_s = 0.0) {
  Sensors sensors = noisy_biased();
  sensors.leg_velocity_std_m_s = leg_velocity_std_m_s;
  Sim sim(Motion{}, sensors, seed);
  InertialKinematicEkf ekf(sim.mounting(), params);
  ConvergenceRun r;
  // The true pose and velocity, the biases unknown (zero).
  EXPECT_EQ(ekf.start_at(truth_start(sim), sim.foot_measurements(0)), EkfStatus::ok);
  run(sim, ekf, ticks, [&](double t, const Truth& s, const InertialKinematicEkf& e) {
    r.t.push_back(t);
    r.v_err.push_back((s.v - e.velocity_w_m_s()).norm());
    r.tilt.push_back(tilt_error(s, e));
    r.yaw.push_back(rotation_error(s, e).z());
    for (int k = 0; k < 3; ++k) {
      r.bg_err[static_cast<std::size_t>(k)].push_back(e.gyro_bias_i_rad_s()[k] - sensors.gyro_bias[k]);
      r.ba_err[static_cast<std::size_t>(k)].push_back(e.accel_bias_i_m_s2()[k] - sensors.accel_bias[k]);
    }
  });
  return r;
}

std::vector<double> after(const std::vector<double>& t, const std::vector<double>& x, double t0) {
  std::vector<double> out;
  for (std::size_t k = 0; k < t.size(); ++k) {
    if (t[k] >= t0) out.push_back(x[k]);
  }
  return out;
}

// Gyro bias 10 mrad/s and accelerometer bias 0.1 m/s^2 per axis (unknown at the start), gyro
// noise 5e-4 rad/s/sqrt(Hz), accelerometer 2e-3 m/s^2/sqrt(Hz), kinematics 1.5 mm per axis.
// Observable while the feet stand: the whole accelerometer bias (the ground row makes the tilt
// measured) and the whole gyro bias, its vertical part (IMU z, the trunk's -z) too: it yaws the
// trunk relative to feet that do not move, which the kinematics see. (Unobservable: the
// absolute yaw and position, WithTheFeetStandingTheAbsoluteYawIsUnobservable...) Bounds: gyro
// 1.5 mrad/s from 1.5 s (x, y) and 2 s (z), accelerometer 0.015 m/s^2 from 1 s; after 2 s tilt
// rms below 2 mrad, velocity rms below 0.03 m/s.
TEST(InertialKinematicEkf, BiasesConvergeAndTheTiltAndVelocityFollow) {
  const ConvergenceRun r = converge(EkfParams{}, 4000, 2);
  const double bg_bound = 1.5e-3, ba_bound = 0.015;
  for (int k = 0; k < 3; ++k) {
    const auto& bg = r.bg_err[static_cast<std::size_t>(k)];
    const auto& ba = r.ba_err[static_cast<std::size_t>(k)];
    std::printf("axis %d: b_g error at start %.4f, end %.5f rad/s, within %.1e from %.3f s; b_a error end %.5f m/s^2, "
                "within %.3f from %.3f s\n",
                k, bg.front(), bg.back(), bg_bound, settle_time(r.t, bg, bg_bound), ba.back(), ba_bound,
                settle_time(r.t, ba, ba_bound));
    EXPECT_LE(settle_time(r.t, bg, bg_bound), k < 2 ? 1.5 : 2.0) << "gyro axis " << k;
    EXPECT_LE(settle_time(r.t, ba, ba_bound), 1.0) << "accel axis " << k;
  }
  const double tilt_rms = rms(after(r.t, r.tilt, 2.0)), v_rms = rms(after(r.t, r.v_err, 2.0));
  const double v_rms_all = rms(r.v_err);
  std::printf("after 2 s: tilt rms %.3g mrad, velocity rms %.3g m/s (whole run %.3g m/s)\n", 1e3 * tilt_rms, v_rms,
              v_rms_all);
  EXPECT_LT(tilt_rms, 2e-3);
  EXPECT_LT(v_rms, 0.03);
  EXPECT_LT(v_rms_all, 0.03);
}

// The legs' velocity (leg odometry: each stance foot's joint rates, 10 mm/s of noise per axis
// and sample) measured beside the kinematics: the same biases converge within the same bounds,
// and the velocity's error is smaller than from the kinematic positions alone (same seeds).
TEST(InertialKinematicEkf, TheLegVelocityIsMeasuredAndTheBiasesStillConverge) {
  for (std::uint64_t seed : {2u, 3u}) {
    const ConvergenceRun with = converge(EkfParams{}, 4000, seed, 0.01), without = converge(EkfParams{}, 4000, seed);
    for (int k = 0; k < 3; ++k) {
      EXPECT_LE(settle_time(with.t, with.bg_err[static_cast<std::size_t>(k)], 1.5e-3), k < 2 ? 1.5 : 2.0) << k;
      EXPECT_LE(settle_time(with.t, with.ba_err[static_cast<std::size_t>(k)], 0.015), 1.0) << k;
    }
    const double v_with = rms(after(with.t, with.v_err, 2.0)), v_without = rms(after(without.t, without.v_err, 2.0));
    const double tilt_with = rms(after(with.t, with.tilt, 2.0)), tilt_without = rms(after(without.t, without.tilt, 2.0));
    std::printf("seed %llu, after 2 s: velocity rms %.3g m/s with the leg velocity, %.3g without; tilt rms %.3g / %.3g mrad\n",
                static_cast<unsigned long long>(seed), v_with, v_without, 1e3 * tilt_with, 1e3 * tilt_without);
    EXPECT_LT(v_with, v_without);
    EXPECT_LT(tilt_with, 2e-3);
  }
}

// The absolute yaw and horizontal position are unobservable (turning or moving the trunk and
// the feet together changes no measurement): their stds stay at their prior's (the yaw's within
// 2 %: linearised at the moving estimate, an EKF gains a little information it has not, the
// inconsistency an invariant EKF or first-estimate Jacobians remove), while
// the yaw's drift is observable while the feet stand, so the vertical gyro bias converges even
// with the trunk held level (no roll, no pitch: gravity never sweeps the IMU's axes).
TEST(InertialKinematicEkf, WithTheFeetStandingTheAbsoluteYawIsUnobservableButTheVerticalGyroBiasIsNot) {
  Motion level;
  level.roll = Wave{0.0, 0.0, 1.0};
  level.pitch = Wave{0.0, 0.0, 1.0};
  const Sensors sensors = noisy_biased();
  Sim sim(level, sensors, 4);
  const EkfParams params;
  InertialKinematicEkf ekf(sim.mounting(), params);
  ASSERT_EQ(ekf.start_at(truth_start(sim), sim.foot_measurements(0)), EkfStatus::ok);
  double min_yaw_sd = 1.0, min_xy_sd = 1.0;
  run(sim, ekf, 3000, [&](double, const Truth&, const InertialKinematicEkf& e) {
    const EkfVector d = e.covariance_diagonal();
    min_yaw_sd = std::min(min_yaw_sd, std::sqrt(d[kEkfTh + 2]));
    min_xy_sd = std::min({min_xy_sd, std::sqrt(d[kEkfP]), std::sqrt(d[kEkfP + 1])});
  });
  const Vec3 sd = ekf.covariance_diagonal().segment<3>(kEkfBg).cwiseSqrt();
  const Vec3 err = ekf.gyro_bias_i_rad_s() - sensors.gyro_bias;
  std::printf("level trunk, 3 s: yaw std never below %.4g rad (prior %.4g), x-y std never below %.4g m (prior %.4g); "
              "gyro bias std (%.2g, %.2g, %.2g) rad/s (prior %.2g), error (%.2g, %.2g, %.2g)\n",
              min_yaw_sd, params.initial_yaw_std_rad, min_xy_sd, params.initial_position_std_m, sd.x(), sd.y(), sd.z(),
              params.initial_gyro_bias_std_rad_s, err.x(), err.y(), err.z());
  EXPECT_GE(min_yaw_sd, 0.98 * params.initial_yaw_std_rad);
  EXPECT_GE(min_xy_sd, 0.999 * params.initial_position_std_m);
  for (int k = 0; k < 3; ++k) {
    EXPECT_LT(sd[k], 0.1 * params.initial_gyro_bias_std_rad_s) << "axis " << k;
    EXPECT_LT(std::abs(err[k]), 1.5e-3) << "axis " << k;
  }
}

// A start 8 mrad off in yaw (its prior 10 mrad): without the aid the error stays (the absolute
// yaw is unobservable); with the IMU's yaw (std 10 mrad, the IMU's output exact here) it goes,
// and the gyro bias converges as without it.
TEST(InertialKinematicEkf, TheYawAidMakesTheYawObservable) {
  const Sensors sensors = noisy_biased();
  double end_err[2] = {0, 0}, rms_after[2] = {0, 0}, end_sd[2] = {0, 0};
  for (int aid = 0; aid < 2; ++aid) {
    Sim sim(Motion{}, sensors, 3);
    EkfParams params;
    params.orientation_aid = aid ? OrientationAid::yaw : OrientationAid::off;
    params.yaw_std_rad = 0.01;
    InertialKinematicEkf ekf(sim.mounting(), params);
    EkfInitialState init = truth_start(sim);
    init.orientation_wb = Quat(Eigen::AngleAxisd(0.008, Vec3::UnitZ())) * init.orientation_wb;
    ASSERT_EQ(ekf.start_at(init, sim.foot_measurements(0)), EkfStatus::ok);
    std::vector<double> t, yaw, bg[3];
    run(sim, ekf, 3000, [&](double tt, const Truth& s, const InertialKinematicEkf& e) {
      t.push_back(tt);
      yaw.push_back(rotation_error(s, e).z());
      for (int k = 0; k < 3; ++k) bg[k].push_back(e.gyro_bias_i_rad_s()[k] - sensors.gyro_bias[k]);
    });
    end_err[aid] = yaw.back();
    rms_after[aid] = rms(after(t, yaw, 1.0));
    end_sd[aid] = std::sqrt(ekf.covariance_diagonal()[kEkfTh + 2]);
    for (int k = 0; k < 3; ++k) {
      std::printf("yaw aid %s, axis %d: b_g error end %.5f rad/s, within 1.5e-03 from %.3f s\n", aid ? "on" : "off", k,
                  bg[k].back(), settle_time(t, bg[k], 1.5e-3));
      EXPECT_LE(settle_time(t, bg[k], 1.5e-3), 2.0) << "gyro axis " << k;
    }
  }
  std::printf("start 8 mrad off in yaw: aid off, yaw error at 3 s %.3g mrad (std %.3g); aid on %.3g mrad (std %.3g), rms "
              "after 1 s %.3g mrad\n",
              1e3 * end_err[0], 1e3 * end_sd[0], 1e3 * end_err[1], 1e3 * end_sd[1], 1e3 * rms_after[1]);
  EXPECT_GT(std::abs(end_err[0]), 0.006);  // (the truth minus the estimate: -8 mrad, kept)
  EXPECT_LT(rms_after[1], 1e-3);
  EXPECT_LT(end_sd[1], 0.2 * end_sd[0]);
}

// ---- 2. calibration -----------------------------------------------------------------------

Motion still_motion() {
  Motion m;
  m.still = true;
  return m;
}

// Records `n` samples of `sim` at 1 kHz from t = 0.
void record(InertialKinematicEkf& ekf, Sim& sim, int n) {
  for (int k = 0; k < n; ++k) (void)ekf.calibrate_sample(sim.imu(k * kDt), kDt);
}

// A 20 mrad/s turn-on gyro bias, 1 s at rest: the mean rate's error has std sigma_g / sqrt(T)
// per axis (0.5 mrad/s here). Over 20 recordings its rms is that within the spread of a
// 60-sample rms (+-20 %); each error within 4 of it.
TEST(InertialKinematicEkf, CalibrationTakesOutTheTurnOnGyroBiasToTheNoisesMeanError) {
  Sensors sensors = noisy_biased();
  sensors.gyro_bias = Vec3(0.02, -0.02, 0.02);
  sensors.accel_bias.setZero();
  const double expected = sensors.gyro_noise / std::sqrt(1.0);  // rad/s, T = 1 s
  const double tilt_expected = sensors.accel_noise / (kG * std::sqrt(1.0));
  double sum2 = 0, worst = 0, worst_tilt = 0;
  int count = 0;
  for (std::uint64_t seed = 100; seed < 120; ++seed) {
    Sim sim(still_motion(), sensors, seed);
    InertialKinematicEkf ekf(sim.mounting());
    EXPECT_EQ(ekf.evaluate_calibration().status, CalibrationStatus::empty);
    record(ekf, sim, 1000);
    const CalibrationResult& c = ekf.evaluate_calibration();
    ASSERT_EQ(c.status, CalibrationStatus::ready) << to_string(c.status);
    EXPECT_EQ(c.samples, 1000);
    for (int k = 0; k < 3; ++k) {
      const double e = c.gyro_bias_i_rad_s[k] - sensors.gyro_bias[k];
      sum2 += e * e;
      ++count;
      worst = std::max(worst, std::abs(e));
    }
    // Roll and pitch from the mean specific force (no accelerometer bias here).
    const Truth s = sim.truth(0);
    const Mat3 est = rz(0.3) * ry(c.pitch_rad) * rx(c.roll_rad);
    worst_tilt = std::max(worst_tilt, log_so3(s.rot * est.transpose()).head<2>().norm());
  }
  const double rms_err = std::sqrt(sum2 / count);
  std::printf("calibration: gyro bias error rms %.3g rad/s (expected %.3g), worst %.3g; tilt worst %.3g rad (std %.3g)\n",
              rms_err, expected, worst, worst_tilt, tilt_expected);
  EXPECT_GT(rms_err, 0.8 * expected);
  EXPECT_LT(rms_err, 1.2 * expected);
  EXPECT_LT(worst, 4 * expected);
  EXPECT_LT(worst_tilt, 4 * std::sqrt(2.0) * tilt_expected);
}

// The start from the recording: the trunk above the feet at the ground height, x, y and yaw as
// given; with an accelerometer bias the tilt is off by its horizontal part over g, as the
// start's covariance says (dth = [e_z]x C b_a / g).
TEST(InertialKinematicEkf, TheCalibratedStartStandsOnTheFeetAndKnowsItsTiltsErrorIsTheAccelBias) {
  const Sensors sensors = noisy_biased();
  Sim sim(still_motion(), sensors, 7);
  InertialKinematicEkf ekf(sim.mounting());
  record(ekf, sim, 1000);
  const Truth s = sim.truth(0);
  ASSERT_EQ(ekf.start_from_calibration(sim.foot_measurements(0), s.p.head<2>(), 0.3), EkfStatus::ok);
  EXPECT_EQ(ekf.calibration().status, CalibrationStatus::ready);
  EXPECT_NEAR(ekf.position_w_m().x(), s.p.x(), 1e-12);
  EXPECT_NEAR(ekf.position_w_m().y(), s.p.y(), 1e-12);
  EXPECT_NEAR(ekf.position_w_m().z(), s.p.z(), 3e-3);  // kinematics' noise and the tilt over the feet
  const Mat3 r = ekf.rotation_wb();
  EXPECT_NEAR(std::atan2(r(1, 0), r(0, 0)), 0.3, 1e-12);
  const Vec3 err = rotation_error(s, ekf);
  const Mat3 c = r * sim.mounting().rotation_bi;
  const Vec3 predicted = Vec3::UnitZ().cross(c * sensors.accel_bias) / kG;
  std::printf("calibrated start: tilt error (%.3g, %.3g) rad, predicted from b_a (%.3g, %.3g)\n", err.x(), err.y(),
              predicted.x(), predicted.y());
  EXPECT_LT((err.head<2>() - predicted.head<2>()).norm(), 1e-3);
  // The covariance holds that: the tilt's correlation with b_a is near -1 or 1.
  const EkfCovariance& P = ekf.covariance();
  for (int k = 0; k < 2; ++k) {
    double best = 0;
    for (int j = 0; j < 3; ++j) {
      best = std::max(best, std::abs(P(kEkfTh + k, kEkfBa + j)) /
                                std::sqrt(P(kEkfTh + k, kEkfTh + k) * P(kEkfBa + j, kEkfBa + j)));
    }
    EXPECT_GT(best, 0.95) << "tilt axis " << k;
  }
  EXPECT_EQ(ekf.gyro_bias_i_rad_s(), ekf.calibration().gyro_bias_i_rad_s);
}

TEST(InertialKinematicEkf, AnUnstillShortOrBadRecordingIsRefused) {
  const Sensors sensors = noisy_biased();
  {  // the trunk swaying while recording
    Sim sim(Motion{}, sensors, 8);
    InertialKinematicEkf ekf(sim.mounting());
    record(ekf, sim, 1000);
    EXPECT_EQ(ekf.evaluate_calibration().status, CalibrationStatus::unstill);
    std::printf("unstill recording: gyro spread (%.3g, %.3g, %.3g) rad/s\n", ekf.calibration().gyro_spread_i_rad_s.x(),
                ekf.calibration().gyro_spread_i_rad_s.y(), ekf.calibration().gyro_spread_i_rad_s.z());
    EXPECT_EQ(ekf.start_from_calibration(sim.foot_measurements(0), Eigen::Vector2d::Zero()), EkfStatus::not_started);
    EXPECT_FALSE(ekf.started());
    EXPECT_EQ(ekf.update(sim.input(kDt), kDt), EkfStatus::not_started);
    // Starting over at rest succeeds.
    ekf.restart_calibration();
    Sim still(still_motion(), sensors, 9);
    record(ekf, still, 1000);
    EXPECT_EQ(ekf.start_from_calibration(still.foot_measurements(0), Eigen::Vector2d::Zero()), EkfStatus::ok);
  }
  {  // too short; then collecting (usable) but not ready; a bad sample is not recorded
    Sim sim(still_motion(), sensors, 10);
    InertialKinematicEkf ekf(sim.mounting());
    record(ekf, sim, 50);
    EXPECT_EQ(ekf.evaluate_calibration().status, CalibrationStatus::too_few_samples);
    EXPECT_EQ(ekf.start_from_calibration(sim.foot_measurements(0), Eigen::Vector2d::Zero()), EkfStatus::not_started);
    ImuSample bad = sim.imu(0);
    bad.rate_i_rad_s.x() = std::numeric_limits<double>::quiet_NaN();
    EXPECT_EQ(ekf.calibrate_sample(bad, kDt), CalibrationStatus::bad_sample);
    EXPECT_EQ(ekf.calibrate_sample(sim.imu(0), -kDt), CalibrationStatus::bad_sample);
    EXPECT_EQ(ekf.evaluate_calibration().samples, 50);
    EXPECT_EQ(ekf.calibrate_sample(sim.imu(0), kDt), CalibrationStatus::collecting);
    record(ekf, sim, 449);
    EXPECT_EQ(ekf.evaluate_calibration().status, CalibrationStatus::collecting);
    FootMeasurements airborne = sim.foot_measurements(0);
    for (auto& f : airborne) f.contact = false;
    EXPECT_EQ(ekf.start_from_calibration(airborne, Eigen::Vector2d::Zero()), EkfStatus::no_anchor);
  }
  {  // an accelerometer that reads in g, not m/s^2
    Sim sim(still_motion(), sensors, 11);
    InertialKinematicEkf ekf(sim.mounting());
    for (int k = 0; k < 1000; ++k) {
      ImuSample imu = sim.imu(k * kDt);
      imu.specific_force_i_m_s2 /= kG;
      (void)ekf.calibrate_sample(imu, kDt);
    }
    EXPECT_EQ(ekf.evaluate_calibration().status, CalibrationStatus::bad_gravity);
  }
}

// ---- 3. slip ----------------------------------------------------------------------------

constexpr double kSlipStart = 1.5, kSlipEnd = 1.7, kSlipSpeed = 0.3;  // s, s, m/s (LF along world x)

Feet slipping_feet(double t) {
  Feet f = standing_feet();
  f.point[0].x() += kSlipSpeed * std::clamp(t - kSlipStart, 0.0, kSlipEnd - kSlipStart);
  return f;  // the stance word says contact throughout
}

struct SlipRun {
  double first_rejected = -1, accepted_again = -1, rejected_fraction = 0;
  double max_v_err = 0;       // during the slide and 0.5 s after it
  double max_v_err_before = 0;  // in the 1 s before the slide
  double p_err_end = 0;       // horizontal, at the end
  int others_rejected_ticks = 0;
};

SlipRun slip_run(double gate_chi2) {
  const Sensors sensors = noisy_biased();
  Sim sim(Motion{}, sensors, 21, slipping_feet);
  EkfParams params;
  params.slip_gate_chi2 = gate_chi2;
  InertialKinematicEkf ekf(sim.mounting(), params);
  EXPECT_EQ(ekf.start_at(truth_start(sim, sensors.accel_bias, sensors.gyro_bias), sim.foot_measurements(0)),
            EkfStatus::ok);
  SlipRun r;
  int slide_ticks = 0, slide_rejected = 0;
  bool was_rejected = false;
  run(sim, ekf, 2500, [&](double t, const Truth& s, const InertialKinematicEkf& e) {
    const bool rej = e.foot_rejected(0);
    if (rej && r.first_rejected < 0 && t >= kSlipStart) r.first_rejected = t;
    if (t > kSlipStart + 0.05 && t <= kSlipEnd) {
      ++slide_ticks;
      slide_rejected += rej ? 1 : 0;
    }
    if (t > kSlipEnd && was_rejected && !rej) r.accepted_again = t;  // the last re-acceptance
    if (t > kSlipEnd && rej) r.accepted_again = -1;
    was_rejected = rej;
    for (int f = 1; f < kEkfFeet; ++f) r.others_rejected_ticks += e.foot_rejected(f) ? 1 : 0;
    const double ev = (s.v - e.velocity_w_m_s()).norm();
    if (t >= kSlipStart - 1.0 && t < kSlipStart) r.max_v_err_before = std::max(r.max_v_err_before, ev);
    if (t >= kSlipStart && t <= kSlipEnd + 0.5) r.max_v_err = std::max(r.max_v_err, ev);
    r.p_err_end = (s.p - e.position_w_m()).head<2>().norm();
  });
  r.rejected_fraction = slide_ticks > 0 ? static_cast<double>(slide_rejected) / slide_ticks : 0.0;
  return r;
}

// LF slides 0.3 m/s for 0.2 s (6 cm) along x while its stance flag says contact.
TEST(InertialKinematicEkf, ASlidingFootIsRejectedAndTheVelocityStaysBounded) {
  const SlipRun g = slip_run(EkfParams{}.slip_gate_chi2);
  const SlipRun n = slip_run(std::numeric_limits<double>::infinity());
  std::printf("slip, gate on: first rejected %.3f s (slide from %.1f), rejected %.0f %% of [%.2f, %.1f] s, accepted "
              "again %.3f s (slide ends %.1f); max |v error| %.4f m/s (before the slide %.4f), horizontal position "
              "error at the end %.4f m; the other feet rejected %d ticks\n",
              g.first_rejected, kSlipStart, 100 * g.rejected_fraction, kSlipStart + 0.05, kSlipEnd, g.accepted_again,
              kSlipEnd, g.max_v_err, g.max_v_err_before, g.p_err_end, g.others_rejected_ticks);
  std::printf("slip, gate off: max |v error| %.4f m/s, horizontal position error at the end %.4f m\n", n.max_v_err,
              n.p_err_end);
  EXPECT_GT(g.first_rejected, kSlipStart);
  EXPECT_LT(g.first_rejected, kSlipStart + 0.05);
  EXPECT_GT(g.rejected_fraction, 0.95);
  EXPECT_GT(g.accepted_again, kSlipEnd);
  EXPECT_LT(g.accepted_again, kSlipEnd + 0.2);
  EXPECT_LT(g.max_v_err, 0.03);
  EXPECT_GT(n.max_v_err, 2.0 * g.max_v_err);     // the gate's worth, in velocity
  EXPECT_GT(n.p_err_end, 3.0 * g.p_err_end);     // and in position
  EXPECT_LT(g.others_rejected_ticks, 2500 * 3 / 100);  // false alarms: under 1 % of the ticks
}

// The same motion of LF's contact point, told as the anchor's known motion (as a rolling
// sphere's contact point is): no slip, the foot stays anchored and follows it.
TEST(InertialKinematicEkf, AnAnchorsToldMotionIsNoSlip) {
  const Sensors sensors = noisy_biased();
  Sim sim(Motion{}, sensors, 21, [](double t) {
    Feet f = slipping_feet(t);
    if (t > kSlipStart && t <= kSlipEnd) f.told_velocity[0] = Vec3(kSlipSpeed, 0, 0);
    return f;
  });
  InertialKinematicEkf ekf(sim.mounting());
  ASSERT_EQ(ekf.start_at(truth_start(sim, sensors.accel_bias, sensors.gyro_bias), sim.foot_measurements(0)),
            EkfStatus::ok);
  int rejected = 0;
  double max_v_err = 0, max_foot_err = 0;
  run(sim, ekf, 2200, [&](double t, const Truth& s, const InertialKinematicEkf& e) {
    if (t >= kSlipStart && t <= kSlipEnd + 0.5) {
      rejected += e.foot_rejected(0) ? 1 : 0;
      max_v_err = std::max(max_v_err, (s.v - e.velocity_w_m_s()).norm());
      max_foot_err = std::max(max_foot_err, (sim.feet(t).point[0] - e.foot_position_w_m(0)).norm());
    }
  });
  std::printf("told anchor motion: LF rejected %d ticks, max |v error| %.4f m/s, max foot error %.4f m\n", rejected,
              max_v_err, max_foot_err);
  EXPECT_EQ(rejected, 0);
  EXPECT_LT(max_v_err, 0.03);
  EXPECT_LT(max_foot_err, 5e-3);
}

// ---- 4. lift-off and touch-down --------------------------------------------------------------

constexpr double kLift = 1.5, kTouch = 1.8;  // LH, s
const Vec3 kStep(0.10, 0.05, 0.0);           // LH's new foothold, relative to the old

Feet stepping_feet(double t) {
  Feet f = standing_feet();
  if (t >= kLift && t < kTouch) {
    const double u = (t - kLift) / (kTouch - kLift);
    f.contact[2] = false;
    f.point[2] += u * kStep + Vec3(0, 0, 0.08 * std::sin(std::numbers::pi * u));  // the swing's kinematics
  } else if (t >= kTouch) {
    f.point[2] += kStep;
  }
  return f;
}

TEST(InertialKinematicEkf, AFootThatLiftsAndTouchesDownElsewhereMovesNothing) {
  const Sensors sensors = noisy_biased();
  Sim sim(Motion{}, sensors, 31, stepping_feet);
  InertialKinematicEkf ekf(sim.mounting());
  ASSERT_EQ(ekf.start_at(truth_start(sim, sensors.accel_bias, sensors.gyro_bias), sim.foot_measurements(0)),
            EkfStatus::ok);
  // The estimate's step each tick less the truth's: its jitter before, at and after the touch-down.
  Vec3 p_prev = ekf.position_w_m(), truth_prev = sim.truth(0).p, v_prev = ekf.velocity_w_m_s();
  double jitter_before = 0, jitter_touch = 0, dv_before = 0, dv_touch = 0, v_err_before = 0, v_err_touch = 0;
  FootMode mode_swing = FootMode::anchored, mode_after = FootMode::free;
  Vec3 foot_after = Vec3::Zero();
  run(sim, ekf, 2300, [&](double t, const Truth& s, const InertialKinematicEkf& e) {
    const double jitter = ((e.position_w_m() - p_prev) - (s.p - truth_prev)).norm();
    const double dv = (e.velocity_w_m_s() - v_prev).norm();
    const double ev = (s.v - e.velocity_w_m_s()).norm();
    if (t > 1.0 && t < kLift) {
      jitter_before = std::max(jitter_before, jitter);
      dv_before = std::max(dv_before, dv);
      v_err_before = std::max(v_err_before, ev);
    }
    if (t >= kTouch && t < kTouch + 0.1) {
      jitter_touch = std::max(jitter_touch, jitter);
      dv_touch = std::max(dv_touch, dv);
      v_err_touch = std::max(v_err_touch, ev);
    }
    if (std::abs(t - 1.65) < 0.5 * kDt) mode_swing = e.foot_mode(2);
    if (std::abs(t - (kTouch + 0.2)) < 0.5 * kDt) {
      mode_after = e.foot_mode(2);
      foot_after = e.foot_position_w_m(2);
    }
    p_prev = e.position_w_m();
    truth_prev = s.p;
    v_prev = e.velocity_w_m_s();
  });
  const Vec3 foothold = standing_feet().point[2] + kStep;
  std::printf("touch-down: max per-tick position step less the truth's %.3g m at the touch-down (%.3g before), "
              "velocity step %.3g m/s (%.3g before), velocity error %.4f m/s (%.4f before); the new foothold's error "
              "0.2 s after %.4f m\n",
              jitter_touch, jitter_before, dv_touch, dv_before, v_err_touch, v_err_before,
              (foot_after - foothold).norm());
  EXPECT_EQ(mode_swing, FootMode::free);
  EXPECT_EQ(mode_after, FootMode::anchored);
  EXPECT_LT(jitter_touch, 2.0 * jitter_before + 1e-5);
  EXPECT_LT(dv_touch, 2.0 * dv_before + 1e-4);
  EXPECT_LT(v_err_touch, 2.0 * v_err_before + 1e-3);
  EXPECT_LT((foot_after - foothold).norm(), 3e-3);
}

// ---- 5. bad input, allocation ------------------------------------------------------------

bool same_state(const InertialKinematicEkf& a, const InertialKinematicEkf& b) {
  bool same = a.position_w_m() == b.position_w_m() && a.velocity_w_m_s() == b.velocity_w_m_s() &&
              a.orientation_wb().coeffs() == b.orientation_wb().coeffs() &&
              a.accel_bias_i_m_s2() == b.accel_bias_i_m_s2() && a.gyro_bias_i_rad_s() == b.gyro_bias_i_rad_s() &&
              a.covariance() == b.covariance() && a.angular_rate_b_rad_s() == b.angular_rate_b_rad_s();
  for (int f = 0; f < kEkfFeet; ++f) {
    same = same && a.foot_position_w_m(f) == b.foot_position_w_m(f) && a.foot_mode(f) == b.foot_mode(f);
  }
  return same;
}

TEST(InertialKinematicEkf, ANonFiniteInputIsRefusedAndTheStateHeld) {
  const Sensors sensors = noisy_biased();
  Sim sim(Motion{}, sensors, 41);
  EkfParams params;
  params.orientation_aid = OrientationAid::yaw;
  InertialKinematicEkf ekf(sim.mounting(), params);
  EXPECT_EQ(ekf.update(sim.input(kDt), kDt), EkfStatus::not_started);
  ASSERT_EQ(ekf.start_at(truth_start(sim), sim.foot_measurements(0)), EkfStatus::ok);
  for (int k = 1; k <= 200; ++k) ASSERT_EQ(ekf.update(sim.input(k * kDt), kDt), EkfStatus::ok);
  const double nan = std::numeric_limits<double>::quiet_NaN(), inf = std::numeric_limits<double>::infinity();
  const EkfInput good = sim.input(201 * kDt);
  std::vector<std::pair<const char*, EkfInput>> bad;
  EkfInput in = good;
  in.imu.rate_i_rad_s.y() = nan;
  bad.emplace_back("gyro", in);
  in = good;
  in.imu.specific_force_i_m_s2.z() = inf;
  bad.emplace_back("accelerometer", in);
  in = good;
  in.feet[1].contact_point_b_m.x() = nan;
  bad.emplace_back("a contact foot's point", in);
  in = good;
  in.feet[3].covariance_b_m2(0, 1) = nan;
  bad.emplace_back("a contact foot's covariance", in);
  in = good;
  in.feet[0].anchor_velocity_w_m_s.z() = nan;
  bad.emplace_back("a contact foot's anchor velocity", in);
  in = good;
  in.orientation_wi.coeffs()[0] = nan;
  bad.emplace_back("the orientation (yaw aid on)", in);
  in = good;
  in.orientation_wi.coeffs().setZero();
  bad.emplace_back("a zero quaternion", in);
  const InertialKinematicEkf before = ekf;
  for (const auto& [what, input] : bad) {
    EXPECT_EQ(ekf.update(input, kDt), EkfStatus::bad_input) << what;
    EXPECT_TRUE(same_state(ekf, before)) << what;
  }
  for (double dt : {0.0, -kDt, nan, inf, 1.0}) {
    EXPECT_EQ(ekf.update(good, dt), EkfStatus::bad_input) << "dt " << dt;
    EXPECT_TRUE(same_state(ekf, before)) << "dt " << dt;
  }
  // What the tick does not use is not checked: a swing foot's point, the orientation when invalid.
  in = good;
  in.feet[2].contact = false;
  in.feet[2].contact_point_b_m.setConstant(nan);
  in.orientation_valid = false;
  in.orientation_wi.coeffs().setConstant(nan);
  EXPECT_EQ(ekf.update(in, kDt), EkfStatus::ok);
  EXPECT_TRUE(ekf.position_w_m().allFinite() && ekf.covariance().allFinite());
  // A finite but absurd contact point, the gate off: the update overflows; the tick is undone.
  {
    EkfParams no_gate = params;
    no_gate.slip_gate_chi2 = 0.0;
    InertialKinematicEkf other(sim.mounting(), no_gate);
    ASSERT_EQ(other.start_at(truth_start(sim), sim.foot_measurements(0)), EkfStatus::ok);
    ASSERT_EQ(other.update(sim.input(kDt), kDt), EkfStatus::ok);
    const InertialKinematicEkf held = other;
    EkfInput huge = sim.input(2 * kDt);
    huge.feet[0].contact_point_b_m = Vec3::Constant(1e300);
    EXPECT_EQ(other.update(huge, kDt), EkfStatus::numerical_fault);
    EXPECT_TRUE(same_state(other, held));
    EXPECT_EQ(other.update(sim.input(3 * kDt), 2 * kDt), EkfStatus::ok);
  }
  // Everything in the air: the IMU alone, said so.
  in = sim.input(202 * kDt);
  for (auto& f : in.feet) f.contact = false;
  EXPECT_EQ(ekf.update(in, kDt), EkfStatus::no_anchor);
}

// 2000 ticks with every path (slip, lift-off, touch-down, a flight phase, the yaw aid, refused
// inputs, a calibration sample) under the allocation trap.
TEST(InertialKinematicEkf, TheTickAllocatesNothing) {
  const Sensors sensors = noisy_biased();
  Sim sim(Motion{}, sensors, 51, [](double t) {
    Feet f = slipping_feet(t);
    if (t >= kLift && t < kTouch) f.contact[2] = false;
    if (t >= 1.9 && t < 1.95) f.contact = {false, false, false, false};
    return f;
  });
  EkfParams params;
  params.orientation_aid = OrientationAid::yaw;
  InertialKinematicEkf ekf(sim.mounting(), params);
  ASSERT_EQ(ekf.start_at(truth_start(sim), sim.foot_measurements(0)), EkfStatus::ok);
  std::vector<EkfInput> inputs;
  for (int k = 1; k <= 2000; ++k) inputs.push_back(sim.input(k * kDt));
  inputs[500].imu.rate_i_rad_s.x() = std::numeric_limits<double>::quiet_NaN();
  const ImuSample sample = sim.imu(0);
  std::array<int, 5> statuses{};
  std::array<int, 3> modes{};
  const std::size_t allocations = springbok::test::count_allocations([&] {
    for (const EkfInput& in : inputs) {
      statuses[static_cast<std::size_t>(ekf.update(in, kDt))]++;
      for (int f = 0; f < kEkfFeet; ++f) modes[static_cast<std::size_t>(ekf.foot_mode(f))]++;
    }
    (void)ekf.calibrate_sample(sample, kDt);
    (void)ekf.evaluate_calibration();
  });
  EXPECT_EQ(allocations, 0u);  // operator new; a dynamic Eigen allocation aborts where the trap is live (Debug)
  EXPECT_GT(statuses[static_cast<std::size_t>(EkfStatus::ok)], 1800);
  EXPECT_GT(statuses[static_cast<std::size_t>(EkfStatus::no_anchor)], 0);
  EXPECT_EQ(statuses[static_cast<std::size_t>(EkfStatus::bad_input)], 1);
  EXPECT_GT(modes[static_cast<std::size_t>(FootMode::rejected)], 0);
  EXPECT_GT(modes[static_cast<std::size_t>(FootMode::free)], 0);
}

// ---- 6. consistency ------------------------------------------------------------------------

// The normalised estimation error squared e^T P^-1 e of the whole 27-state error, averaged
// over 3 s of swaying after a calibrated start (1 s at rest, the biases of BiasesConverge...; x,
// y and yaw given with errors drawn from their prior) and over 6 seeds: a consistent filter's
// mean is 27. The filter is told the truth where the truth has noise (IMU densities,
// kinematics) and small values where it has none (bias walks, the anchored feet's drift, the
// ground's flatness): those make it a little cautious. Band: [0.5, 1.5] x 27; each block's
// mean (3 dof) and the trunk origin's velocity and position (the outputs, their covariances
// mapped) within [0.3, 2] x 3.
TEST(InertialKinematicEkf, TheNormalisedEstimationErrorSquaredMatchesItsDimension) {
  const Sensors sensors = noisy_biased();
  EkfParams params;
  params.foot_anchored_walk_m_s_per_sqrt_hz = 1e-4;
  params.gyro_bias_walk_rad_s2_per_sqrt_hz = 1e-6;
  params.accel_bias_walk_m_s3_per_sqrt_hz = 1e-5;
  params.ground_std_m = 1e-3;
  double sum = 0, trunk_v = 0, trunk_p = 0;
  std::array<double, 9> block{};
  int n = 0;
  std::mt19937_64 rng(99);
  std::normal_distribution<double> normal(0.0, 1.0);
  for (std::uint64_t seed = 60; seed < 66; ++seed) {
    Sim still(still_motion(), sensors, seed + 1000);
    Sim sim(Motion{}, sensors, seed);
    InertialKinematicEkf ekf(sim.mounting(), params);
    record(ekf, still, 1000);
    const Truth s0 = sim.truth(0);
    const Eigen::Vector2d xy = s0.p.head<2>() + params.initial_position_std_m * Eigen::Vector2d(normal(rng), normal(rng));
    const double yaw = 0.3 + params.initial_yaw_std_rad * normal(rng);
    ASSERT_EQ(ekf.start_from_calibration(sim.foot_measurements(0), xy, yaw), EkfStatus::ok);
    run(sim, ekf, 3000, [&](double t, const Truth& s, const InertialKinematicEkf& e) {
      const EkfVector err = error_state(s, sim.feet(t), sensors, e);
      const EkfCovariance& P = e.covariance();
      sum += err.dot(P.ldlt().solve(err));
      for (int b = 0; b < 9; ++b) {
        const Vec3 eb = err.segment<3>(3 * b);
        block[static_cast<std::size_t>(b)] += eb.dot(P.block<3, 3>(3 * b, 3 * b).ldlt().solve(eb));
      }
      const Vec3 ev = s.v - e.velocity_w_m_s(), ep = s.p - e.position_w_m();
      trunk_v += ev.dot(e.trunk_velocity_covariance_w().ldlt().solve(ev));
      trunk_p += ep.dot(e.trunk_position_covariance_w().ldlt().solve(ep));
      ++n;
    });
  }
  const double nees = sum / n;
  const char* names[] = {"p", "v", "th", "d_LF", "d_RF", "d_LH", "d_RH", "b_a", "b_g"};
  std::printf("NEES: mean %.2f (dimension 27) over %d ticks; per block (dimension 3):", nees, n);
  for (int b = 0; b < 9; ++b) std::printf(" %s %.2f", names[b], block[static_cast<std::size_t>(b)] / n);
  std::printf("; the trunk origin's v %.2f, p %.2f\n", trunk_v / n, trunk_p / n);
  EXPECT_GT(nees, 0.5 * 27);
  EXPECT_LT(nees, 1.5 * 27);
  for (int b = 0; b < 9; ++b) {
    EXPECT_GT(block[static_cast<std::size_t>(b)] / n, 0.3 * 3) << names[b];
    EXPECT_LT(block[static_cast<std::size_t>(b)] / n, 2.0 * 3) << names[b];
  }
  EXPECT_GT(trunk_v / n, 0.3 * 3);
  EXPECT_LT(trunk_v / n, 2.0 * 3);
  EXPECT_GT(trunk_p / n, 0.3 * 3);
  EXPECT_LT(trunk_p / n, 2.0 * 3);
}

}  // namespace
