// The controller's parameters from YAML, read with springbok::yaml (start-up only): the
// tick libraries (wbc, gait, estimation) know nothing of YAML. Used by the robot config
// (control.wbc, control.estimator, control.gait), scenarios (controller.params) and the
// operator's gait requests. Every problem goes to the field's yaml::Errors; absent keys
// keep the structs' defaults.
//
// wbc (read_wbc_params):
//
//   template:                     # required: the double mass-spring-damper to render
//     base: {mass: 92, damping: 610, stiffness: 1000}   # each a number or [x, y, z]
//     ee:   {mass: 4,  damping: 90,  stiffness: 500}
//   rotational_template:          # optional, beyond the paper: present = on (the hand's
//                                 # orientation too; base_orientation's kp/kd then unused)
//     base: {inertia: auto, damping: 150, stiffness: 500}   # N m s/rad, N m/rad; each a number or [x, y, z]
//     ee:   {inertia: 0.1, damping: 4.5, stiffness: 50}     # kg m^2 (base: auto = composite)
//   base_orientation: {kp: 1600, kd: 160, inertia: auto}  # inertia: auto or [Ixx, Iyy, Izz]
//   arm: {posture_kp: 100, posture_kd: 20, posture: current, pinv_lambda0: 0.05,
//         manipulability_threshold: 0.02,                # posture: current or 7 angles
//         manipulability_threshold_6d: 0.005,            # the 6-D task's (rotational template)
//         max_acceleration: 100, max_angular_acceleration: 200}  # m/s^2 (or none), rad/s^2
//   weights: {base_force: 1, base_torque: 1, arm: 100, reg_acceleration: 1e-4,
//             reg_force: 1e-6, reg_slack: 1000}
//   contact: {friction_mu: 0.6, normal_force_min: 5, normal_force_max: 1500,
//             foot_radius: 0.02175,     # foot Jacobians at the ground contact point (0: centre)
//             support_margin: 0.04}     # m: the push's centre of pressure kept this far inside
//                                       # the feet while standing (0: off; WbcParams)
//   limits: {joint_horizon_s: 0.05, torque_scale: 1.0}
//   swing: {kp: 400, kd: 40}
//   joint_friction: {viscous: 0}    # N m s/rad, compensated: one number or 19 (kJoints' order)
//
// (No fallback section: what a failed tick commands is the safety supervisor's.)
// Every key is optional (defaults of WbcParams; the template's, the robot file's). Masses and
// stiffnesses must be positive, dampings non-negative; unknown keys, wrong
// types and non-finite numbers are errors naming the field.
//
// estimator (read_estimator_params), every key optional: velocity_gain, position_gain,
// foot_radius, ground_height, use_accelerometer.
//
// gait (read_trot_params), every key optional: the keys and ranges of gait::kTrotFields
// (step_frequency 0.1..5 Hz, duty_factor 0.5..0.95, step_height, velocity_gain, touchdown_depth,
// touchdown_force, late_touchdown, force_ramp, velocity_x, velocity_y, yaw_rate), and `velocity: [v_x, v_y, yaw_rate]` for the last three at once.
// With `schedule` yes the map may also hold `velocity_schedule` (a scenario's; its reader is the tool's).
//
// push_stepping (read_push_stepping; control::PushStepping), every key optional:
//   {enabled: true, trigger_inside: 0.02, unloaded_within: 5, leg_torque_ratio: 0.95, delay: 0.05,
//    velocity_gain: 0.25, settle: 1.0, settle_drift: 0.05, settle_push_change: 20}
//   # m, N, fraction of the limit (> 1: off), s, s, s, m, N
#pragma once

#include "springbok/yaml/reader.hpp"
#include "springbok/control/robot_controller.hpp"  // kTemplateRanges: the template's ranges, one table
#include "springbok/estimation/base_estimator.hpp"
#include "springbok/gait/trot.hpp"
#include "springbok/wbc/whole_body_controller.hpp"

namespace springbok::params {

// `yes`: the map may also hold `estimator`, `gait` and `push_stepping` (a scenario's
// controller.params, whose other keys are the WBC's); they are read by read_estimator_params /
// read_trot_params / read_push_stepping.
enum class WithControllerParts : bool { no, yes };
wbc::WbcParams read_wbc_params(const yaml::Field& f, WithControllerParts parts = WithControllerParts::no);
est::EstimatorParams read_estimator_params(const yaml::Field& f);
enum class WithVelocitySchedule : bool { no, yes };
gait::TrotParams read_trot_params(const yaml::Field& f, WithVelocitySchedule schedule = WithVelocitySchedule::no);
// A walking velocity `[v_x, v_y, yaw_rate]` (a list of 3, each within its kTrotFields range)
// into p's velocity_x / velocity_y / yaw_rate; false (and an error) when `f` is not such a list.
bool read_walking_velocity(const yaml::Field& f, gait::TrotParams& p);
control::PushStepping read_push_stepping(const yaml::Field& f);

}  // namespace springbok::params
