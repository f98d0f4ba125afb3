// BaseEstimator against independent oracles: the IMU mounting against forward
// kinematics in world, leg odometry against finite differences of the contact
// point's material motion along a properly integrated q(t), the reset height
// against world forward kinematics; bad inputs, no stance, allocation.
#include <cmath>
#include <cstdio>
#include <memory>
#include <functional>
#include <random>
#include <vector>

#include <gtest/gtest.h>

#include "alloc_trap.hpp"
#include "springbok/estimation/base_estimator.hpp"

namespace {

// The complementary filter (the cases below are its; filter ekf, the default, has its own).
springbok::est::EstimatorParams complementary() {
  springbok::est::EstimatorParams p;
  p.filter = springbok::est::BaseFilter::complementary;
  return p;
}

using namespace springbok;

const VecNj kStance = [] {
  VecNj q = VecNj::Zero();
  const double front[3] = {0.0, 0.7, -1.4};
  for (int j = 0; j < 12; ++j) q[j] = (j / 3 < 2 ? 1.0 : -1.0) * front[j % 3];
  return q;
}();

Quat random_orientation(std::mt19937_64& rng, double max_rad) {
  std::uniform_real_distribution<double> a(-max_rad, max_rad);
  return Quat(Eigen::AngleAxisd(a(rng), Vec3::UnitZ()) * Eigen::AngleAxisd(a(rng), Vec3::UnitY()) *
              Eigen::AngleAxisd(a(rng), Vec3::UnitX()));
}

VecNq make_q(const Vec3& p, const Quat& o, const VecNj& joints) {
  VecNq q;
  q.head<3>() = p;
  q.segment<4>(3) = o.normalized().coeffs();
  q.tail<kNj>() = joints;
  return q;
}

// q(t + dt) for constant v (CONVENTIONS.md: T_WB <- T_WB exp_SE3(dt [v_B; w_B])).
VecNq integrate(const VecNq& q, const VecNv& v, double dt) {
  const Quat o(q[6], q[3], q[4], q[5]);
  const Vec3 w = v.segment<3>(3) * dt, u = v.head<3>() * dt;
  const double th = w.norm();
  Mat3 vmat = Mat3::Identity();
  if (th > 1e-12) {
    Mat3 wx;
    wx << 0, -w.z(), w.y(), w.z(), 0, -w.x(), -w.y(), w.x(), 0;
    vmat += (1 - std::cos(th)) / (th * th) * wx + (th - std::sin(th)) / (th * th * th) * wx * wx;
  }
  const Quat dq(Eigen::AngleAxisd(th, th > 1e-12 ? Vec3(w / th) : Vec3::UnitX()));
  VecNq out = q;
  out.head<3>() = q.head<3>() + o.toRotationMatrix() * (vmat * u);
  out.segment<4>(3) = (o * dq).normalized().coeffs();
  out.tail<kNj>() += v.tail<kNj>() * dt;
  return out;
}

hal::Measurements measure(const dyn::Model& model, dyn::Data& data, const VecNq& q, const VecNv& v) {
  dyn::forward_kinematics(model, data, q);
  hal::Measurements m;
  m.q_rad = q.tail<kNj>();
  m.qd_rad_s = v.tail<kNj>();
  m.imu.valid = true;
  const Mat3 r_wi = data.frames[kImuFrame].rotation;
  m.imu.orientation = Quat(r_wi);
  const Mat3 r_bi = model.frame_placement[kImuFrame].rotation;
  m.imu.angular_rate_rad_s = r_bi.transpose() * v.segment<3>(3);
  m.imu.linear_accel_m_s2 = r_wi.transpose() * Vec3(0, 0, kGravity_m_s2);  // at rest
  return m;
}

// The measurements of the robot at rest at the stance, its trunk 0.6 m above the origin in `orientation`.
hal::Measurements at_rest(const Quat& orientation = Quat::Identity()) {
  const dyn::Model model;
  auto data = std::make_unique<dyn::Data>();
  return measure(model, *data, make_q(Vec3(0, 0, 0.6), orientation, kStance), VecNv::Zero());
}

TEST(BaseEstimator, ImuMountingIsRemoved) {
  const dyn::Model model;
  auto data = std::make_unique<dyn::Data>();
  est::BaseEstimator estimator(complementary());
  std::mt19937_64 rng(11);
  for (int trial = 0; trial < 20; ++trial) {
    const Quat o = random_orientation(rng, 3.0);
    const VecNq q = make_q(Vec3(0.1, 0.2, 0.6), o, kStance);
    VecNv v = VecNv::Zero();
    v.segment<3>(3) = Vec3(0.3, -1.2, 0.7) * (trial + 1) * 0.1;
    const hal::Measurements m = measure(model, *data, q, v);
    EXPECT_LT((estimator.trunk_rotation(m.imu.orientation) - o.toRotationMatrix()).norm(), 1e-12);
    EXPECT_LT((estimator.trunk_angular_rate(m.imu.angular_rate_rad_s) - v.segment<3>(3)).norm(), 1e-12);
  }
}

TEST(BaseEstimator, LegOdometryMatchesFiniteDifferencesOfTheContactPoint) {
  // The ground contact point is a material point of the lower leg (foot_radius below
  // the sphere centre in world z at this instant). Its world velocity, by central
  // differences of forward kinematics along q(t), is R (v_B - leg_odometry_velocity).
  const dyn::Model model;
  auto data = std::make_unique<dyn::Data>();
  est::BaseEstimator estimator(complementary());
  std::mt19937_64 rng(5);
  std::normal_distribution<double> n(0.0, 1.0);
  const double r = kFootRadius_m;
  for (int trial = 0; trial < 10; ++trial) {
    VecNj joints = kStance;
    for (int j = 0; j < kNj; ++j) joints[j] += 0.2 * n(rng);
    const VecNq q = make_q(Vec3(n(rng), n(rng), 0.6), random_orientation(rng, 0.4), joints);
    VecNv v;
    for (int i = 0; i < kNv; ++i) v[i] = n(rng);
    const Mat3 rot = Quat(q[6], q[3], q[4], q[5]).toRotationMatrix();
    estimator.kinematics(q.tail<kNj>());
    for (int f = 0; f < kFeet; ++f) {
      dyn::forward_kinematics(model, *data, q);
      const int body = model.frame_body[kFootFrames[f]];
      const Vec3 offset_body = data->body_rotation[body].transpose() * Vec3(0, 0, -r);  // fixed in the shin
      auto point = [&](const VecNq& qq) {
        dyn::forward_kinematics(model, *data, qq);
        return Vec3(data->frames[kFootFrames[f]].translation + data->body_rotation[body] * offset_body);
      };
      const double h = 1e-6;
      const Vec3 fd = (point(integrate(q, v, h)) - point(integrate(q, v, -h))) / (2 * h);
      const Vec3 odometry = estimator.leg_odometry_velocity(f, rot, v.segment<3>(3), v.tail<kNj>());
      const Vec3 predicted = rot * (v.head<3>() - odometry);
      EXPECT_LT((predicted - fd).norm(), 1e-7 * (1 + fd.norm())) << "foot " << f << " trial " << trial;
    }
  }
}

TEST(BaseEstimator, ResetPutsTheTrunkAboveTheFeetOnTheGround) {
  const dyn::Model model;
  auto data = std::make_unique<dyn::Data>();
  std::mt19937_64 rng(2);
  for (int trial = 0; trial < 10; ++trial) {
    const VecNq q = make_q(Vec3(0.4, -0.3, 0.61), random_orientation(rng, 0.15), kStance);
    // Oracle: world forward kinematics of the true pose; the ground is at the mean contact height.
    dyn::forward_kinematics(model, *data, q);
    double ground = 0.0;
    for (int f : kFootFrames) ground += data->frames[f].translation.z() - kFootRadius_m;
    ground /= kFeet;
    est::EstimatorParams params = complementary();
    params.ground_height_m = ground;
    est::BaseEstimator estimator(params);
    const hal::Measurements m = measure(model, *data, q, VecNv::Zero());
    ASSERT_EQ(estimator.reset(m, {true, true, true, true}, Eigen::Vector2d(0.4, -0.3)), est::EstimateStatus::ok);
    const VecNq& e = estimator.estimate().q;
    EXPECT_LT((e.head<3>() - q.head<3>()).norm(), 1e-12);
    EXPECT_LT((Quat(e[6], e[3], e[4], e[5]).toRotationMatrix() - Quat(q[6], q[3], q[4], q[5]).toRotationMatrix()).norm(),
              1e-12);
    for (int f = 0; f < kFeet; ++f) {
      EXPECT_NEAR(estimator.estimate().anchor_world_m[f].z(), data->frames[kFootFrames[f]].translation.z() - kFootRadius_m,
                  1e-12);
    }
  }
}

TEST(BaseEstimator, StandingStillStaysStillAndDoesNotAllocate) {
  const hal::Measurements m = at_rest(Quat(Eigen::AngleAxisd(0.1, Vec3::UnitY())));
  est::BaseEstimator estimator(complementary());
  const Stance all{true, true, true, true};
  ASSERT_EQ(estimator.reset(m, all, Eigen::Vector2d::Zero()), est::EstimateStatus::ok);
  const VecNq start = estimator.estimate().q;
  test::AllocationTrap trap;
  for (int k = 0; k < 2000; ++k) estimator.update(m, all, 0.001);
  const std::size_t allocations = trap.disarm();
  EXPECT_EQ(allocations, 0u);
  EXPECT_EQ(estimator.estimate().status, est::EstimateStatus::ok);
  EXPECT_LT((estimator.estimate().q - start).norm(), 1e-9);
  EXPECT_LT(estimator.estimate().v.norm(), 1e-9);
}

// filter ekf: the start-up calibration. A still robot (lying or standing before start-up) whose
// gyro reads a 20 mrad/s turn-on bias on every axis plus white noise: after calibration_time_s
// the bias is known to the noise's mean error, and reset() starts the filter from it (the
// filter then holds it, standing still). A bump (rates far above the noise) drops the recording
// under way; without a still recording the filter starts from zero. No allocation.
TEST(BaseEstimator, TheEkfStartsFromTheStillRecordingsGyroBias) {
  est::EstimatorParams params;
  params.filter = est::BaseFilter::ekf;
  const Stance all{true, true, true, true};
  const Vec3 bias(0.02, -0.02, 0.02);
  constexpr double kNoise = 0.005;  // rad/s per sample
  std::mt19937_64 rng(7);
  std::normal_distribution<double> normal(0.0, kNoise);
  hal::Measurements m = at_rest(Quat(Eigen::AngleAxisd(0.05, Vec3::UnitX())));
  const Vec3 rate0 = m.imu.angular_rate_rad_s;
  const auto sample = [&](const Vec3& extra) {
    m.imu.angular_rate_rad_s = rate0 + bias + extra + Vec3(normal(rng), normal(rng), normal(rng));
    return m;
  };
  {
    est::BaseEstimator uncalibrated(params);
    ASSERT_EQ(uncalibrated.reset(sample(Vec3::Zero()), all, Eigen::Vector2d::Zero()), est::EstimateStatus::ok);
    EXPECT_FALSE(uncalibrated.gyro_calibrated());
    EXPECT_EQ(uncalibrated.ekf().gyro_bias_i_rad_s().norm(), 0.0);
  }
  est::BaseEstimator estimator(params);
  const int window = static_cast<int>(std::lround(params.ekf.calibration_time_s / 0.001));
  test::AllocationTrap trap;
  for (int k = 0; k < window / 2; ++k) estimator.calibrate(sample(Vec3::Zero()), 0.001);
  for (int k = 0; k < 50; ++k) estimator.calibrate(sample(Vec3(0.5, 0.0, 0.0)), 0.001);  // bumped
  for (int k = 0; k < window / 2; ++k) estimator.calibrate(sample(Vec3::Zero()), 0.001);
  const bool after_bump = estimator.gyro_calibrated();
  for (int k = 0; k < 2 * window; ++k) estimator.calibrate(sample(Vec3::Zero()), 0.001);
  ASSERT_EQ(estimator.reset(sample(Vec3::Zero()), all, Eigen::Vector2d::Zero()), est::EstimateStatus::ok);
  const Vec3 started_from = estimator.ekf().gyro_bias_i_rad_s();
  for (int k = 0; k < 500; ++k) estimator.update(sample(Vec3::Zero()), all, 0.001);
  const std::size_t allocations = trap.disarm();
  EXPECT_EQ(allocations, 0u);
  EXPECT_FALSE(after_bump) << "the bumped recording is not used";
  ASSERT_TRUE(estimator.gyro_calibrated());
  EXPECT_EQ(started_from, estimator.calibrated_gyro_bias_i_rad_s());
  // The mean of N samples: kNoise / sqrt(N) per axis; within 4 of those.
  const double mean_error = kNoise / std::sqrt(static_cast<double>(window));
  for (int a = 0; a < 3; ++a) {
    EXPECT_NEAR(estimator.calibrated_gyro_bias_i_rad_s()[a], bias[a], 4.0 * mean_error) << a;
    // The filter starts there and moves within its own prior (EkfParams' initial std).
    EXPECT_NEAR(estimator.ekf().gyro_bias_i_rad_s()[a], bias[a], 0.0015) << a;
  }
  EXPECT_EQ(estimator.estimate().status, est::EstimateStatus::ok);
  EXPECT_LT(estimator.estimate().v.head<3>().norm(), 0.005);
}

// Successive still recordings average: 30 s of them give the bias to 1/sqrt(30) of one
// recording's error, and the filter starts with that average's std as the bias's prior (the
// gyro's noise density over the time, at least); the average keeps the newest 60 s.
TEST(BaseEstimator, TheStillRecordingsAverageAndGiveTheBiasItsPrior) {
  est::EstimatorParams params;
  params.filter = est::BaseFilter::ekf;
  params.ekf.gyro_noise_rad_s_per_sqrt_hz = 1e-5;  // below this test's noise: the spread rules
  const Stance all{true, true, true, true};
  const Vec3 bias(0.006, -0.004, 0.005);
  constexpr double kNoise = 0.005;  // rad/s per sample at 1 kHz
  std::mt19937_64 rng(11);
  std::normal_distribution<double> normal(0.0, kNoise);
  hal::Measurements m = at_rest(Quat::Identity());
  const Vec3 rate0 = m.imu.angular_rate_rad_s;
  est::BaseEstimator estimator(params);
  for (int k = 0; k < 30000; ++k) {
    m.imu.angular_rate_rad_s = rate0 + bias + Vec3(normal(rng), normal(rng), normal(rng));
    estimator.calibrate(m, 0.001);
  }
  ASSERT_TRUE(estimator.gyro_calibrated());
  EXPECT_NEAR(estimator.calibrated_time_s(), 30.0, 1e-6);
  const double expected_std = kNoise / std::sqrt(30000.0);
  for (int a = 0; a < 3; ++a) {
    EXPECT_NEAR(estimator.calibrated_gyro_bias_std_rad_s()[a], expected_std, 0.05 * expected_std) << a;
    EXPECT_NEAR(estimator.calibrated_gyro_bias_i_rad_s()[a], bias[a], 4.0 * expected_std) << a;
  }
  ASSERT_EQ(estimator.reset(m, all, Eigen::Vector2d::Zero()), est::EstimateStatus::ok);
  const auto& P = estimator.ekf().covariance();
  for (int a = 0; a < 3; ++a) {
    EXPECT_NEAR(std::sqrt(P(est::kEkfBg + a, est::kEkfBg + a)), estimator.calibrated_gyro_bias_std_rad_s()[a], 1e-12) << a;
  }
  est::BaseEstimator longer(params);
  for (int k = 0; k < 90000; ++k) {
    m.imu.angular_rate_rad_s = rate0 + bias + Vec3(normal(rng), normal(rng), normal(rng));
    longer.calibrate(m, 0.001);
  }
  EXPECT_NEAR(longer.calibrated_time_s(), est::kCalibrationMemory_s, 1e-6);
}

TEST(BaseEstimator, MovingTrunkOverStillFeetIsTracked) {
  // The trunk sways over four fixed feet: the leg joint rates that keep each contact
  // point still are solved from the world foot Jacobian at the contact point (dynamics),
  // the estimator sees only the IMU and the joints.
  const dyn::Model model;
  auto data = std::make_unique<dyn::Data>();
  est::BaseEstimator estimator(complementary());
  const Stance all{true, true, true, true};
  VecNq q = make_q(Vec3(0, 0, 0.6), Quat::Identity(), kStance);
  double ground = 0.0;
  dyn::forward_kinematics(model, *data, q);
  for (int f : kFootFrames) ground += (data->frames[f].translation.z() - kFootRadius_m) / kFeet;
  est::EstimatorParams params = complementary();
  params.ground_height_m = ground;
  params.use_accelerometer = false;  // this synthetic motion has no IMU acceleration model
  estimator = est::BaseEstimator(params);
  ASSERT_EQ(estimator.reset(measure(model, *data, q, VecNv::Zero()), all, Eigen::Vector2d::Zero()),
            est::EstimateStatus::ok);
  const double dt = 0.001;
  double worst_v = 0.0;
  for (int k = 0; k < 1000; ++k) {
    const double t = k * dt;
    VecNv v = VecNv::Zero();
    v.head<3>() = Vec3(0.05 * std::cos(6 * t), 0.04 * std::sin(5 * t), 0.02 * std::cos(7 * t));
    v.segment<3>(3) = Vec3(0.1 * std::sin(4 * t), 0.08 * std::cos(3 * t), 0.05);
    dyn::point_jacobians(model, *data, q);
    const Mat3 rot = Quat(q[6], q[3], q[4], q[5]).toRotationMatrix();
    for (int f = 0; f < kFeet; ++f) {
      // Contact-point Jacobian: J_c = J_f + r [z]x J_shin (columns: base angular, leg joints).
      Mat3Nv jc = data->J_feet[f];
      auto shift = [&](int col, const Vec3& w) {
        jc(0, col) -= kFootRadius_m * w.y();
        jc(1, col) += kFootRadius_m * w.x();
      };
      for (int c = 0; c < 3; ++c) shift(3 + c, rot.col(c));
      const int first = leg_first_joint(f);
      for (int c = 0; c < kLegJoints; ++c) shift(6 + first + c, data->joint_axis[first + c]);
      const Mat3 jl = jc.block<3, 3>(0, 6 + first);
      v.segment<3>(6 + first) = jl.lu().solve(-jc.leftCols<6>() * v.head<6>());
    }
    const est::BaseEstimate& e = estimator.update(measure(model, *data, q, v), all, dt);
    worst_v = std::max(worst_v, (e.v.head<3>() - v.head<3>()).norm());
    q = integrate(q, v, dt);
  }
  EXPECT_LT(worst_v, 1e-12);  // the velocity at the measured state is exact
  // The position: explicit Euler in the estimator vs the exact SE(3) step here, O(dt) over 1 s.
  EXPECT_LT((estimator.estimate().q.head<3>() - q.head<3>()).norm(), 2e-4);
}

TEST(BaseEstimator, BadInputHoldsTheLastEstimateAndSaysSo) {
  const hal::Measurements good = at_rest();
  est::BaseEstimator estimator(complementary());
  const Stance all{true, true, true, true};
  EXPECT_EQ(estimator.update(good, all, 0.001).status, est::EstimateStatus::not_reset);
  EXPECT_EQ(estimator.reset(good, {false, false, false, false}, Eigen::Vector2d::Zero()), est::EstimateStatus::bad_input);
  hal::Measurements nan_joint = good;
  nan_joint.qd_rad_s[4] = std::nan("");
  EXPECT_EQ(estimator.reset(nan_joint, all, Eigen::Vector2d::Zero()), est::EstimateStatus::bad_input);
  ASSERT_EQ(estimator.reset(good, all, Eigen::Vector2d::Zero()), est::EstimateStatus::ok);
  const est::BaseEstimate before = estimator.estimate();
  for (const auto& spoil : std::vector<std::function<void(hal::Measurements&)>>{
           [](hal::Measurements& m) { m.q_rad[0] = std::nan(""); },
           [](hal::Measurements& m) { m.imu.valid = false; },
           [](hal::Measurements& m) { m.imu.orientation.coeffs().setZero(); },
           [](hal::Measurements& m) { m.imu.angular_rate_rad_s.x() = INFINITY; },
           [](hal::Measurements& m) { m.imu.linear_accel_m_s2.z() = std::nan(""); }}) {
    hal::Measurements bad = good;
    spoil(bad);
    const est::BaseEstimate& e = estimator.update(bad, all, 0.001);
    EXPECT_EQ(e.status, est::EstimateStatus::bad_input);
    EXPECT_TRUE(e.q.allFinite() && e.v.allFinite());
    EXPECT_EQ(e.q, before.q);
  }
  EXPECT_EQ(estimator.update(good, all, std::nan("")).status, est::EstimateStatus::bad_input);
  EXPECT_EQ(estimator.update(good, all, 0.001).status, est::EstimateStatus::ok);
}

TEST(BaseEstimator, WithoutStanceTheImuAlonePredicts) {
  hal::Measurements m = at_rest();
  est::BaseEstimator estimator(complementary());
  ASSERT_EQ(estimator.reset(m, {true, true, true, true}, Eigen::Vector2d::Zero()), est::EstimateStatus::ok);
  const double z0 = estimator.estimate().q[2];
  m.imu.linear_accel_m_s2.setZero();  // free fall: the accelerometer reads zero specific force
  const Stance none{false, false, false, false};
  for (int k = 0; k < 100; ++k) EXPECT_EQ(estimator.update(m, none, 0.001).status, est::EstimateStatus::no_stance);
  // 100 explicit Euler steps of g: v = g t exactly, z = z0 - g dt^2 n(n+1)/2.
  EXPECT_NEAR(estimator.estimate().v[2], -kGravity_m_s2 * 0.1, 1e-12);
  EXPECT_NEAR(estimator.estimate().q[2], z0 - kGravity_m_s2 * 1e-6 * 100 * 101 / 2, 1e-12);
}

// The case the complementary filter's position-aided tilt (retired) was for, which the EKF
// covers: the IMU, mounted upside down as on the robot, reports a q_w 0.0018 off (what the CAN
// IMU loses: its q_w is not on the wire), a 3.6 mrad tilt the trunk does not have, while its gyro
// and accelerometer measure the true rate and specific force; the trunk sways along x and y over
// four still, rolling feet with 0.5 m/s^2 (the tilt an accelerometer-only estimate would see:
// 50 mrad). The EKF starts from the reported orientation and takes the tilt error below 0.1 mrad
// within 30 s (the base's acceleration is what the feet's kinematics see); the complementary
// filter keeps the IMU's.
struct SwayResult {
  double tilt_error_rad = -1.0;    // estimate against truth at the end (< 0: the reset failed)
  double reported_error_rad = 0.0;  // what the IMU's q_w error alone makes of it
  std::size_t allocations = 0;
};

double tilt_between(const Mat3& a, const Mat3& b) {
  const Vec3 up_a = a.row(2).transpose(), up_b = b.row(2).transpose();  // world z in each trunk frame
  return std::asin(std::min(1.0, up_a.cross(up_b).norm()));
}

SwayResult sway(est::BaseFilter filter) {
  SwayResult out;
  const dyn::Model model;
  auto data = std::make_unique<dyn::Data>();
  const Stance all{true, true, true, true};
  const Quat heading(Eigen::AngleAxisd(0.4, Vec3::UnitZ()));
  VecNq q = make_q(Vec3(0, 0, 0.6), heading, kStance);
  double ground = 0.0;
  dyn::forward_kinematics(model, *data, q);
  for (int f : kFootFrames) ground += (data->frames[f].translation.z() - kFootRadius_m) / kFeet;
  est::EstimatorParams params = complementary();
  params.filter = filter;
  params.ground_height_m = ground;
  est::BaseEstimator estimator(params);
  const auto sensed = [&](const VecNq& qt, const VecNv& v, const Vec3& accel_w) {
    hal::Measurements m = measure(model, *data, qt, v);
    const Mat3 r_wi = data->frames[kImuFrame].rotation;
    m.imu.linear_accel_m_s2 = r_wi.transpose() * (accel_w + Vec3(0, 0, kGravity_m_s2));
    Quat reported(r_wi);
    if (reported.w() < 0.0) reported.coeffs() = -reported.coeffs();
    reported.w() += 0.0018;
    m.imu.orientation = reported.normalized();
    return m;
  };
  const hal::Measurements first = sensed(q, VecNv::Zero(), Vec3::Zero());
  out.reported_error_rad = tilt_between(estimator.trunk_rotation(first.imu.orientation), heading.toRotationMatrix());
  if (estimator.reset(first, all, Eigen::Vector2d::Zero()) != est::EstimateStatus::ok) return out;
  const double dt = 0.001, amp = 0.5, wx = 2 * M_PI * 0.5, wy = 2 * M_PI * 0.3;
  const auto velocity_w = [&](double t) { return Vec3(amp / wx * std::sin(wx * t), amp / wy * std::sin(wy * t), 0.0); };
  const auto accel_w = [&](double t) { return Vec3(amp * std::cos(wx * t), amp * std::cos(wy * t), 0.0); };
  test::AllocationTrap trap;
  for (int k = 0; k < 30000; ++k) {
    const double t = k * dt;
    VecNv v = VecNv::Zero();
    const Mat3 rot = Quat(q[6], q[3], q[4], q[5]).toRotationMatrix();
    v.head<3>() = rot.transpose() * velocity_w(t + 0.5 * dt);  // the step's mean velocity
    dyn::point_jacobians(model, *data, q);
    for (int f = 0; f < kFeet; ++f) {  // the legs' rates that keep the contact points still (rolling feet)
      Mat3Nv jc = data->J_feet[f];  // as MovingTrunkOverStillFeetIsTracked: J_c = J_f + r [z]x J_shin
      const int first = leg_first_joint(f);
      for (int c = 0; c < kLegJoints; ++c) {
        const Vec3& w = data->joint_axis[first + c];
        jc(0, 6 + first + c) -= kFootRadius_m * w.y();
        jc(1, 6 + first + c) += kFootRadius_m * w.x();
      }
      v.segment<3>(6 + first) = jc.block<3, 3>(0, 6 + first).lu().solve(-jc.leftCols<3>() * v.head<3>());
    }
    estimator.update(sensed(q, v, accel_w(t)), all, dt);
    q = integrate(q, v, dt);
  }
  out.allocations = trap.disarm();
  const VecNq& e = estimator.estimate().q;
  out.tilt_error_rad = tilt_between(Quat(e[6], e[3], e[4], e[5]).toRotationMatrix(), Quat(q[6], q[3], q[4], q[5]).toRotationMatrix());
  return out;
}

TEST(BaseEstimator, TheEkfRemovesTheUpsideDownCanImusTiltErrorWhileTheTrunkAccelerates) {
  const SwayResult ekf = sway(est::BaseFilter::ekf), complementary = sway(est::BaseFilter::complementary);
  std::printf("tilt error after 30 s of sway: ekf %.2e rad, complementary %.2e rad (the IMU's q_w error: %.2e rad)\n",
              ekf.tilt_error_rad, complementary.tilt_error_rad, ekf.reported_error_rad);
  ASSERT_GE(ekf.tilt_error_rad, 0.0) << "reset failed";
  EXPECT_GT(ekf.reported_error_rad, 3e-3);
  EXPECT_LT(ekf.tilt_error_rad, 1e-4);
  EXPECT_EQ(ekf.allocations, 0u);
  EXPECT_NEAR(complementary.tilt_error_rad, complementary.reported_error_rad, 1e-4);
}

}  // namespace
