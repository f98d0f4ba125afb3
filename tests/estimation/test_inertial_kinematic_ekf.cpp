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
      for (int k = 0; k < 3; ++k) m.contact_point_b_m[k] += sensors_.kin_std_m * n_(rng_);
      m.covariance_b_m2 = Mat3::Identity() * sd * sd;
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
[[maybe_unused]] EkfVector error_state(const Truth& s, const Feet& feet, const Sensors& sensors, const InertialKinematicEkf& ekf) {
  EkfVector e;
  e.segment<3>(kEkfP) = s.p - ekf.position_w_m();
  e.segment<3>(kEkfV) = s.v - ekf.velocity_w_m_s();
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
  // At 1 kHz: far below the noise's effect (BiasesConverge...: mm/s, tenths of mrad).
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

ConvergenceRun converge(const EkfParams& params, int ticks, std::uint64_t seed) {
  const Sensors sensors = noisy_biased();
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
// Observable without the yaw aid: the whole accelerometer bias, and the gyro bias's part
// perpendicular to gravity, here IMU x and y (its z axis is the trunk's -z, near vertical): the
// vertical part only turns the unobservable yaw, and is seen only through the trunk's tilting.
TEST(InertialKinematicEkf, BiasesConvergeAndTheTiltAndVelocityFollow) {
  const double t_conv = 2.0;  // s
  const ConvergenceRun r = converge(EkfParams{}, 4000, 2);
  const double bg_bound = 1.5e-3, ba_bound = 0.015;
  for (int k = 0; k < 3; ++k) {
    const auto& bg = r.bg_err[static_cast<std::size_t>(k)];
    const auto& ba = r.ba_err[static_cast<std::size_t>(k)];
    std::printf("axis %d: b_g error at start %.4f, end %.5f rad/s, within %.1e from %.3f s; b_a error end %.5f m/s^2, "
                "within %.3f from %.3f s\n",
                k, bg.front(), bg.back(), bg_bound, settle_time(r.t, bg, bg_bound), ba.back(), ba_bound,
                settle_time(r.t, ba, ba_bound));
    if (k < 2) {
      EXPECT_LE(settle_time(r.t, bg, bg_bound), t_conv) << "gyro axis " << k;
    }
    EXPECT_LE(settle_time(r.t, ba, ba_bound), t_conv) << "accel axis " << k;
  }
  const double tilt_rms = rms(after(r.t, r.tilt, t_conv)), v_rms = rms(after(r.t, r.v_err, t_conv));
  const double v_rms_all = rms(r.v_err);
  std::printf("after %.1f s: tilt rms %.3g mrad, velocity rms %.3g m/s (whole run %.3g m/s)\n", t_conv, 1e3 * tilt_rms,
              v_rms, v_rms_all);
  EXPECT_LT(tilt_rms, 2e-3);
  EXPECT_LT(v_rms, 0.03);
  EXPECT_LT(v_rms_all, 0.03);
}

// With the IMU's yaw the gyro bias's vertical part is observable too.
TEST(InertialKinematicEkf, TheYawAidMakesTheVerticalGyroBiasObservable) {
  EkfParams params;
  params.orientation_aid = OrientationAid::yaw;
  params.yaw_std_rad = 0.01;
  const ConvergenceRun r = converge(params, 4000, 3);
  const double bg_bound = 1.5e-3;
  for (int k = 0; k < 3; ++k) {
    const auto& bg = r.bg_err[static_cast<std::size_t>(k)];
    std::printf("yaw aid, axis %d: b_g error end %.5f rad/s, within %.1e from %.3f s\n", k, bg.back(), bg_bound,
                settle_time(r.t, bg, bg_bound));
    EXPECT_LE(settle_time(r.t, bg, bg_bound), 3.0) << "gyro axis " << k;
  }
  const double yaw_rms = rms(after(r.t, r.yaw, 2.0));
  std::printf("yaw aid: yaw error rms after 2 s %.3g mrad\n", 1e3 * yaw_rms);
  EXPECT_LT(yaw_rms, 0.01);
}

}  // namespace
