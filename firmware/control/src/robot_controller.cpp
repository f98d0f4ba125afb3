#include "springbok/control/robot_controller.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include <Eigen/Geometry>

namespace springbok::control {

const char* to_string(GaitKind kind) noexcept {
  switch (kind) {
    case GaitKind::stand: return "stand";
    case GaitKind::trot: return "trot";
  }
  return "?";
}

const char* to_string(TickStatus status) noexcept {
  switch (status) {
    case TickStatus::ok: return "ok";
    case TickStatus::estimate_failed: return "estimate_failed";
    case TickStatus::qp_failed: return "qp_failed";
  }
  return "?";
}

const char* to_string(GaitState state) noexcept {
  switch (state) {
    case GaitState::stand: return "stand";
    case GaitState::trot: return "trot";
    case GaitState::stopping: return "stopping";
  }
  return "?";
}

Vec3 center_of_mass_from_inertia(const MatNv& mass_matrix, const RobotState& state) noexcept {
  const double mass_kg = mass_matrix(0, 0);
  const Vec3 com_b(-mass_matrix(2, 4) / mass_kg, -mass_matrix(0, 5) / mass_kg, -mass_matrix(1, 3) / mass_kg);
  return state.q.head<3>() + state.rotation_wb * com_b;
}

RobotController::RobotController(const ControlParams& params)
    : params_(params),
      data_(std::make_unique<dyn::Data>()),
      estimator_(params.estimator),
      wbc_(std::make_unique<wbc::WholeBodyController>(params.wbc)),
      trot_(params.gait.trot),
      requested_gait_(params.gait) {
  tare_.running = params_.tare_samples > 0;
}

RobotController::~RobotController() = default;

est::EstimateStatus RobotController::estimate(const hal::Measurements& m, double dt_s, const Stance& stance) noexcept {
  const bool continuous = have_sequence_ && m.sequence == last_sequence_ + 1;
  have_sequence_ = true;
  last_sequence_ = m.sequence;
  if (!continuous || estimator_.estimate().status == est::EstimateStatus::not_reset) {
    return estimator_.reset(m, stance, start_xy_m_);
  }
  return estimator_.update(m, stance, dt_s).status;
}

// The tick's wrist wrench: the reading minus the tare, zero when not valid; the
// tare collects while `collect`. rt: no alloc
void RobotController::take_wrist(const hal::Measurements& m, bool collect) noexcept {
  const bool valid = m.wrist.valid && m.wrist.force_n.allFinite() && m.wrist.torque_nm.allFinite();
  if (valid && collect && tare_.running) {
    tare_force_sum_n_ += m.wrist.force_n;
    tare_torque_sum_nm_ += m.wrist.torque_nm;
    if (++tare_.samples >= params_.tare_samples) {
      tare_.force_n = tare_force_sum_n_ / static_cast<double>(tare_.samples);
      tare_.torque_nm = tare_torque_sum_nm_ / static_cast<double>(tare_.samples);
      tare_.running = false;
      ++tare_.completed;
    }
  }
  wrist_force_n_ = valid ? Vec3(m.wrist.force_n - tare_.force_n) : Vec3::Zero();
  wrist_torque_nm_ = valid ? Vec3(m.wrist.torque_nm - tare_.torque_nm) : Vec3::Zero();
}

bool RobotController::request_velocity(const Vec3& velocity) noexcept {
  gait::TrotParams p = requested_gait_.trot;
  p.velocity_x_m_s = velocity.x();
  p.velocity_y_m_s = velocity.y();
  p.yaw_rate_rad_s = velocity.z();
  if (gait::trot_params_error(p) != nullptr) return false;
  requested_gait_.trot = p;
  velocity_command_ = velocity;
  return true;
}

namespace {
double toward(double now, double target, double step) noexcept {
  return now + std::clamp(target - now, -step, step);
}
}  // namespace

// The rest pose's planar motion this tick: the walking velocity ramped towards the
// command (zero unless trotting), integrated in the heading of the rest pose. rt: no alloc
void RobotController::move_rest_pose(double dt_s) noexcept {
  const Vec3 target = gait_state_ == GaitState::trot ? velocity_command_ : Vec3::Zero();
  velocity_now_.x() = toward(velocity_now_.x(), target.x(), kWalkAcceleration_m_s2 * dt_s);
  velocity_now_.y() = toward(velocity_now_.y(), target.y(), kWalkAcceleration_m_s2 * dt_s);
  velocity_now_.z() = toward(velocity_now_.z(), target.z(), kWalkYawAcceleration_rad_s2 * dt_s);
  motion_.yaw_acceleration_rad_s2 = (velocity_now_.z() - motion_.yaw_rate_rad_s) / dt_s;
  motion_.yaw_rate_rad_s = velocity_now_.z();
  motion_.yaw_rad += velocity_now_.z() * dt_s;
  const Mat3& engaged = wbc_->engaged_reference().base_rotation;
  const double heading = std::atan2(engaged(1, 0), engaged(0, 0)) + motion_.yaw_rad;
  const Vec3 velocity_world =
      Eigen::AngleAxisd(heading, Vec3::UnitZ()) * Vec3(velocity_now_.x(), velocity_now_.y(), 0.0);
  motion_.acceleration_m_s2 = (velocity_world - motion_.velocity_m_s) / dt_s;
  motion_.velocity_m_s = velocity_world;
  motion_.offset_m += velocity_world * dt_s;
  const HandSample hand = hand_.at(control_time_s_);
  motion_.hand_offset_m = hand.offset_m;
  motion_.hand_velocity_m_s = hand.velocity_m_s;
  motion_.hand_acceleration_m_s2 = hand.acceleration_m_s2;
  motion_.hand_rotation_rad = hand.rotation_rad;
  motion_.hand_rotation_rate_rad_s = hand.rotation_rate_rad_s;
  motion_.hand_rotation_acceleration_rad_s2 = hand.rotation_acceleration_rad_s2;
  wbc_->move_reference(motion_);
}

void RobotController::request_tare() noexcept {
  tare_.running = params_.tare_samples > 0;
  tare_.samples = 0;
  tare_force_sum_n_.setZero();
  tare_torque_sum_nm_.setZero();
}

bool RobotController::request_gait(const GaitCommand& command) noexcept {
  if (command.kind == GaitKind::trot && gait::trot_params_error(command.trot) != nullptr) return false;
  requested_gait_ = command;
  gait_request_pending_ = true;
  return true;
}

void RobotController::observe(const hal::Measurements& m, double dt_s, bool standing_still) noexcept {
  (void)estimate(m, dt_s, kAllFeet);
  state_.stance = kAllFeet;
  take_wrist(m, standing_still);
  (void)report_tick(report_.status, false);
}

void RobotController::calibrate(const hal::Measurements& m, double dt_s) noexcept {
  estimator_.calibrate(m, dt_s);
  report_gyro_bias();
}

void RobotController::report_gyro_bias() noexcept {
  report_.gyro_bias_i_rad_s = estimator_.ekf().started() ? estimator_.ekf().gyro_bias_i_rad_s()
                                                         : estimator_.calibrated_gyro_bias_i_rad_s();
  report_.gyro_calibrated_s = estimator_.gyro_calibrated() ? estimator_.calibrated_time_s() : 0.0;
}

TickStatus RobotController::report_tick(TickStatus status, bool control_tick) noexcept {
  TickReport& r = report_;
  if (control_tick) r.status = status;
  r.engaged = engaged_;
  r.gait = gait_state_;
  r.stepping_for_push = stepping_for_push_;
  r.trot = trot_.params();
  r.stance = state_.stance;
  r.failed_ticks = failed_ticks_;
  r.stance_changes = stance_changes_;
  r.tare = tare_;
  r.wrist_force_n = wrist_force_n_;
  const est::BaseEstimate& e = estimator_.estimate();
  r.base_pose = e.q.head<7>();
  r.base_twist = e.v.head<6>();
  report_gyro_bias();
  if (control_tick && status != TickStatus::estimate_failed) {  // the WBC ran
    const wbc::WbcOutput& o = wbc_->output();
    const wbc::WbcReference& ref = wbc_->reference();
    r.qp_status = o.qp_status;
    r.qp_iterations = o.qp_iterations;
    r.arm_overloaded = o.arm_overloaded;
    r.support_limited = o.support_limited;
    r.base_rest_m = ref.base_position_m;
    r.hand_rest_m = ref.ee_position_m;
    r.hand_rest_rotation = ref.ee_rotation;
    r.base_displacement_m = o.base_displacement_m;
    r.hand_displacement_m = o.ee_displacement_m;
    r.hand_rotation = o.ee_rotation;
    r.external_force_world_n = o.external_force_world_n;
    r.external_torque_world_nm = o.external_torque_world_nm;
    r.unmeasured_force_world_n = input_.unmeasured_force_world_n;
    r.foot_force_n = o.foot_force_n;
  }
  return status;
}

// The shift of the trot's footholds (frame H; data_ holds this tick's kinematics)
// that puts their pattern's centre on the ground (the stance feet's height) under
// the static ZMP of the weight and the wrist's wrench. rt: no alloc
Vec3 RobotController::footholds_shift_h(const Mat3& yaw) const noexcept {
  const dyn::Data& d = *data_;
  double feet_z_m = 0.0;
  int stance_feet = 0;
  for (int f = 0; f < kFeet; ++f) {
    if (!state_.stance[f]) continue;
    feet_z_m += d.frames[kFootFrames[f]].translation.z();
    ++stance_feet;
  }
  if (stance_feet == 0) return Vec3::Zero();
  feet_z_m /= stance_feet;
  const dyn::Placement& wrist = d.frames[kWristFtFrame];
  const Vec3 com = center_of_mass_from_inertia(d.M, state_);
  // The unmeasured pushes less kUnmeasuredForceDeadband_n of their magnitude: the footholds
  // move on every tick, and the estimate's own error is no push.
  const Vec3& unmeasured = input_.unmeasured_force_world_n;
  const double magnitude = unmeasured.norm();
  const Vec3 push = magnitude > kUnmeasuredForceDeadband_n ? Vec3((1.0 - kUnmeasuredForceDeadband_n / magnitude) * unmeasured)
                                                           : Vec3::Zero();
  Vec3 centre = dyn::static_zmp(com, model_.total_mass_kg * kGravity_m_s2, wrist.translation,
                                 input_.wrist_force_world_n, input_.wrist_torque_world_nm, feet_z_m - kFootRadius_m, push);
  centre.z() = feet_z_m;
  if (!centre.allFinite()) return Vec3::Zero();
  return yaw.transpose() * (centre - state_.q.head<3>()) - trot_.nominal_centre_h();
}

// The pushes the wrist sensor does not measure: the robot's external force but gravity, less
// the feet's and the hand's, low-passed over kUnmeasuredForceFilter_s. rt: no alloc
void RobotController::observe_unmeasured_force(double dt_s, bool engaging) noexcept {
  Vec3& estimate = input_.unmeasured_force_world_n;
  if (engaging || !foot_forces_.ready()) {
    estimate.setZero();
    return;
  }
  Vec3 force = foot_forces_.external_force_world_n() - input_.wrist_force_world_n;
  for (int f = 0; f < kFeet; ++f) force -= foot_forces_.force_world_n()[f];
  if (!force.allFinite()) return;
  const double alpha = dt_s / (kUnmeasuredForceFilter_s + dt_s);
  estimate += alpha * (force - estimate);
}

// PushStepping, standing: for delay_s the support limit's centre of pressure or its capture
// point (the WBC's, last tick) has been closer than trigger_inside_m to the feet's edge (or
// past it), a foot's normal force (the QP's) within unloaded_within_n of its minimum, or a leg
// joint's torque at leg_torque_ratio of its limit at its angle (the WBC's scaled one). Only
// while the limit has settled on the stance (its distance computed: not right after a stance
// change). rt: no alloc
bool RobotController::push_needs_a_step(double dt_s) noexcept {
  const PushStepping& p = params_.push_stepping;
  const wbc::WbcOutput& o = wbc_->output();
  double least_normal_n = std::numeric_limits<double>::infinity();
  for (int f = 0; f < kFeet; ++f) least_normal_n = std::min(least_normal_n, o.foot_force_n[f].z());
  double leg_torque_ratio = 0.0;  // of what the QP may use
  for (int j = 0; j < kFirstArmJoint; ++j) {
    leg_torque_ratio = std::max(leg_torque_ratio,
                                std::abs(o.tau_nm[j]) / (params_.wbc.torque_limit_scale * o.torque_limit_nm[j]));
  }
  const bool near_edge =
      std::isfinite(o.support_distance_m) &&
      (o.support_distance_m < p.trigger_inside_m || o.capture_distance_m < p.trigger_inside_m ||
       least_normal_n < params_.wbc.normal_force_min_n + p.unloaded_within_n ||
       leg_torque_ratio >= p.leg_torque_ratio);
  push_near_edge_s_ = p.enabled && near_edge ? push_near_edge_s_ + dt_s : 0.0;
  if (!(push_near_edge_s_ >= p.delay_s)) return false;
  push_near_edge_s_ = 0.0;
  push_settled_s_ = 0.0;
  return true;
}

// PushStepping, trotting for a push: for settle_s the trunk has stayed within settle_drift_m
// (horizontally) and the push (the unmeasured one and the wrist's) within settle_push_change_n
// of where they were when that interval began (the trot's own sway is no drift). rt: no alloc
bool RobotController::push_settled(double dt_s) noexcept {
  const PushStepping& p = params_.push_stepping;
  const Vec3 push = input_.unmeasured_force_world_n + input_.wrist_force_world_n;
  const Vec3& base = state_.q.head<3>();
  if (push_settled_s_ == 0.0 || !((base - base_at_settle_m_).head<2>().norm() < p.settle_drift_m) ||
      !((push - push_at_settle_n_).head<2>().norm() < p.settle_push_change_n)) {
    push_settled_s_ = dt_s;  // a new interval from this tick
    push_at_settle_n_ = push;
    base_at_settle_m_ = base;
    return false;
  }
  push_settled_s_ += dt_s;
  return push_settled_s_ >= p.settle_s;
}

// A trot with `p` from this tick on (its cycle starts from the feet where they stand). rt: no alloc
void RobotController::begin_trot(const gait::TrotParams& p) noexcept {
  trot_ = gait::TrotGait(p);
  velocity_command_ = Vec3(p.velocity_x_m_s, p.velocity_y_m_s, p.yaw_rate_rad_s);
  gait_state_ = GaitState::trot;
  gait_time_s_ = 0.0;
}

// Stance set and swing targets for this tick (data_ holds its kinematics). rt: no alloc
void RobotController::plan_gait(double dt_s, bool engaging) noexcept {
  if (engaging) {
    gait_state_ = GaitState::stand;
    gait_request_pending_ = requested_gait_.kind == GaitKind::trot;
    motion_ = wbc::PlanarMotion{};
    velocity_now_.setZero();
    velocity_command_.setZero();
  }
  bool start_trot = false;
  if (gait_request_pending_ || engaging) stepping_for_push_ = false;  // the operator's gait from now on
  if (gait_request_pending_) {
    if (gait_state_ == GaitState::trot) {
      gait_state_ = GaitState::stopping;  // to stand, or to restart with new parameters once stood
    }
    if (requested_gait_.kind == GaitKind::stand) {
      gait_request_pending_ = false;
    } else if (gait_state_ == GaitState::stand) {
      begin_trot(requested_gait_.trot);
      start_trot = true;
      gait_request_pending_ = false;
    }
  }
  const bool standing = gait_state_ == GaitState::stand && !start_trot && !engaging;
  if (!standing) push_near_edge_s_ = 0.0;
  if (standing && push_needs_a_step(dt_s)) {
    gait::TrotParams in_place = params_.gait.trot;
    in_place.velocity_x_m_s = in_place.velocity_y_m_s = in_place.yaw_rate_rad_s = 0.0;
    in_place.velocity_gain_s = std::max(in_place.velocity_gain_s, params_.push_stepping.velocity_gain_s);
    begin_trot(in_place);
    start_trot = true;
    stepping_for_push_ = true;
  } else if (stepping_for_push_ && gait_state_ == GaitState::trot && push_settled(dt_s)) {
    gait_state_ = GaitState::stopping;
  }
  move_rest_pose(dt_s);
  Stance stance = kAllFeet;
  input_.normal_force_cap_n.fill(gait::kNoCap);
  if (gait_state_ != GaitState::stand) {
    if (!start_trot) gait_time_s_ += dt_s;
    // Feet relative to the trunk in its horizontal frame H (yaw axes); the trunk's
    // tilt maps the references to trunk axes.
    const Mat3& rot = state_.rotation_wb;
    const Mat3 yaw = Eigen::AngleAxisd(std::atan2(rot(1, 0), rot(0, 0)), Vec3::UnitZ()).toRotationMatrix();
    const Mat3 tilt = yaw.transpose() * rot;
    std::array<Vec3, kFeet> feet_h;
    for (int f = 0; f < kFeet; ++f) {
      feet_h[f] = yaw.transpose() * (data_->frames[kFootFrames[f]].translation - state_.q.head<3>());
    }
    if (start_trot) trot_.start(feet_h);
    const double yaw_rate_rad_s = (rot * state_.v.segment<3>(3)).z();
    gait::ContactSense sense;
    sense.valid = foot_forces_.ready();
    for (int f = 0; f < kFeet; ++f) sense.normal_force_n[f] = foot_forces_.force_world_n()[f].z();
    const gait::ContactPlan& plan = trot_.update(gait_time_s_, feet_h, tilt * state_.v.head<3>(), footholds_shift_h(yaw),
                                                 tilt, Vec3(velocity_now_.x(), velocity_now_.y(), 0.0), yaw_rate_rad_s,
                                                 &sense);
    bool all_down = true;
    for (int f = 0; f < kFeet; ++f) {
      // Stopping: a foot on the ground stays there (at full force), a swinging one lands by the plan.
      const bool kept = gait_state_ == GaitState::stopping && state_.stance[f];
      stance[f] = plan.stance[f] || kept;
      input_.normal_force_cap_n[f] = kept ? gait::kNoCap : plan.normal_force_cap_n[f];
      all_down = all_down && stance[f];
      input_.swing[f].position_m = plan.swing[f].position_m;
      input_.swing[f].velocity_m_s = plan.swing[f].velocity_m_s;
      input_.swing[f].acceleration_m_s2 = plan.swing[f].acceleration_m_s2;
    }
    if (gait_state_ == GaitState::stopping && all_down) gait_state_ = GaitState::stand;
  }
  if (gait_state_ == GaitState::stand) stepping_for_push_ = false;
  for (int f = 0; f < kFeet; ++f) stance_changes_ += stance[f] != state_.stance[f] ? 1 : 0;
  state_.stance = stance;
}

std::string RobotController::set_hand_trajectory(std::span<const HandWaypoint> waypoints) {
  HandTrajectory path;
  if (std::string why = path.set_waypoints(waypoints); !why.empty()) return why;
  if (path.turns() && !params_.wbc.rotational_template_enabled) {
    return "turning the hand needs the rotational template (rotational_template), which renders about its orientation";
  }
  configured_hand_ = path;
  return "";
}

const char* RobotController::request_hand_move(const Vec3& target_m, const Vec3& target_rotation_rad,
                                                double duration_s) noexcept {
  if (!engaged_) return "hand moves need the controller engaged (mode control)";
  if (target_rotation_rad != Vec3::Zero() && !params_.wbc.rotational_template_enabled) {
    return "turning the hand needs the rotational template (control.wbc.rotational_template)";
  }
  return hand_.move_to(control_time_s_, target_m, target_rotation_rad, duration_s);
}

const char* RobotController::request_tuning(const TuningRequest& r) noexcept {
  const auto within = [](double v, const TuningRange& range) { return v >= range.lo && v <= range.hi; };  // NaN: false
  for (int p = 0; p < TuningRequest::kParts; ++p) {
    if (!r.set[static_cast<std::size_t>(p)]) continue;
    if (p >= TuningRequest::kTranslationalParts && !params_.wbc.rotational_template_enabled) {
      return "the rotational template is off (control.wbc.rotational_template)";
    }
    for (double v : r.value[static_cast<std::size_t>(p)]) {
      if (!within(v, kTemplateRanges[static_cast<std::size_t>(p)])) return "tuning values out of range";
    }
  }
  if ((r.set_posture_kp && !within(r.posture_kp_per_s2, kPostureKpRange)) ||
      (r.set_posture_kd && !within(r.posture_kd_per_s, kPostureKdRange)) || !within(r.ramp_s, kTuningRampRange)) {
    return "tuning values out of range";
  }
  tune_.request = r;
  tune_.pending = true;
  return nullptr;
}

// Takes a pending tuning request (the ramp's start: this tick's values) and moves the
// template and the posture gains along the ramp. rt: no alloc
void RobotController::step_tuning(double dt_s) noexcept {
  // The templates' parts in TuningRequest::Part's order: the translational, then the rotational.
  static constexpr std::array<Vec3 wbc::TemplateParams::*, TuningRequest::kTranslationalParts> kPart{
      &wbc::TemplateParams::mass_base_kg,          &wbc::TemplateParams::damping_base_ns_per_m,
      &wbc::TemplateParams::stiffness_base_n_per_m, &wbc::TemplateParams::mass_ee_kg,
      &wbc::TemplateParams::damping_ee_ns_per_m,   &wbc::TemplateParams::stiffness_ee_n_per_m};
  static constexpr std::array<Vec3 wbc::RotationalTemplateParams::*,
                              TuningRequest::kParts - TuningRequest::kTranslationalParts>
      kRotPart{&wbc::RotationalTemplateParams::damping_base_nms_per_rad,
               &wbc::RotationalTemplateParams::stiffness_base_nm_per_rad, &wbc::RotationalTemplateParams::inertia_ee_kgm2,
               &wbc::RotationalTemplateParams::damping_ee_nms_per_rad, &wbc::RotationalTemplateParams::stiffness_ee_nm_per_rad};
  const auto vec = [](const std::array<double, 3>& v) { return Vec3(v[0], v[1], v[2]); };
  if (tune_.pending) {
    tune_.pending = false;
    const TuningRequest& r = tune_.request;
    tune_.from = wbc_->params().template_params;
    tune_.to = tune_.from;
    for (std::size_t i = 0; i < kPart.size(); ++i) {
      if (r.set[i]) tune_.to.*kPart[i] = vec(r.value[i]);
    }
    tune_.rot_from = wbc_->params().rotational_template;
    tune_.rot_to = tune_.rot_from;
    for (std::size_t i = 0; i < kRotPart.size(); ++i) {
      const std::size_t part = TuningRequest::kTranslationalParts + i;
      if (r.set[part]) tune_.rot_to.*kRotPart[i] = vec(r.value[part]);
    }
    tune_.kp_from = wbc_->params().posture_kp_per_s2;
    tune_.kd_from = wbc_->params().posture_kd_per_s;
    tune_.kp_to = r.set_posture_kp ? r.posture_kp_per_s2 : tune_.kp_from;
    tune_.kd_to = r.set_posture_kd ? r.posture_kd_per_s : tune_.kd_from;
    tune_.elapsed_s = 0.0;
    tune_.active = true;
  }
  if (!tune_.active) return;
  tune_.elapsed_s += dt_s;
  const double ramp = tune_.request.ramp_s;
  const double s = ramp > 0.0 ? std::min(1.0, tune_.elapsed_s / ramp) : 1.0;
  wbc::TemplateParams t;
  for (const auto part : kPart) t.*part = tune_.from.*part + s * (tune_.to.*part - tune_.from.*part);
  wbc_->set_template(t);
  wbc::RotationalTemplateParams rt = tune_.rot_from;  // its base inertia stays the engaged one
  for (const auto part : kRotPart) rt.*part = tune_.rot_from.*part + s * (tune_.rot_to.*part - tune_.rot_from.*part);
  wbc_->set_rotational_template(rt);
  wbc_->set_posture_gains(tune_.kp_from + s * (tune_.kp_to - tune_.kp_from),
                          tune_.kd_from + s * (tune_.kd_to - tune_.kd_from));
  if (s >= 1.0) tune_.active = false;
}

TickStatus RobotController::tick(const hal::Measurements& m, double dt_s, hal::JointCommands& cmd,
                                  const BaseTruth* truth) noexcept {
  const est::EstimateStatus estimated = estimate(m, dt_s, state_.stance);  // last tick's stance
  if (truth != nullptr) {
    state_.q.head<7>() = truth->pose;
    state_.q.tail<kNj>() = m.q_rad;
    state_.v.head<6>() = truth->twist;
    state_.v.tail<kNj>() = m.qd_rad_s;
  } else {
    if (estimated != est::EstimateStatus::ok) {
      ++failed_ticks_;
      return report_tick(TickStatus::estimate_failed, true);
    }
    state_.q = estimator_.estimate().q;
    state_.v = estimator_.estimate().v;
  }
  state_.set_rotation_from_q();
  take_wrist(m, false);  // the tare collects in stand only (observe): a push here is not a bias

  const bool engaging = !engaged_;
  if (engaging) {
    control_time_s_ = 0.0;
    hand_ = configured_hand_;
    wbc_->set_reference(state_.q, *data_);  // the template's rest pose: this instant's
    engaged_ = true;
  }
  if (!engaging) control_time_s_ += dt_s;
  step_tuning(dt_s);
  dyn::compute_tick(model_, *data_, state_.q, state_.v);  // the tick's kinematics and dynamics, once
  const Mat3& wrist_rotation = data_->frames[kWristFtFrame].rotation;  // the wrist wrench in world axes, once
  input_.wrist_force_world_n = wrist_rotation * wrist_force_n_;
  input_.wrist_torque_world_nm = wrist_rotation * wrist_torque_nm_;
  if (engaging) foot_forces_.reset();
  foot_forces_.update(*data_, state_.v, state_.rotation_wb, m.tau_nm,
                      params_.wbc.joint_viscous_friction_nms_per_rad.cwiseProduct(state_.v.tail<kNj>()), dt_s);
  observe_unmeasured_force(dt_s, engaging);
  plan_gait(dt_s, engaging);

  const wbc::WbcOutput& o = wbc_->tick(input_, *data_);
  if (o.failed) {
    ++failed_ticks_;
    return report_tick(TickStatus::qp_failed, true);
  }
  cmd.mode = hal::CommandMode::enabled;
  cmd.tau_ff_nm = o.tau_nm;
  cmd.q_des_rad = m.q_rad;
  cmd.qd_des_rad_s.setZero();
  cmd.kp_nm_per_rad.setZero();
  cmd.kd_nms_per_rad.setZero();
  return report_tick(TickStatus::ok, true);
}

}  // namespace springbok::control
