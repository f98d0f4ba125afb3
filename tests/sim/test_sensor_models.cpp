// sim::SensorModel against statistics and exact expectations: the white noise's per-sample std,
// the bias random walk's variance growth, the per-run draws over seeds, quantisation, hold,
// delay, saturation, the encoders, the joint torque, the F/T's drifting offset; the ideal model
// is the identity, the legacy ImuNoise maps onto it, the same seed repeats, no tick allocates.
// Statistical tolerances are stated per case: about 5 standard errors of the estimate.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <random>
#include <vector>

#include "alloc_trap.hpp"
#include "springbok/sim_hal/sensor_models.hpp"

namespace springbok::sim {
namespace {

constexpr double kDt = 0.001;

struct Moments {
  double mean = 0.0, std = 0.0;
};
Moments moments(const std::vector<double>& x) {
  Moments m;
  for (double v : x) m.mean += v / static_cast<double>(x.size());
  double var = 0.0;
  for (double v : x) var += (v - m.mean) * (v - m.mean) / static_cast<double>(x.size() - 1);
  m.std = std::sqrt(var);
  return m;
}

SensorModel configured(const SensorModelConfig& c, double dt = kDt) {
  SensorModel m;
  const std::string why = m.configure(c, dt);
  EXPECT_TRUE(why.empty()) << why;
  return m;
}

ImuTruth truth_at(int k) {
  ImuTruth t;
  t.angular_rate_rad_s = Vec3(0.1 * std::sin(0.01 * k), -0.2, 0.3 * std::cos(0.003 * k));
  t.specific_force_m_s2 = Vec3(0.5 * std::cos(0.02 * k), 0.1, 9.81);
  t.orientation = Quat(Eigen::AngleAxisd(0.001 * k, Vec3(1, 2, 3).normalized()));
  return t;
}

TEST(SensorModels, IdealReproducesTheInputExactly) {
  SensorModel m = configured(SensorModelConfig{});
  std::mt19937_64 rng(3);
  std::normal_distribution<double> n;
  for (int k = 0; k < 200; ++k) {
    const ImuTruth t = truth_at(k);
    hal::Imu out;
    m.imu(t, k == 0, out);
    EXPECT_EQ(out.angular_rate_rad_s, t.angular_rate_rad_s) << k;
    EXPECT_EQ(out.linear_accel_m_s2, t.specific_force_m_s2) << k;
    EXPECT_EQ(out.orientation.coeffs(), t.orientation.coeffs()) << k;
    EXPECT_FALSE(out.clipping);
    EXPECT_EQ(out.age_ticks, 0u);
    VecNj q, qd, tau, q_out, qd_out, tau_out;
    for (int j = 0; j < kNj; ++j) {
      q[j] = n(rng);
      qd[j] = n(rng);
      tau[j] = 10.0 * n(rng);
    }
    m.joints(q, qd, tau, k == 0, q_out, qd_out, tau_out);
    EXPECT_EQ(q_out, q);
    EXPECT_EQ(qd_out, qd);
    EXPECT_EQ(tau_out, tau);
    const Vec3 f(n(rng), n(rng), -0.0), tq(n(rng), 0.0, n(rng));
    hal::Wrench w;
    m.wrist(f, tq, w);
    EXPECT_EQ(w.force_n, f);
    EXPECT_TRUE(std::signbit(w.force_n.z())) << "a -0 stays -0: nothing is added";
    EXPECT_EQ(w.torque_nm, tq);
    EXPECT_FALSE(w.clipping);
  }
}

// Per-sample std = density * sqrt(rate): at the tick rate (20000 samples: std's standard
// error 0.5 %, tolerance 3 %) and at a 250 Hz output data rate (its 5000 distinct samples:
// 1 %, tolerance 5 %).
TEST(SensorModels, WhiteNoisePerSampleStdIsDensityTimesRootRate) {
  for (const double rate_hz : {0.0, 250.0}) {
    SensorModelConfig c;
    c.imu.gyro.noise_per_sqrt_hz = 1e-3;
    c.imu.accel.noise_per_sqrt_hz = 2e-3;
    c.imu.gyro.sample_rate_hz = c.imu.accel.sample_rate_hz = rate_hz;
    SensorModel m = configured(c);
    std::vector<double> g, a;
    Vec3 last = Vec3::Constant(1e9);
    ImuTruth t;
    t.angular_rate_rad_s = Vec3(1.0, 2.0, 3.0);
    for (int k = 0; k < 20000; ++k) {
      hal::Imu out;
      m.imu(t, k == 0, out);
      if (out.angular_rate_rad_s == last) continue;  // a held sample: not a new draw
      last = out.angular_rate_rad_s;
      g.push_back(out.angular_rate_rad_s.y() - 2.0);
      a.push_back(out.linear_accel_m_s2.x());
    }
    const double rate = rate_hz > 0.0 ? rate_hz : 1.0 / kDt;
    const double tol = rate_hz > 0.0 ? 0.05 : 0.03;
    EXPECT_EQ(static_cast<double>(g.size()), 20000.0 * kDt * rate);
    EXPECT_NEAR(moments(g).std, 1e-3 * std::sqrt(rate), tol * 1e-3 * std::sqrt(rate)) << rate_hz;
    EXPECT_NEAR(moments(a).std, 2e-3 * std::sqrt(rate), tol * 2e-3 * std::sqrt(rate)) << rate_hz;
    EXPECT_LT(std::abs(moments(g).mean), 5.0 * 1e-3 * std::sqrt(rate) / std::sqrt(g.size())) << "no bias configured";
  }
}

// The bias random walk: over 400 seeds x 3 axes, Var(b(t)) = K^2 t at t = 0.5, 1 and 2 s
// (1200 samples: the variance's standard error is 4 %; tolerance 20 %), so linear in time.
TEST(SensorModels, BiasRandomWalkVarianceGrowsLinearlyAtItsDensity) {
  constexpr double kWalkGyro = 0.01, kWalkAccel = 0.05;
  const int checkpoints[] = {500, 1000, 2000};
  std::vector<double> g[3], a[3];
  for (std::uint64_t seed = 1; seed <= 400; ++seed) {
    SensorModelConfig c;
    c.seed = seed;
    c.imu.gyro.bias_walk_per_sqrt_hz = kWalkGyro;
    c.imu.accel.bias_walk_per_sqrt_hz = kWalkAccel;
    SensorModel m = configured(c);
    const ImuTruth t;  // at rest, no noise: the output is the bias
    hal::Imu out;
    for (int k = 0, next = 0; k <= 2000; ++k) {
      m.imu(t, k == 0, out);
      if (k == checkpoints[next]) {
        for (int i = 0; i < 3; ++i) {
          g[next].push_back(out.angular_rate_rad_s[i]);
          a[next].push_back(out.linear_accel_m_s2[i]);
        }
        EXPECT_EQ(out.angular_rate_rad_s, m.imu_errors().gyro_bias_rad_s);
        ++next;
        if (next == 3) break;
      }
    }
  }
  for (int n = 0; n < 3; ++n) {
    const double t_s = checkpoints[n] * kDt;
    const double sg = moments(g[n]).std, sa = moments(a[n]).std;
    EXPECT_NEAR(sg * sg / (kWalkGyro * kWalkGyro * t_s), 1.0, 0.2) << t_s;
    EXPECT_NEAR(sa * sa / (kWalkAccel * kWalkAccel * t_s), 1.0, 0.2) << t_s;
  }
}

// The per-run constants over 2000 seeds x 3 axes (6000 samples: std's standard error 0.9 %;
// tolerance 5 %), and what they do to the output: y = (1 + s) x + b.
TEST(SensorModels, TurnOnBiasAndScaleFactorDrawTheirStdsOverSeeds) {
  std::vector<double> bg, ba, sg, sa, tau, ff, ft;
  for (std::uint64_t seed = 1; seed <= 2000; ++seed) {
    SensorModelConfig c;
    c.seed = seed;
    c.imu.gyro.turn_on_bias = 0.01;
    c.imu.accel.turn_on_bias = 0.2;
    c.imu.gyro.scale_factor_std = 0.003;
    c.imu.accel.scale_factor_std = 0.005;
    c.joint_torque.offset_std_nm.setConstant(1.5);
    c.wrist_ft.force_offset_std_n = 2.0;
    c.wrist_ft.torque_offset_std_nm = 0.05;
    SensorModel m = configured(c);
    const ImuErrorState e = m.imu_errors();
    ImuTruth t;
    t.angular_rate_rad_s = Vec3(2.0, -1.0, 0.5);
    t.specific_force_m_s2 = Vec3(1.0, 3.0, -9.0);
    hal::Imu out;
    m.imu(t, true, out);
    const Vec3 expected_g = t.angular_rate_rad_s + e.gyro_scale_factor.cwiseProduct(t.angular_rate_rad_s) + e.gyro_bias_rad_s;
    const Vec3 expected_a = t.specific_force_m_s2 + e.accel_scale_factor.cwiseProduct(t.specific_force_m_s2) + e.accel_bias_m_s2;
    EXPECT_LT((out.angular_rate_rad_s - expected_g).norm(), 1e-15);
    EXPECT_LT((out.linear_accel_m_s2 - expected_a).norm(), 1e-14);
    for (int i = 0; i < 3; ++i) {
      bg.push_back(e.gyro_bias_rad_s[i]);
      ba.push_back(e.accel_bias_m_s2[i]);
      sg.push_back(e.gyro_scale_factor[i]);
      sa.push_back(e.accel_scale_factor[i]);
      ff.push_back(m.wrist_errors().force_offset_n[i]);
      ft.push_back(m.wrist_errors().torque_offset_nm[i]);
    }
    tau.push_back(m.joint_torque_offsets_nm()[seed % kNj]);
  }
  EXPECT_NEAR(moments(bg).std, 0.01, 0.05 * 0.01);
  EXPECT_NEAR(moments(ba).std, 0.2, 0.05 * 0.2);
  EXPECT_NEAR(moments(sg).std, 0.003, 0.05 * 0.003);
  EXPECT_NEAR(moments(sa).std, 0.005, 0.05 * 0.005);
  EXPECT_NEAR(moments(ff).std, 2.0, 0.05 * 2.0);
  EXPECT_NEAR(moments(ft).std, 0.05, 0.05 * 0.05);
  EXPECT_NEAR(moments(tau).std, 1.5, 0.08 * 1.5);  // 2000 samples: 1.6 %
  EXPECT_LT(std::abs(moments(bg).mean), 5.0 * 0.01 / std::sqrt(6000.0));
}

// A known part of the turn-on bias: the same seed's draw plus the offset, exactly; a
// non-finite offset refused naming the field.
TEST(SensorModels, ABiasOffsetAddsToTheSameDraw) {
  SensorModelConfig c;
  c.seed = 9;
  c.imu.gyro.turn_on_bias = 0.01;
  c.imu.accel.turn_on_bias = 0.2;
  const ImuErrorState drawn = configured(c).imu_errors();
  c.imu.gyro.bias_offset = Vec3(0.02, -0.02, 0.02);
  c.imu.accel.bias_offset = Vec3(0.0, 0.5, 0.0);
  const ImuErrorState offset = configured(c).imu_errors();
  EXPECT_LT((offset.gyro_bias_rad_s - drawn.gyro_bias_rad_s - c.imu.gyro.bias_offset).norm(), 1e-15);
  EXPECT_LT((offset.accel_bias_m_s2 - drawn.accel_bias_m_s2 - c.imu.accel.bias_offset).norm(), 1e-15);
  c = SensorModelConfig{};
  c.imu.gyro.bias_offset = Vec3(0.0, 0.0, 1e-3);
  EXPECT_FALSE(is_ideal(c.imu)) << "an offset alone is not the exact IMU";
  c.imu.gyro.bias_offset.x() = std::nan("");
  SensorModel m;
  EXPECT_EQ(m.configure(c, 1e-3), "imu.gyro.bias_offset must be finite");
}

TEST(SensorModels, QuantisationStepsAreOneLsb) {
  SensorModelConfig c;
  c.imu.gyro.lsb = 0.01;
  c.imu.accel.lsb = 0.02;
  SensorModel m = configured(c);
  double previous = 0.0;
  int steps = 0;
  for (int k = 0; k < 3000; ++k) {
    ImuTruth t;
    t.angular_rate_rad_s = Vec3::Constant(-1.0 + 1e-3 * k);  // a slow ramp: 0.1 LSB per tick
    t.specific_force_m_s2 = Vec3::Constant(3.0 - 1.7e-3 * k);
    hal::Imu out;
    m.imu(t, k == 0, out);
    for (int i = 0; i < 3; ++i) {
      const double y = out.angular_rate_rad_s[i];
      EXPECT_NEAR(y / 0.01, std::round(y / 0.01), 1e-9) << k;
      EXPECT_LE(std::abs(y - t.angular_rate_rad_s[i]), 0.005 + 1e-12) << k;
      EXPECT_LE(std::abs(out.linear_accel_m_s2[i] - t.specific_force_m_s2[i]), 0.01 + 1e-12) << k;
    }
    const double y = out.angular_rate_rad_s.x();
    if (k > 0 && y != previous) {
      EXPECT_NEAR(y - previous, 0.01, 1e-12) << "one LSB at a time, tick " << k;
      ++steps;
    }
    previous = y;
  }
  EXPECT_EQ(steps, 300);  // 3 rad/s of ramp in 0.01 steps
}

// Below the tick rate a sample is held: at 250 Hz the output changes on every 4th tick
// exactly; at 400 Hz on 400 ticks of 1000 (2.5 ticks apart: 3, 2, 3, 2, ...). age_ticks
// counts the hold.
TEST(SensorModels, ASampleRateBelowTheTickRateHoldsSamples) {
  for (const double rate_hz : {250.0, 400.0}) {
    SensorModelConfig c;
    c.imu.gyro.sample_rate_hz = rate_hz;
    c.imu.accel.sample_rate_hz = 2.0 * rate_hz;
    SensorModel m = configured(c);
    int changes = 0;
    std::vector<int> at;
    double previous = -1.0;
    for (int k = 0; k < 1000; ++k) {
      ImuTruth t;
      t.angular_rate_rad_s = Vec3::Constant(static_cast<double>(k));
      t.specific_force_m_s2 = Vec3::Constant(static_cast<double>(k));
      hal::Imu out;
      m.imu(t, k == 0, out);
      const double y = out.angular_rate_rad_s.x();
      EXPECT_LE(y, k);
      if (y != previous) {
        EXPECT_EQ(y, k) << "a new sample is this tick's value";
        at.push_back(k);
        ++changes;
      }
      previous = y;
      EXPECT_LE(out.age_ticks, 3u);
    }
    EXPECT_EQ(changes, static_cast<int>(rate_hz));
    if (rate_hz == 250.0) {
      for (std::size_t i = 1; i < at.size(); ++i) EXPECT_EQ(at[i] - at[i - 1], 4) << i;
    } else {
      for (std::size_t i = 1; i < at.size(); ++i) EXPECT_TRUE(at[i] - at[i - 1] == 2 || at[i] - at[i - 1] == 3) << i;
    }
  }
}

// The delay: the output at tick k is the sample of tick k - d (before the first tick: the
// first sample, the line filled with it); the orientation follows the gyro's delay.
TEST(SensorModels, TheDelayShiftsByExactlyItsTicks) {
  SensorModelConfig c;
  c.imu.gyro.delay_ticks = 3;
  c.imu.accel.delay_ticks = 5;
  SensorModel m = configured(c);
  for (int k = 0; k < 100; ++k) {
    hal::Imu out;
    m.imu(truth_at(k), k == 0, out);
    const ImuTruth g = truth_at(std::max(0, k - 3)), a = truth_at(std::max(0, k - 5));
    EXPECT_EQ(out.angular_rate_rad_s, g.angular_rate_rad_s) << k;
    EXPECT_EQ(out.orientation.coeffs(), g.orientation.coeffs()) << k;
    EXPECT_EQ(out.linear_accel_m_s2, a.specific_force_m_s2) << k;
  }
  // A restart (a teleport) refills the line: the delay counts from there.
  hal::Imu out;
  m.imu(truth_at(500), true, out);
  EXPECT_EQ(out.angular_rate_rad_s, truth_at(500).angular_rate_rad_s);
}

TEST(SensorModels, SaturationClipsAndSetsTheFlag) {
  SensorModelConfig c;
  c.imu.gyro.range = 1.0;
  c.imu.accel.range = 20.0;
  c.wrist_ft.force_range_n = Vec3(10.0, 10.0, 20.0);
  c.wrist_ft.torque_range_nm = Vec3::Constant(1.0);
  SensorModel m = configured(c);
  hal::Imu out;
  ImuTruth t;
  t.angular_rate_rad_s = Vec3(0.5, -0.9, 0.0);
  t.specific_force_m_s2 = Vec3(0.0, 0.0, 9.81);
  m.imu(t, true, out);
  EXPECT_FALSE(out.clipping);
  EXPECT_EQ(out.angular_rate_rad_s, t.angular_rate_rad_s);
  t.angular_rate_rad_s = Vec3(1.5, -2.0, 0.2);
  m.imu(t, false, out);
  EXPECT_TRUE(out.clipping);
  EXPECT_EQ(out.angular_rate_rad_s, Vec3(1.0, -1.0, 0.2));
  t.angular_rate_rad_s.setZero();
  t.specific_force_m_s2 = Vec3(0.0, -25.0, 9.81);
  m.imu(t, false, out);
  EXPECT_TRUE(out.clipping) << "the accelerometer's own range";
  EXPECT_EQ(out.linear_accel_m_s2, Vec3(0.0, -20.0, 9.81));
  hal::Wrench w;
  m.wrist(Vec3(5.0, -9.0, 15.0), Vec3(0.5, 0.0, -0.9), w);
  EXPECT_FALSE(w.clipping);
  m.wrist(Vec3(5.0, -9.0, 25.0), Vec3(0.5, 0.0, -0.9), w);
  EXPECT_TRUE(w.clipping);
  EXPECT_EQ(w.force_n, Vec3(5.0, -9.0, 20.0));
  m.wrist(Vec3::Zero(), Vec3(0.0, 3.0, 0.0), w);
  EXPECT_TRUE(w.clipping);
  EXPECT_EQ(w.torque_nm, Vec3(0.0, 1.0, 0.0));
}

// Encoders: positions quantised to one count at the joint, D = 2 pi / (counts gear); the
// velocity the difference of the quantised positions over the tick (averaging to the true
// speed), or that through the drive's first-order low-pass.
TEST(SensorModels, EncodersQuantiseAndDifference) {
  SensorModelConfig c;
  c.encoders.counts_per_rev = 1000.0;
  c.encoders.gear_ratio.setConstant(2.0);
  c.encoders.gear_ratio[3] = 5.0;
  c.encoders.velocity = EncoderVelocity::difference;
  SensorModel m = configured(c);
  const double d0 = 2.0 * std::numbers::pi / 2000.0, d3 = 2.0 * std::numbers::pi / 5000.0;
  VecNj q = VecNj::Zero(), qd = VecNj::Constant(0.7), tau = VecNj::Zero(), q_out, qd_out, tau_out, previous;
  double sum_qd = 0.0;
  constexpr int kTicks = 2000;
  for (int k = 0; k < kTicks; ++k) {
    q = VecNj::Constant(0.3) + qd * (k * kDt);
    m.joints(q, qd, tau, k == 0, q_out, qd_out, tau_out);
    EXPECT_NEAR(q_out[0] / d0, std::round(q_out[0] / d0), 1e-9);
    EXPECT_NEAR(q_out[3] / d3, std::round(q_out[3] / d3), 1e-9);
    EXPECT_LE(std::abs(q_out[0] - q[0]), 0.5 * d0 + 1e-12);
    EXPECT_LE(std::abs(q_out[3] - q[3]), 0.5 * d3 + 1e-12);
    if (k > 0) {
      EXPECT_DOUBLE_EQ(qd_out[0], (q_out[0] - previous[0]) / kDt) << k;
      sum_qd += qd_out[0];
    }
    previous = q_out;
  }
  EXPECT_NEAR(sum_qd / (kTicks - 1), 0.7, d0 / ((kTicks - 1) * kDt));  // telescopes: within one count over the span

  c.encoders.velocity = EncoderVelocity::lowpass;
  c.encoders.velocity_cutoff_hz = 50.0;
  SensorModel f = configured(c);
  const double a = 1.0 - std::exp(-2.0 * std::numbers::pi * 50.0 * kDt);
  q.setZero();
  qd.setZero();
  f.joints(q, qd, tau, true, q_out, qd_out, tau_out);
  EXPECT_EQ(qd_out[0], 0.0);
  q[0] = 100.0 * d0;  // a 100-count jump: the difference is 100 d0 / dt, filtered by a
  f.joints(q, qd, tau, false, q_out, qd_out, tau_out);
  EXPECT_NEAR(qd_out[0], a * 100.0 * d0 / kDt, 1e-9);
  f.joints(q, qd, tau, false, q_out, qd_out, tau_out);
  EXPECT_NEAR(qd_out[0], (1.0 - a) * a * 100.0 * d0 / kDt, 1e-9);
}

// Joint torque: the offset drawn once per joint, the white noise's std per tick (20000
// ticks x 1 joint: 0.5 %, tolerance 3 %).
TEST(SensorModels, JointTorqueOffsetAndNoise) {
  SensorModelConfig c;
  c.joint_torque.noise_std_nm.setConstant(0.4);
  c.joint_torque.offset_std_nm.setConstant(2.0);
  SensorModel m = configured(c);
  const VecNj q = VecNj::Zero(), tau = VecNj::LinSpaced(-10.0, 10.0);
  VecNj q_out, qd_out, tau_out;
  std::vector<double> e;
  for (int k = 0; k < 20000; ++k) {
    m.joints(q, q, tau, k == 0, q_out, qd_out, tau_out);
    e.push_back(tau_out[5] - tau[5]);
  }
  EXPECT_NEAR(moments(e).std, 0.4, 0.03 * 0.4);
  EXPECT_NEAR(moments(e).mean, m.joint_torque_offsets_nm()[5], 5.0 * 0.4 / std::sqrt(20000.0));
  EXPECT_NE(m.joint_torque_offsets_nm()[5], 0.0);
}

// The F/T's offset: a turn-on draw that then drifts as a random walk, Var(o(t) - o(0)) =
// K^2 t over 400 seeds x 3 axes (tolerance 20 %); the white noise adds per tick.
TEST(SensorModels, WristFtOffsetDriftsFromItsTurnOnValue) {
  constexpr double kWalk = 0.2;
  std::vector<double> drift_1s, drift_2s;
  for (std::uint64_t seed = 1; seed <= 400; ++seed) {
    SensorModelConfig c;
    c.seed = seed;
    c.wrist_ft.force_offset_std_n = 1.0;
    c.wrist_ft.force_offset_walk_n_per_sqrt_s = kWalk;
    SensorModel m = configured(c);
    const Vec3 o0 = m.wrist_errors().force_offset_n;
    hal::Wrench w;
    for (int k = 1; k <= 2000; ++k) {
      m.wrist(Vec3(1.0, 2.0, 3.0), Vec3::Zero(), w);
      if (k == 1000 || k == 2000) {
        const Vec3 d = w.force_n - Vec3(1.0, 2.0, 3.0) - o0;
        EXPECT_LT((w.force_n - Vec3(1.0, 2.0, 3.0) - m.wrist_errors().force_offset_n).norm(), 1e-12);
        for (int i = 0; i < 3; ++i) (k == 1000 ? drift_1s : drift_2s).push_back(d[i]);
      }
    }
  }
  const double s1 = moments(drift_1s).std, s2 = moments(drift_2s).std;
  EXPECT_NEAR(s1 * s1 / (kWalk * kWalk * 1.0), 1.0, 0.2);
  EXPECT_NEAR(s2 * s2 / (kWalk * kWalk * 2.0), 1.0, 0.2);

  SensorModelConfig c;
  c.wrist_ft.force_noise_std_n = 0.3;
  c.wrist_ft.torque_noise_std_nm = 0.01;
  SensorModel m = configured(c);
  std::vector<double> fx, tz;
  hal::Wrench w;
  for (int k = 0; k < 20000; ++k) {
    m.wrist(Vec3::Zero(), Vec3::Zero(), w);
    fx.push_back(w.force_n.x());
    tz.push_back(w.torque_nm.z());
  }
  EXPECT_NEAR(moments(fx).std, 0.3, 0.03 * 0.3);
  EXPECT_NEAR(moments(tz).std, 0.01, 0.03 * 0.01);
}

// The orientation's error: a random walk (Var = K^2 t per axis, over seeds) plus white noise.
TEST(SensorModels, OrientationErrorDriftsAsARandomWalk) {
  constexpr double kDrift = 0.01;
  std::vector<double> e;
  for (std::uint64_t seed = 1; seed <= 300; ++seed) {
    SensorModelConfig c;
    c.seed = seed;
    c.imu.orientation.drift_rad_per_sqrt_s = kDrift;
    SensorModel m = configured(c);
    hal::Imu out;
    const Quat truth(Eigen::AngleAxisd(0.7, Vec3::UnitZ()));
    ImuTruth t;
    t.orientation = truth;
    for (int k = 0; k <= 1000; ++k) m.imu(t, k == 0, out);
    const Eigen::AngleAxisd err(out.orientation * truth.inverse());
    const Vec3 v = err.angle() * err.axis();
    EXPECT_LT((v - m.imu_errors().orientation_drift_rad).norm(), 1e-9);
    for (int i = 0; i < 3; ++i) e.push_back(v[i]);
  }
  const double s = moments(e).std;
  EXPECT_NEAR(s * s / (kDrift * kDrift * 1.0), 1.0, 0.2);  // 900 samples: 4.7 %
}

TEST(SensorModels, TheSameSeedGivesTheSameStream) {
  const auto stream = [](std::uint64_t seed) {
    SensorModelConfig c = sensor_preset(ImuPreset::mems);
    c.seed = seed;
    SensorModel m = configured(c);
    std::vector<double> x;
    for (int k = 0; k < 300; ++k) {
      hal::Imu out;
      m.imu(truth_at(k), k == 0, out);
      VecNj q = VecNj::Constant(0.01 * k), q_out, qd_out, tau_out;
      m.joints(q, q, q, k == 0, q_out, qd_out, tau_out);
      hal::Wrench w;
      m.wrist(Vec3(1, 2, 3), Vec3(0.1, 0.2, 0.3), w);
      x.insert(x.end(), {out.angular_rate_rad_s.x(), out.linear_accel_m_s2.z(), tau_out[4], w.force_n.y()});
    }
    return x;
  };
  EXPECT_EQ(stream(7), stream(7));
  EXPECT_NE(stream(7), stream(8));
}

// The legacy ImuNoise (a per-sample std and a turn-on std at the tick rate) through
// apply_legacy_imu gives the legacy formula's samples: the same engine, seed and draws.
TEST(SensorModels, TheLegacyImuNoiseMapsOntoTheModel) {
  constexpr double kGyroStd = 0.01, kAccelStd = 0.05, kGyroBias = 0.1, kAccelBias = 0.2;
  SensorModelConfig c;
  apply_legacy_imu(kGyroStd, kAccelStd, kGyroBias, kAccelBias, kDt, c.imu);
  SensorModel m;
  ASSERT_TRUE(m.configure(c, kDt, /*imu_seed=*/5).empty());
  // The legacy code (sim_hal before the sensor model), verbatim in its draws.
  std::mt19937_64 rng(5);
  std::normal_distribution<double> unit_normal{0.0, 1.0};
  const auto gaussian3 = [&](double std_dev) -> Vec3 {
    return Vec3(unit_normal(rng), unit_normal(rng), unit_normal(rng)) * std_dev;
  };
  const Vec3 gyro_bias = gaussian3(kGyroBias);
  const Vec3 accel_bias = gaussian3(kAccelBias);
  for (int k = 0; k < 500; ++k) {
    const ImuTruth t = truth_at(k);
    hal::Imu out;
    m.imu(t, k == 0, out);
    const Vec3 g = t.angular_rate_rad_s + gyro_bias + gaussian3(kGyroStd);
    const Vec3 a = t.specific_force_m_s2 + accel_bias + gaussian3(kAccelStd);
    EXPECT_LT((out.angular_rate_rad_s - g).cwiseAbs().maxCoeff(), 1e-15) << k;
    EXPECT_LT((out.linear_accel_m_s2 - a).cwiseAbs().maxCoeff(), 1e-14) << k;
  }
}

TEST(SensorModels, PresetsHoldTheirStatedNumbers) {
  constexpr double kDeg = std::numbers::pi / 180.0;
  EXPECT_TRUE(is_ideal(sensor_preset(ImuPreset::ideal)));
  const SensorModelConfig mems = sensor_preset(ImuPreset::mems), tactical = sensor_preset(ImuPreset::tactical);
  EXPECT_TRUE(check_sensor_model(mems, kDt).empty());
  EXPECT_TRUE(check_sensor_model(tactical, kDt).empty());
  EXPECT_NEAR(mems.imu.gyro.noise_per_sqrt_hz, 0.014 * kDeg, 1e-12);
  EXPECT_NEAR(mems.imu.accel.noise_per_sqrt_hz, 175e-6 * 9.80665, 1e-12);
  EXPECT_NEAR(mems.imu.gyro.range / mems.imu.gyro.lsb, 32768.0, 1e-6);  // 16 bits on +-2000 deg/s
  EXPECT_NEAR(mems.imu.accel.range / mems.imu.accel.lsb, 32768.0, 1e-6);
  EXPECT_NEAR(tactical.imu.gyro.noise_per_sqrt_hz, 0.012 * kDeg / 60.0, 1e-15);  // deg/sqrt(h)
  EXPECT_FALSE(is_ideal(mems.encoders));
  EXPECT_FALSE(is_ideal(mems.wrist_ft));
  EXPECT_NEAR(2.0 * std::numbers::pi / (mems.encoders.counts_per_rev * mems.encoders.gear_ratio[0]), 3.835e-5, 1e-8);
}

TEST(SensorModels, BadParametersAreRefusedNamingTheField) {
  SensorModelConfig c;
  c.imu.gyro.noise_per_sqrt_hz = -1.0;
  EXPECT_NE(check_sensor_model(c, kDt).find("imu.gyro.noise_per_sqrt_hz"), std::string::npos);
  c = SensorModelConfig{};
  c.imu.accel.delay_ticks = kMaxSensorDelayTicks + 1;
  EXPECT_NE(check_sensor_model(c, kDt).find("imu.accel.delay_ticks"), std::string::npos);
  c = SensorModelConfig{};
  c.encoders.velocity = EncoderVelocity::lowpass;
  EXPECT_NE(check_sensor_model(c, kDt).find("encoders.velocity_cutoff_hz"), std::string::npos);
  c = SensorModelConfig{};
  c.encoders.gear_ratio[2] = 0.0;
  EXPECT_NE(check_sensor_model(c, kDt).find("encoders.gear_ratio[2]"), std::string::npos);
  c = SensorModelConfig{};
  c.wrist_ft.force_range_n.x() = std::nan("");
  EXPECT_NE(check_sensor_model(c, kDt).find("wrist_ft.force_range_n"), std::string::npos);
  SensorModel m;
  EXPECT_FALSE(m.configure(c, kDt).empty());
}

// Every part of every preset, ticking: no allocation (operator new counted, Eigen's trap armed).
TEST(SensorModels, NoTickAllocates) {
  for (const ImuPreset p : {ImuPreset::ideal, ImuPreset::mems, ImuPreset::tactical}) {
    SensorModelConfig c = sensor_preset(p);
    c.imu.orientation.drift_rad_per_sqrt_s = 1e-4;
    c.imu.orientation.noise_rad = 1e-4;
    c.encoders.velocity = EncoderVelocity::lowpass;
    c.encoders.velocity_cutoff_hz = 100.0;
    SensorModel m = configured(c);
    hal::Imu out;
    hal::Wrench w;
    VecNj q = VecNj::Zero(), q_out, qd_out, tau_out;
    const std::size_t allocations = test::count_allocations([&] {
      for (int k = 0; k < 1000; ++k) {
        m.imu(truth_at(k), k == 0, out);
        q.setConstant(1e-3 * k);
        m.joints(q, q, q, k == 0, q_out, qd_out, tau_out);
        m.wrist(Vec3(1, 2, 3), Vec3(0.1, 0.2, 0.3), w);
      }
    });
    EXPECT_EQ(allocations, 0u) << static_cast<int>(p);
  }
}

}  // namespace
}  // namespace springbok::sim
