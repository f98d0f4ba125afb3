// The base estimator's errors against the simulator's ground truth, over a run's control ticks:
// the figures issue 47 sets targets on (summary.json "estimator", tools/scenarios/README.md).
//   velocity: RMS of |v_est - v_true| (the trunk's linear velocity, world frame)
//   tilt:     RMS of the angle between the estimated and the true gravity direction in the
//             trunk frame (R_est^T e_z against R_true^T e_z): roll and pitch, not yaw
//   yaw:      the heading error's change from the first control tick to the last, per minute;
//             and split by whether the trunk turns (its true yaw rate, low-passed over
//             kTurnFilter_s, above kTurning_rad_s): per minute of the ticks it does not (standing,
//             trotting or walking straight), and per radian it turned (a gyro's scale error)
//   position: the horizontal position error's change over the run, over the distance the trunk
//             walked (the true horizontal path's length); none under 0.5 m walked
// Each tick's estimate is compared with the truth of the same instant (before the physics step).
#pragma once

#include <Eigen/Dense>
#include <cmath>
#include <cstdint>
#include <string>

#include <fmt/format.h>

namespace springbok::simtool {

class EstimatorErrors {
 public:
  static constexpr double kTurnFilter_s = 0.5, kTurning_rad_s = 0.05;

  // `pose_*`: [x y z qx qy qz qw] (the trunk's), `velocity_*`: its linear velocity, world frame.
  void add(const Eigen::Matrix<double, 7, 1>& pose_est, const Eigen::Vector3d& velocity_est,
           const Eigen::Matrix<double, 7, 1>& pose_true, const Eigen::Vector3d& velocity_true, bool estimate_ok,
           double dt_s) noexcept {
    const Eigen::Matrix3d r_est = rotation(pose_est), r_true = rotation(pose_true);
    const Eigen::Vector3d g_est = r_est.row(2).transpose(), g_true = r_true.row(2).transpose();
    const double tilt = std::atan2(g_est.cross(g_true).norm(), g_est.dot(g_true));
    const double yaw_error = wrap(yaw(r_est) - yaw(r_true));
    const Eigen::Vector2d p_error = pose_est.head<2>() - pose_true.head<2>();
    const double yaw_true = yaw(r_true);
    if (samples_ == 0) {
      first_p_error_ = p_error;
    } else {
      distance_m_ += (pose_true.head<2>() - last_p_true_).norm();
      // The heading error unwrapped across ±pi.
      const double step = wrap(yaw_error - last_yaw_error_), turn = wrap(yaw_true - last_yaw_true_);
      yaw_drift_ += step;
      if (dt_s > 0.0) yaw_rate_lp_ += std::min(1.0, dt_s / kTurnFilter_s) * (turn / dt_s - yaw_rate_lp_);
      if (std::abs(yaw_rate_lp_) > kTurning_rad_s) {
        yaw_error_turning_ += step;
        turned_rad_ += std::abs(turn);
      } else {
        yaw_drift_in_place_ += step;
        in_place_s_ += dt_s;
      }
    }
    last_yaw_error_ = yaw_error;
    last_yaw_true_ = yaw_true;
    last_p_true_ = pose_true.head<2>();
    last_p_error_ = p_error;
    last_velocity_error_m_s_ = (velocity_est - velocity_true).norm();
    last_tilt_rad_ = tilt;
    velocity_sq_ += last_velocity_error_m_s_ * last_velocity_error_m_s_;
    tilt_sq_ += tilt * tilt;
    position_max_m_ = std::max(position_max_m_, (pose_est.head<3>() - pose_true.head<3>()).norm());
    all_ok_ = all_ok_ && estimate_ok;
    duration_s_ += samples_ > 0 ? dt_s : 0.0;
    ++samples_;
  }

  // The last tick's: |v_est - v_true|, the tilt error, the heading error's change since the first tick.
  double velocity_error_m_s() const noexcept { return last_velocity_error_m_s_; }
  double tilt_error_rad() const noexcept { return last_tilt_rad_; }
  double yaw_drift_rad() const noexcept { return yaw_drift_; }

  double velocity_rms_m_s() const noexcept { return rms(velocity_sq_); }
  double tilt_rms_rad() const noexcept { return rms(tilt_sq_); }
  double yaw_drift_rad_per_min() const noexcept { return duration_s_ > 0.0 ? yaw_drift_ / (duration_s_ / 60.0) : 0.0; }
  double yaw_drift_in_place_rad_per_min() const noexcept {
    return in_place_s_ > 0.0 ? yaw_drift_in_place_ / (in_place_s_ / 60.0) : 0.0;
  }
  double turned_rad() const noexcept { return turned_rad_; }
  // The heading error gathered while turning, per cent of the angle turned (0 under 1 rad
  // turned: the summary's null).
  double yaw_error_per_turn_percent() const noexcept {
    return turned_rad_ >= 1.0 ? 100.0 * yaw_error_turning_ / turned_rad_ : 0.0;
  }
  double distance_walked_m() const noexcept { return distance_m_; }
  // Percent of the distance walked; negative: under 0.5 m walked (none).
  double position_drift_percent() const noexcept {
    return distance_m_ >= 0.5 ? 100.0 * (last_p_error_ - first_p_error_).norm() / distance_m_ : -1.0;
  }

  // The summary's "estimator" object (one line, no trailing newline).
  std::string json() const {
    const double drift = position_drift_percent();
    return fmt::format(
        "{{\"all_ok\": {}, \"velocity_rms_error_m_s\": {:.6g}, \"position_max_error_m\": {:.6g}, "
        "\"tilt_rms_error_mrad\": {:.6g}, \"yaw_drift_deg_per_min\": {:.6g}, \"yaw_drift_in_place_deg_per_min\": {:.6g}, "
        "\"turned_rad\": {:.6g}, \"yaw_error_per_turn_percent\": {}, \"distance_walked_m\": {:.6g}, "
        "\"position_drift_percent\": {}}}",
        all_ok_ ? "true" : "false", velocity_rms_m_s(), position_max_m_, 1e3 * tilt_rms_rad(),
        yaw_drift_rad_per_min() * 180.0 / M_PI, yaw_drift_in_place_rad_per_min() * 180.0 / M_PI, turned_rad_,
        turned_rad_ >= 1.0 ? fmt::format("{:.6g}", yaw_error_per_turn_percent()) : std::string("null"), distance_m_,
        drift < 0.0 ? std::string("null") : fmt::format("{:.6g}", drift));
  }

 private:
  static Eigen::Matrix3d rotation(const Eigen::Matrix<double, 7, 1>& pose) noexcept {
    return Eigen::Quaterniond(pose[6], pose[3], pose[4], pose[5]).normalized().toRotationMatrix();
  }
  static double yaw(const Eigen::Matrix3d& r) noexcept { return std::atan2(r(1, 0), r(0, 0)); }
  static double wrap(double a) noexcept { return std::remainder(a, 2.0 * M_PI); }
  double rms(double sum_sq) const noexcept { return samples_ > 0 ? std::sqrt(sum_sq / static_cast<double>(samples_)) : 0.0; }

  std::uint64_t samples_ = 0;
  bool all_ok_ = true;
  double velocity_sq_ = 0.0, tilt_sq_ = 0.0, position_max_m_ = 0.0, last_velocity_error_m_s_ = 0.0, last_tilt_rad_ = 0.0;
  double last_yaw_error_ = 0.0, yaw_drift_ = 0.0, last_yaw_true_ = 0.0, yaw_rate_lp_ = 0.0;
  double yaw_drift_in_place_ = 0.0, in_place_s_ = 0.0, yaw_error_turning_ = 0.0, turned_rad_ = 0.0;
  Eigen::Vector2d first_p_error_ = Eigen::Vector2d::Zero(), last_p_error_ = Eigen::Vector2d::Zero();
  Eigen::Vector2d last_p_true_ = Eigen::Vector2d::Zero();
  double distance_m_ = 0.0, duration_s_ = 0.0;
};

}  // namespace springbok::simtool
