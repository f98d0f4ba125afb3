// The whole-body controller's YAML configuration (start-up only). Schema:
//
//   template:                     # required: the double mass-spring-damper to render
//     base: {mass: 92, damping: 610, stiffness: 1000}   # each a number or [x, y, z]
//     ee:   {mass: 4,  damping: 90,  stiffness: 500}
//   base_orientation: {kp: 1600, kd: 160, inertia: auto}  # inertia: auto or [Ixx, Iyy, Izz]
//   arm: {posture_kp: 100, posture_kd: 20, posture: current, pinv_lambda0: 0.05,
//         manipulability_threshold: 0.02}                # posture: current or 7 angles
//   weights: {base_force: 1, base_torque: 1, arm: 100, reg_acceleration: 1e-4,
//             reg_force: 1e-6, reg_slack: 1000}
//   contact: {friction_mu: 0.6, normal_force_min: 5, normal_force_max: 1500,
//             foot_radius: 0.02175}     # foot Jacobians at the ground contact point (0: centre)
//   limits: {joint_horizon_s: 0.05, torque_scale: 1.0}
//   swing: {kp: 400, kd: 40}
//
// (No fallback section: what a failed tick commands is the safety supervisor's.)
// Everything but `template` is optional (defaults of WbcParams). Masses and
// stiffnesses must be positive, dampings non-negative; unknown keys, wrong
// types and non-finite numbers are errors naming the field.
#pragma once

#include "springbok/config/fields.hpp"
#include "springbok/wbc/whole_body_controller.hpp"

namespace springbok::wbc {

// Throws config::ConfigError naming the bad field.
WbcParams read_wbc_params(const config::Fields& fields);

}  // namespace springbok::wbc
