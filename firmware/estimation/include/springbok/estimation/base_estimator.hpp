// The floating-base state from what a real robot measures (SPEC section 6):
// the trunk IMU (orientation, angular rate, specific force) and the joint
// encoders, with the stance feet as the kinematic anchors.
//
// One tick:
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
// Without a stance foot the filter predicts from the IMU alone and says so.
// A non-finite or invalid measurement holds the last estimate and reports it.
//
// Conventions are CONVENTIONS.md's: q = [p_WB, quaternion xyzw, joints],
// v = [v_B, w_B (trunk frame), joint rates].
#pragma once

#include <array>
#include <cstdint>

#include "springbok/dynamics/dynamics.hpp"
#include "springbok/hal/types.hpp"
#include "springbok/model/model.hpp"
#include "springbok/model/robot_state.hpp"

namespace springbok::est {

struct EstimatorParams {
  double velocity_gain_per_s = 30.0;  // leg odometry vs IMU integration crossover
  double position_gain_per_s = 10.0;  // pull towards the stance anchors
  double foot_radius_m = kFootRadius_m;
  double ground_height_m = 0.0;       // world z of the ground under the feet at reset
  bool use_accelerometer = true;      // false: velocity = leg odometry alone
};

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

  // One estimator tick of dt_s. rt: no alloc, no block
  const BaseEstimate& update(const hal::Measurements& m, const Stance& stance, double dt_s) noexcept;

  const BaseEstimate& estimate() const noexcept { return out_; }

  // The trunk velocity (trunk frame) implied by one stance foot, given the trunk
  // orientation, its angular rate (trunk frame) and the joint state: leg odometry,
  // exposed for tests. Uses the kinematics last computed by kinematics(). rt: no alloc
  Vec3 leg_odometry_velocity(int foot, const Mat3& rot_wb, const Vec3& omega_b, const VecNj& qd) const noexcept;
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

  EstimatorParams params_;
  dyn::Model model_;
  dyn::Data data_;
  VecNq q_identity_ = VecNq::Zero();
  Vec3 position_w_ = Vec3::Zero();
  Vec3 velocity_w_ = Vec3::Zero();  // of the trunk origin
  Stance stance_prev_{};
  bool reset_ = false;
  BaseEstimate out_;
};

}  // namespace springbok::est
