// The floating-base state from what a real robot measures (SPEC section 6):
// the trunk IMU (orientation, angular rate, specific force) and the joint
// encoders, with the stance feet as the kinematic anchors.
//
// Two filters (EstimatorParams::filter): ekf, the default (below), and the complementary
// filter of steps 1-4, whose tilt and yaw are the IMU's orientation output as reported.
//
// filter: complementary, one tick:
//  1. orientation R_WB and angular rate w_B from the IMU through its mounting
//     (robot::kFrame_trunk_imu): R_WB = R_WI R_BI', w_B = R_BI w_I;
//  2. leg odometry: the material point of each stance foot that touches the
//     ground (the sphere's lowest point, foot_radius below the centre) does not
//     move, so with the foot Jacobian at the identity base pose
//        0 = v_B + J_w(q) w_B + J_q(q) qd + w_shin x (-r z_B)
//     gives one measurement of the trunk velocity v_B per stance foot (averaged);
//  3. a complementary filter in world axes: the IMU's acceleration predicts the
//     velocity, leg odometry corrects it with gain k_v [1/s] (crossover k_v);
//  4. the position integrates the velocity and is pulled with gain k_p [1/s]
//     towards the one the stance feet's anchors imply (each foot's ground
//     contact point in world, set when it touches down and then moved as the
//     sphere rolls without slipping: d/dt anchor = w_shin x r z).
// Its tilt and yaw are the IMU's orientation output: for an IMU whose own filter is good (a
// tactical-grade unit's AHRS). An IMU whose orientation drifts (the CAN IMU of CAN.md 6.1, which
// sends no q_w) is filter ekf's case.
// Without a stance foot the filter predicts from the IMU alone and says so.
// A non-finite or invalid measurement holds the last estimate and reports it.
//
// filter: ekf (the default) replaces steps 1-4 with est::InertialKinematicEkf (inertial_kinematic_ekf.hpp:
// the IMU's biases in its state, the raw gyro and specific force, each stance foot's contact
// point as a measurement, a slipping foot rejected). This class gives it what it needs from
// the robot: the IMU's mounting (robot::kFrame_trunk_imu), each foot's contact point from the
// encoders (the sphere's lowest point, as step 2) with its covariance (encoder_std_rad through
// the leg's Jacobian, plus kinematics_std_m), and the rolling sphere's contact-point motion
// (step 4's w_shin x r z) as the anchor's known velocity. reset() starts it from the IMU's
// orientation output, with the gyro bias the still recordings calibrate() took before it gave
// (the robot lying or standing still before start-up: recordings of calibration_time_s of
// samples whose spread says still, averaged over the newest kCalibrationMemory_s of them; a
// recording that moved is dropped, and the next one begins) and that average's own std as the
// bias's prior, else zero and initial_gyro_bias_std; the accelerometer's bias starts at zero.
// Both are learnt online from there.
//
// Conventions are CONVENTIONS.md's: q = [p_WB, quaternion xyzw, joints],
// v = [v_B, w_B (trunk frame), joint rates].
#pragma once

#include <array>
#include <cstdint>

#include "springbok/dynamics/dynamics.hpp"
#include "springbok/estimation/inertial_kinematic_ekf.hpp"
#include "springbok/hal/types.hpp"
#include "springbok/model/model.hpp"
#include "springbok/model/robot_state.hpp"

namespace springbok::est {

// The filter that estimates the base (see above).
enum class BaseFilter : std::uint8_t { complementary, ekf };
const char* to_string(BaseFilter f) noexcept;

struct EstimatorParams {
  BaseFilter filter = BaseFilter::ekf;
  double velocity_gain_per_s = 30.0;  // leg odometry vs IMU integration crossover
  double position_gain_per_s = 10.0;  // pull towards the stance anchors
  double foot_radius_m = kFootRadius_m;
  double ground_height_m = 0.0;       // world z of the ground under the feet at reset
  bool use_accelerometer = true;      // false: velocity = leg odometry alone
  // filter ekf: the filter's own parameters (its ground_height_m is set from ground_height_m
  // above) and the kinematics' noise for each contact point's covariance.
  EkfParams ekf;
  double encoder_std_rad = 2e-4;   // a joint angle's error (the encoder's resolution, backlash)
  double kinematics_std_m = 2e-3;  // what the kinematics do not know (where the sphere touches, flex)
  // A joint rate's error (a differenced encoder's, a drive's filter). Above a differenced
  // encoder's own per-sample std (its quantisation's): that error is the difference of two
  // position errors, not white, and the contact point's too; weighted at its own std, the filter
  // rectifies it into a heading drift (tools/scenarios/README.md).
  double encoder_rate_std_rad_s = 0.05;
};
// The still time the start-up gyro calibration averages at most (the newest): the bias walks.
inline constexpr double kCalibrationMemory_s = 60.0;

enum class EstimateStatus : std::uint8_t {
  ok,
  no_stance,      // no foot on the ground: IMU prediction only (position drifts)
  bad_input,      // non-finite joint state or invalid/non-finite IMU: last estimate held
  not_reset,      // reset() has not succeeded yet
};
const char* to_string(EstimateStatus s) noexcept;

struct BaseEstimate {
  VecNq q = VecNq::Zero();
  VecNv v = VecNv::Zero();
  EstimateStatus status = EstimateStatus::not_reset;
  std::array<Vec3, kFeet> anchor_world_m{};  // ground contact point of each stance foot
};

class BaseEstimator {
 public:
  explicit BaseEstimator(const EstimatorParams& params = {}) noexcept;

  // Initialises the pose from one measurement: orientation from the IMU, the
  // base above the given stance feet standing on the ground plane
  // (ground_height), horizontal position `xy_m`. Returns bad_input (and stays
  // not reset) on a bad measurement or no stance foot. rt: no alloc
  EstimateStatus reset(const hal::Measurements& m, const Stance& stance, const Eigen::Vector2d& xy_m) noexcept;

  // One estimator tick of dt_s, at the instruction-set level springbok::isa chose. rt: no
  // alloc, no block
  const BaseEstimate& update(const hal::Measurements& m, const Stance& stance, double dt_s) noexcept;
  // The kernel behind update(), compiled once per level (src/dispatch.hpp).
  const BaseEstimate& update_kernel(const hal::Measurements& m, const Stance& stance, double dt_s) noexcept;
  // filter ekf, before reset(): one IMU sample for the start-up gyro calibration (see above);
  // nothing with the complementary filter. rt: no alloc, no block
  void calibrate(const hal::Measurements& m, double dt_s) noexcept;
  // The gyro bias the next reset() starts from and whether a still recording gave it (filter
  // ekf); the filter's estimate of both biases once it runs.
  bool gyro_calibrated() const noexcept { return gyro_calibrated_; }
  const Vec3& calibrated_gyro_bias_i_rad_s() const noexcept { return calibrated_gyro_bias_; }
  // Its std per axis (the recordings' spread over the root of their samples, at least the gyro
  // noise density's over the recorded time) and the still time it averages.
  Vec3 calibrated_gyro_bias_std_rad_s() const noexcept;
  double calibrated_time_s() const noexcept { return calibrated_time_s_; }
  const InertialKinematicEkf& ekf() const noexcept { return ekf_; }

  const BaseEstimate& estimate() const noexcept { return out_; }
  // The trunk velocity (trunk frame) implied by one stance foot, given the trunk
  // orientation, its angular rate (trunk frame) and the joint state: leg odometry,
  // exposed for tests. Uses the kinematics last computed by kinematics(). rt: no alloc
  Vec3 leg_odometry_velocity(int foot, const Mat3& rot_wb, const Vec3& omega_b, const VecNj& qd) const noexcept;
  // The joint rates' part of a stance foot's contact-point velocity relative to the trunk,
  // trunk axes: the leg Jacobian's and the lower leg's turn about the sphere's contact (down_b:
  // world down in trunk axes; after kinematics()). rt: no alloc
  Vec3 leg_contact_velocity_b(int foot, const Vec3& down_b, const VecNj& qd) const noexcept;
  // Angular velocity of a foot's lower leg, trunk axes (after kinematics()). rt: no alloc
  Vec3 shin_angular_velocity_b(int foot, const Vec3& omega_b, const VecNj& qd) const noexcept;
  // Foot kinematics at the identity base pose for joint angles q. rt: no alloc
  void kinematics(const VecNj& q_rad) noexcept;
  // Ground contact point of a foot relative to the trunk origin, trunk axes (after kinematics()).
  Vec3 contact_point_b(int foot, const Mat3& rot_wb) const noexcept;

  // Trunk orientation and angular rate (trunk frame) from the IMU's (its mounting removed).
  Mat3 trunk_rotation(const Eigen::Quaterniond& world_from_imu) const noexcept;
  Vec3 trunk_angular_rate(const Vec3& imu_rate_rad_s) const noexcept;

 private:
  bool measurement_ok(const hal::Measurements& m) const noexcept;
  void write_state(const hal::Measurements& m, const Mat3& rot_wb, const Vec3& omega_b) noexcept;
  // filter ekf: reset() and update() through the EKF. rt: no alloc
  // reset()'s checks and start position done (rot_wb: the IMU's; position_w: the trunk above the feet).
  EstimateStatus reset_ekf(const hal::Measurements& m, const Stance& stance, const Mat3& rot_wb,
                           const Vec3& position_w) noexcept;
  const BaseEstimate& update_ekf(const hal::Measurements& m, const Stance& stance, double dt_s) noexcept;
  // The feet's measurements for the EKF at its last orientation (kinematics() done). rt: no alloc
  void ekf_feet(const hal::Measurements& m, const Stance& stance, const Mat3& rot_wb, const Vec3& omega_b,
                FootMeasurements& feet) const noexcept;
  void write_ekf_state(const hal::Measurements& m) noexcept;

  EstimatorParams params_;
  dyn::Model model_;
  dyn::Data data_;
  VecNq q_identity_ = VecNq::Zero();
  Vec3 position_w_ = Vec3::Zero();
  Vec3 velocity_w_ = Vec3::Zero();  // of the trunk origin
  Stance stance_prev_{};
  bool reset_ = false;

  InertialKinematicEkf ekf_;  // filter ekf
  bool gyro_calibrated_ = false;
  Vec3 calibrated_gyro_bias_ = Vec3::Zero();     // IMU axes
  Vec3 calibrated_rate_variance_ = Vec3::Zero();  // a sample's, per axis
  double calibrated_time_s_ = 0.0, calibrated_rate_hz_ = 0.0;

  BaseEstimate out_;
};

}  // namespace springbok::est
