#include "wbc_adapter.hpp"

#include <algorithm>
#include <charconv>
#include <chrono>
#include <cmath>
#include <numbers>

#include <sys/resource.h>

#include <Eigen/Dense>
#include <fmt/format.h>

#include "springbok/params/controller_params.hpp"

namespace springbok::simtool {
namespace {

constexpr int kScoredAxes = 12;
constexpr const char* kAxisKeys[kScoredAxes] = {"base_x",  "base_y",  "base_z",  "ee_x",  "ee_y",  "ee_z",
                                                "base_rx", "base_ry", "base_rz", "ee_rx", "ee_ry", "ee_rz"};
constexpr const char* kFootNames[kFeet] = {"lf", "rf", "lh", "rh"};
// A joint is "at its torque limit" from this fraction of it on.
constexpr double kAtLimit = 0.99;

// An axis is scored only if the template's peak-to-peak there exceeds this
// fraction of the largest peak-to-peak over the six axes (else `null`).
constexpr double kMovingAxisFraction = 0.05;

void put(std::string& out, double value) {
  char buf[32];
  const auto r = std::to_chars(buf, buf + sizeof buf, value, std::chars_format::general, 9);
  out.push_back(',');
  out.append(buf, r.ptr);
}

std::string json_number_or_null(const std::optional<double>& v) {
  return v && std::isfinite(*v) ? fmt::format("{:.6g}", *v) : std::string("null");
}

std::string json_axes(const std::array<std::optional<double>, kScoredAxes>& values) {
  std::string s = "{";
  for (int a = 0; a < kScoredAxes; ++a) s += fmt::format("{}\"{}\": {}", a ? ", " : "", kAxisKeys[a], json_number_or_null(values[a]));
  return s + "}";
}

double chirp_phase_rad(const sim::ForceProfile& p, double t_s) {
  const double tau = t_s - p.start_s;
  return 2.0 * std::numbers::pi *
         (p.start_frequency_hz * tau + (p.end_frequency_hz - p.start_frequency_hz) * tau * tau / (2.0 * p.duration_s));
}

// Amplitude of the component of y at the chirp's phase: least squares y ~ a sin(phi) + b cos(phi) + c.
double fitted_amplitude(const std::vector<double>& y, const std::vector<double>& phase) {
  Eigen::MatrixXd a(static_cast<Eigen::Index>(y.size()), 3);
  Eigen::VectorXd b(static_cast<Eigen::Index>(y.size()));
  for (std::size_t i = 0; i < y.size(); ++i) {
    a.row(static_cast<Eigen::Index>(i)) << std::sin(phase[i]), std::cos(phase[i]), 1.0;
    b[static_cast<Eigen::Index>(i)] = y[i];
  }
  const Eigen::Vector3d x = a.colPivHouseholderQr().solve(b);
  return std::hypot(x[0], x[1]);
}

double percentile(std::vector<double> v, double fraction) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  const auto i = static_cast<std::size_t>(std::ceil(fraction * static_cast<double>(v.size()))) ;
  return v[std::min(v.size() - 1, i == 0 ? 0 : i - 1)];
}

}  // namespace

WbcAdapter::WbcAdapter(const Scenario& s, const yaml::Field& params, sim::BulletRobot& robot)
    : dt_s_(s.sim.step_s), settle_s_(s.controller_settle_s), still_start_s_(s.controller_still_start_s),
      idle_columns_(static_cast<int>(std::ranges::count(csv_columns(), ','))),
      data_(std::make_unique<dyn::Data>()) {
  control::ControlParams& cp = config_.control;  // the firmware's controller, as the scenario sets it
  // `estimator`, `gait` and `push_stepping` are the controller's own parts, every other key the WBC's.
  // state_source: the base state the controller is given, the estimator's (from the simulated
  // sensors) or the simulator's truth; without it, the estimator's when the scenario configures
  // one (`estimator`), else the truth. The estimator runs either way, and its errors are scored.
  if (params["estimator"].present()) cp.estimator = params::read_estimator_params(params["estimator"]);
  use_estimator_ = params["estimator"].present();
  if (int source = 0; params["state_source"].choice(source, {"truth", "estimated"})) use_estimator_ = source == 1;
  if (params["push_stepping"].present()) cp.push_stepping = params::read_push_stepping(params["push_stepping"]);
  if (params["gait"].present()) {
    cp.gait.kind = control::GaitKind::trot;
    cp.gait.trot = params::read_trot_params(params["gait"], params::WithVelocitySchedule::yes);
    trot_ = true;
    // velocity_schedule: [{at_s, velocity: [v_x, v_y, yaw_rate]} or {at_s, gait: stand | trot}, ...],
    // times increasing: the operator's walk and gait requests (a trot resumed in place, with the
    // scenario's gait parameters).
    const yaml::Field list = params["gait"]["velocity_schedule"];
    if (list.present() && list.expect_list()) {
      for (std::size_t i = 0; i < list.size(); ++i) {
        const yaml::Field e = list[i];
        if (!e.allow_only({"at_s", "velocity", "gait"})) continue;
        ScheduledRequest change{0.0, {}};
        if (e["at_s"].require()) e["at_s"].number(change.at_s, 0.0, 1e6);  // as hand_trajectory's: no default
        if (e["velocity"].present() == e["gait"].present()) {
          e.fail("needs velocity or gait (one of them)");
        } else if (e["velocity"].present()) {
          gait::TrotParams v = cp.gait.trot;
          (void)params::read_walking_velocity(e["velocity"], v);
          change.request.kind = app::ControllerRequest::Kind::walk;
          change.request.velocity = {v.velocity_x_m_s, v.velocity_y_m_s, v.yaw_rate_rad_s};
        } else if (int kind = 0; e["gait"].choice(kind, {"stand", "trot"})) {
          change.request.kind = app::ControllerRequest::Kind::gait;
          change.request.gait.kind = kind == 0 ? control::GaitKind::stand : control::GaitKind::trot;
          change.request.gait.trot = cp.gait.trot;
          change.request.gait.trot.velocity_x_m_s = change.request.gait.trot.velocity_y_m_s =
              change.request.gait.trot.yaw_rate_rad_s = 0.0;
        }
        if (!velocity_schedule_.empty() && change.at_s <= velocity_schedule_.back().at_s) {
          e["at_s"].fail("must be after the previous change's");
        }
        velocity_schedule_.push_back(change);
      }
    }
  }
  params_ = params::read_wbc_params(params, params::WithControllerParts::yes);
  cp.wbc = params_;
  // The firmware's configuration: the control mode's controller as the scenario sets it; the
  // stand posture is the scenario's initial one (stand-up takes one tick), held with the stand
  // gains and the robot's weight as feed-forward until the operator's `mode control`.
  config_.rate_hz = static_cast<int>(std::lround(1.0 / dt_s_));
  config_.control_mode = app::ControlModeKind::wbc;
  config_.stand_posture_rad = s.sim.initial_q.tail<kNj>();
  config_.stand_up_duration_s = dt_s_;
  config_.stand_weight_feed_forward = true;
  const wbc::StandGains stand;
  config_.stand_gains.kp_nm_per_rad.head<kFirstArmJoint>().setConstant(stand.kp_leg_nm_per_rad);
  config_.stand_gains.kd_nms_per_rad.head<kFirstArmJoint>().setConstant(stand.kd_leg_nms_per_rad);
  config_.stand_gains.kp_nm_per_rad.tail<kArmJoints>().setConstant(stand.kp_arm_nm_per_rad);
  config_.stand_gains.kd_nms_per_rad.tail<kArmJoints>().setConstant(stand.kd_arm_nms_per_rad);
  config_.control_gains = config_.stand_gains;
  // The scenario's operator: start, mode control, the velocity schedule's walk requests.
  posted_.reserve(16 + 2 * velocity_schedule_.size());
  refusals_.reserve(16);
  firmware_ = std::make_unique<app::Firmware>(robot, config_, nullptr);
  if (!use_estimator_) firmware_->control().use_base_truth(&base_truth_);
  control::RobotController& control = firmware_->control().controller();
  control.set_start_position_xy(robot.ground_truth().q.head<2>());
  // hand_trajectory: [{at_s, position: [x, y, z], rotation: [rx, ry, rz]}, ...]: the hand's rest
  // point's offset (m) and, optionally, its rest orientation's rotation vector (rad; with the
  // rotational template), both in the rest pose's horizontal frame, at scenario times; the
  // controller counts from its engagement at settle_s.
  if (const yaml::Field list = params["hand_trajectory"]; list.present() && list.expect_list()) {
    std::vector<control::HandWaypoint> waypoints;
    bool ok = true;
    for (std::size_t i = 0; i < list.size(); ++i) {
      const yaml::Field e = list[i];
      if (!e.allow_only({"at_s", "position", "rotation"})) {
        ok = false;
        continue;
      }
      control::HandWaypoint w;
      ok = e["at_s"].require() && e["at_s"].number(w.at_s, 0.0, 1e6) && ok;
      ok = e["position"].require() && e["position"].vector<3>(w.offset_m, -1.0, 1.0) && ok;
      if (e["rotation"].present()) ok = e["rotation"].vector<3>(w.rotation_rad, -4.0, 4.0) && ok;
      w.at_s -= settle_s_;
      waypoints.push_back(w);
    }
    if (ok) {
      if (const std::string why = control.set_hand_trajectory(waypoints); !why.empty()) {
        list.fail(why + " (times from the controller's start at settle_s)");
      }
    }
  }
  template_ = std::make_unique<wbc::TemplateReference>(params_.template_params, dt_s_);
  step_profile_ = !s.wrenches.empty();
  for (const auto& w : s.wrenches) {
    const auto shape = w.wrench.profile.shape;
    if (shape != sim::ProfileShape::step && shape != sim::ProfileShape::constant) step_profile_ = false;
    if (shape == sim::ProfileShape::chirp && !chirp_) {
      chirp_ = w.wrench.profile;
      chirp_axis_ = w.wrench.axis_world;
    }
  }
  const auto ticks = static_cast<std::size_t>(std::llround(s.duration_s / dt_s_)) + 1;
  samples_.reserve(ticks);
  trunk_velocity_h_.reserve(ticks);
  tick_us_all_.reserve(ticks);
  qp_iterations_all_.reserve(ticks);
}

WbcAdapter::~WbcAdapter() = default;

void WbcAdapter::post(const app::OperatorRequest& request) noexcept {
  app::OperatorRequest r = request;
  r.id = posted_.size() + 1;
  if (firmware_->mailbox().requests.push(r) && posted_.size() < posted_.capacity()) posted_.push_back({firmware_ticks_, r});
}

void WbcAdapter::firmware_tick(const sim::GroundTruth& truth) noexcept {
  app::Firmware& fw = *firmware_;
  base_truth_.pose = truth.q.head<7>();
  base_truth_.twist = truth.v.head<6>();
  rt::TickInfo info;
  info.index = firmware_ticks_;
  info.elapsed_ns = std::llround(dt_s_ * 1e9);
  info.scheduled_ns = static_cast<std::int64_t>(firmware_ticks_) * info.elapsed_ns;
  info.wake_ns = info.scheduled_ns;
  fw.loop().tick(info);
  ++firmware_ticks_;
  if (recording_ != nullptr) {
    recording_->push_back({fw.loop().measurements(), fw.loop().commands(), fw.loop().computed_mode()});
  }
  app::OperatorReply reply;
  while (fw.mailbox().replies.pop(reply)) {
    if (!reply.accepted && refusals_.size() < refusals_.capacity()) {
      refusals_.push_back(fmt::format("t = {:.3f} s: request {} refused: {}", truth.time_s, reply.id,
                                      reply.refusal != nullptr ? reply.refusal : "?"));
    }
  }
}

bool WbcAdapter::tick(sim::BulletRobot& robot, std::int64_t k) noexcept {
  const sim::GroundTruth& truth = robot.ground_truth();
  app::Firmware& fw = *firmware_;
  control::RobotController& control = fw.control().controller();
  const double t_s = static_cast<double>(k) * dt_s_;
  const std::uint64_t hal_errors = fw.status().hal_errors.load(std::memory_order_relaxed);
  // The scenario's operator: `start` and the stand-up before the physics starts (the robot
  // starts in the stand posture: its stand-up is done at t = 0, its weight carried from the
  // first step), `mode control` at settle_s (again each tick while the robot stands, as an
  // operator would), the velocity schedule's walks.
  if (k == 0) {
    // The still start-up: idle ticks on the motionless robot (none if it starts moving).
    if (robot.ground_truth().v.isZero(0.0)) {
      const auto still_ticks = static_cast<std::int64_t>(std::llround(still_start_s_ / dt_s_));
      for (std::int64_t i = 0; i < still_ticks; ++i) {
        firmware_tick(truth);
        robot.hold_still();
      }
    }
    app::OperatorRequest start;
    start.command = safety::OperatorCommand::start;
    post(start);
    for (int i = 0; i < kStandUpTicks && fw.supervisor().mode() != safety::Mode::stand; ++i) firmware_tick(truth);
  }
  if (fw.supervisor().mode() == safety::Mode::stand && t_s + 0.5 * dt_s_ >= settle_s_) {
    app::OperatorRequest engage;
    engage.command = safety::OperatorCommand::mode_control;
    post(engage);
  }
  while (next_velocity_change_ < velocity_schedule_.size() &&
         t_s + 0.5 * dt_s_ >= velocity_schedule_[next_velocity_change_].at_s) {
    app::OperatorRequest change;
    change.for_controller = true;
    change.request = velocity_schedule_[next_velocity_change_++].request;
    post(change);
  }
  truth_before_step_pose_ = truth.q.head<7>();
  truth_before_step_v_ = truth.v.head<3>();

  // The thread's page faults and context switches across the tick (read outside the timed
  // span): what made a slow tick slow, told apart from a slow solve.
  rusage before{}, after{};
  getrusage(RUSAGE_THREAD, &before);
  const auto t0 = std::chrono::steady_clock::now();
  firmware_tick(truth);
  tick_us_ = std::chrono::duration<double, std::micro>(std::chrono::steady_clock::now() - t0).count();
  getrusage(RUSAGE_THREAD, &after);
  tick_faults_ = static_cast<int>((after.ru_minflt - before.ru_minflt) + (after.ru_majflt - before.ru_majflt));
  tick_switches_ = static_cast<int>((after.ru_nvcsw - before.ru_nvcsw) + (after.ru_nivcsw - before.ru_nivcsw));

  const safety::Mode previous_mode = tick_mode_;
  tick_mode_ = fw.loop().computed_mode();
  ticked_ = false;
  if (tick_mode_ == safety::Mode::control) {
    if (previous_mode != safety::Mode::control) template_->reset();  // engaged anew
    status_ = control.report().status;
    ticked_ = control.engaged();
    if (ticked_) {
      template_->step(control.output().external_force_world_n);
      if (params_.rotational_template_enabled) {
        if (!rotational_template_) {
          rotational_template_.emplace(
              wbc::template_axes(params_.rotational_template, control.wbc().base_rotational_inertia_kgm2()), dt_s_);
        }
        rotational_template_->step(control.output().external_torque_world_nm);
      }
    }
  }
  return fw.status().hal_errors.load(std::memory_order_relaxed) == hal_errors;
}

std::string WbcAdapter::csv_columns() const {
  std::string h = ",wbc_active";
  for (const char* a : {"x", "y", "z"}) h += fmt::format(",base_d{}_m", a);
  for (const char* a : {"x", "y", "z"}) h += fmt::format(",ee_d{}_m", a);
  for (const char* a : {"x", "y", "z"}) h += fmt::format(",template_base_{}_m", a);
  for (const char* a : {"x", "y", "z"}) h += fmt::format(",template_ee_{}_m", a);
  for (const char* a : {"x", "y", "z"}) h += fmt::format(",fe_{}_n", a);
  for (const char* f : kFootNames) {
    for (const char* a : {"x", "y", "z"}) h += fmt::format(",{}_f{}_n", f, a);
  }
  h += ",qp_status,qp_iterations,qp_from_hint,tick_failed,manipulability,tick_us,tick_page_faults,tick_context_switches";
  for (const char* b : {"base", "ee"}) {
    for (const char* a : {"x", "y", "z"}) h += fmt::format(",{}_r{}_rad", b, a);
  }
  for (const char* w : {"desired", "applied"}) {
    for (const char* a : {"x", "y", "z"}) h += fmt::format(",base_wrench_{}_f{}_n", w, a);
    for (const char* a : {"x", "y", "z"}) h += fmt::format(",base_wrench_{}_t{}_nm", w, a);
  }
  for (const char* f : kFootNames) h += fmt::format(",{}_fz_estimated_n", f);
  for (const char* f : kFootNames) h += fmt::format(",{}_stance", f);
  for (const char* f : kFootNames) h += fmt::format(",{}_fz_cap_n", f);
  for (const char* a : {"x", "y", "z"}) h += fmt::format(",hand_rest_d{}_m", a);
  for (const char* b : {"base", "ee"}) {
    for (const char* a : {"x", "y", "z"}) h += fmt::format(",template_{}_r{}_rad", b, a);
  }
  for (const char* a : {"x", "y", "z"}) h += fmt::format(",te_{}_nm", a);
  for (const char* a : {"x", "y", "z"}) h += fmt::format(",hand_rest_r{}_rad", a);
  h += ",arm_reference_saturated,arm_overloaded,hand_coupling_limited,support_limited,support_distance_m,capture_distance_m";
  for (const char* a : {"x", "y", "z"}) h += fmt::format(",unmeasured_f{}_n", a);
  h += ",stepping_for_push,estimate_velocity_error_m_s,estimate_tilt_error_rad,estimate_yaw_drift_rad";
  return h;
}

void WbcAdapter::after_step(const sim::GroundTruth& truth, std::string& row) {
  if (!ticked_) {
    for (int i = 0; i < idle_columns_; ++i) row += ",0";  // wbc_active 0, and zeros in the WBC's columns
    return;
  }
  const wbc::WbcOutput& o = controller().output();
  dyn::forward_kinematics(model_, *data_, truth.q);
  const wbc::WbcReference& ref = controller().wbc().reference();
  Sample s{};
  s.time_s = truth.time_s;
  const Vec3 base_d = truth.q.head<3>() - ref.base_position_m;
  const Vec3 ee_d = data_->frames[kEeFrame].translation - ref.ee_position_m;
  const Vec3 tb = template_->base_m(), te = template_->ee_m();
  for (int a = 0; a < 3; ++a) {
    s.measured[a] = base_d[a];
    s.measured[3 + a] = ee_d[a];
    s.reference[a] = tb[a];
    s.reference[3 + a] = te[a];
  }
  s.force_world_n = o.external_force_world_n;
  {
    // From the rest pose's orientations: the base's (it turns when walking) and the hand's (it
    // turns with it, and with a hand pose command).
    const Mat3 rot = Quat(truth.q[6], truth.q[3], truth.q[4], truth.q[5]).normalized().toRotationMatrix();
    const Vec3 rb = wbc::so3_log(rot * ref.base_rotation.transpose());
    const Vec3 re = wbc::so3_log(data_->frames[kEeFrame].rotation * ref.ee_rotation.transpose());
    const Vec3 tb_r = rotational_template_ ? rotational_template_->base_m() : Vec3::Zero();
    const Vec3 te_r = rotational_template_ ? rotational_template_->ee_m() : Vec3::Zero();
    for (int a = 0; a < 3; ++a) {
      s.measured[6 + a] = rb[a];
      s.measured[9 + a] = re[a];
      s.reference[6 + a] = tb_r[a];
      s.reference[9 + a] = te_r[a];
    }
  }
  s.torque_world_nm = o.external_torque_world_nm;
  s.base_wrench_error = o.base_wrench_desired - o.base_wrench_applied;
  samples_.push_back(s);
  {
    const Mat3 rot = Quat(truth.q[6], truth.q[3], truth.q[4], truth.q[5]).normalized().toRotationMatrix();
    const Mat3 yaw = Eigen::AngleAxisd(std::atan2(rot(1, 0), rot(0, 0)), Vec3::UnitZ()).toRotationMatrix();
    const Vec3 v_h = yaw.transpose() * (rot * truth.v.head<3>());
    trunk_velocity_h_.push_back(Vec3(v_h.x(), v_h.y(), (rot * truth.v.segment<3>(3)).z()));
  }
  {  // this tick's estimate vs the truth of that tick (before the step)
    const est::BaseEstimate& e = controller().estimate();
    estimator_errors_.add(e.q.head<7>(), e.v.head<3>(), truth_before_step_pose_, truth_before_step_v_,
                          e.status == est::EstimateStatus::ok, dt_s_);
  }
  if (tick_us_ > slowest_.tick_us) {
    slowest_ = {tick_us_, truth.time_s, tick_faults_, tick_switches_, o.qp_iterations, o.qp_from_hint, tick_us_all_.empty()};
  }
  tick_us_all_.push_back(tick_us_);
  qp_iterations_all_.push_back(o.qp_iterations);
  const bool failed = status_ != control::TickStatus::ok;
  if (failed) ++failed_ticks_;
  if (o.qp_from_hint) ++qp_from_hint_ticks_;
  bool at_limit = false;
  for (int j = 0; j < kNj; ++j) {
    const auto& lim = robot::kJoints[j].limits;
    const double torque_ratio = std::abs(truth.tau_applied_nm[j]) / truth.tau_limit_nm[j];
    max_torque_ratio_ = std::max(max_torque_ratio_, torque_ratio);
    if (torque_ratio >= kAtLimit) {
      ++torque_limit_ticks_[static_cast<std::size_t>(j)];
      at_limit = true;
    }
    const double speed_ratio = std::abs(truth.v[6 + j]) / lim.velocity_rad_s;
    if (speed_ratio > max_speed_ratio_) {
      max_speed_ratio_ = speed_ratio;
      max_speed_joint_ = j;
    }
    const double q = truth.q[7 + j];
    if (lim.bounded && !joint_limit_hit_ && (q <= lim.lower_rad + 1e-3 || q >= lim.upper_rad - 1e-3)) {
      joint_limit_hit_ = true;
      joint_limit_joint_ = robot::kJoints[j].name;
    }
  }

  if (at_limit) ++any_torque_limit_ticks_;
  if (o.arm_overloaded) ++arm_overloaded_ticks_;
  if (o.support_limited) ++support_limited_ticks_;
  if (controller().stepping_for_push()) {
    ++push_stepping_ticks_;
    if (!was_stepping_for_push_) ++push_steppings_;
  }
  was_stepping_for_push_ = controller().stepping_for_push();

  row += ",1";
  for (int a = 0; a < 6; ++a) put(row, s.measured[a]);
  for (int a = 0; a < 6; ++a) put(row, s.reference[a]);
  for (int a = 0; a < 3; ++a) put(row, s.force_world_n[a]);
  for (const Vec3& f : truth.foot_force_n) {
    for (int a = 0; a < 3; ++a) put(row, f[a]);
  }
  row += ",";
  row += qp::to_string(o.qp_status);
  put(row, o.qp_iterations);
  row += o.qp_from_hint ? ",1" : ",0";
  row += failed ? ",1" : ",0";
  put(row, o.manipulability);
  put(row, tick_us_);
  put(row, tick_faults_);
  put(row, tick_switches_);
  for (int a = 6; a < 12; ++a) put(row, s.measured[a]);
  for (double v : o.base_wrench_desired) put(row, v);
  for (double v : o.base_wrench_applied) put(row, v);
  for (const Vec3& f : controller().foot_force_estimate_n()) put(row, f.z());
  for (bool c : controller().state().stance) row += c ? ",1" : ",0";
  for (double v : controller().input().normal_force_cap_n) put(row, std::isfinite(v) ? v : -1.0);  // -1: no cap
  // The hand's rest point from the engaged one (it moves with hand_trajectory and walking).
  const Vec3 rest_d = ref.ee_position_m - controller().wbc().engaged_reference().ee_position_m;
  for (int a = 0; a < 3; ++a) put(row, rest_d[a]);
  for (int a = 6; a < 12; ++a) put(row, s.reference[a]);
  for (int a = 0; a < 3; ++a) put(row, s.torque_world_nm[a]);
  // The hand's rest orientation from the engaged one (world; it turns with a hand pose command).
  const Vec3 rest_r = wbc::so3_log(ref.ee_rotation * controller().wbc().engaged_reference().ee_rotation.transpose());
  for (int a = 0; a < 3; ++a) put(row, rest_r[a]);
  row += o.arm_reference_saturated ? ",1" : ",0";
  row += o.arm_overloaded ? ",1" : ",0";
  row += o.hand_coupling_limited ? ",1" : ",0";
  row += o.support_limited ? ",1" : ",0";
  put(row, std::isfinite(o.support_distance_m) ? o.support_distance_m : -1.0);
  put(row, std::isfinite(o.capture_distance_m) ? o.capture_distance_m : -1.0);
  for (int a = 0; a < 3; ++a) put(row, controller().input().unmeasured_force_world_n[a]);
  row += controller().stepping_for_push() ? ",1" : ",0";
  put(row, estimator_errors_.velocity_error_m_s());
  put(row, estimator_errors_.tilt_error_rad());
  put(row, estimator_errors_.yaw_drift_rad());
}

std::string WbcAdapter::summary_fields() const {
  std::array<std::optional<double>, kAxes> nrmse{}, steady{}, peak{}, chirp_db{};
  const std::size_t n = samples_.size();
  // Translations (axes 0-5) and rotations (6-11) are scored apart: an axis counts as moved
  // against the largest peak-to-peak of its own kind.
  std::array<double, kAxes> ptp{};
  std::array<double, 2> ptp_max{};
  for (int a = 0; a < kAxes && n > 0; ++a) {
    double lo = samples_[0].reference[a], hi = lo;
    for (const auto& s : samples_) {
      lo = std::min(lo, s.reference[a]);
      hi = std::max(hi, s.reference[a]);
    }
    ptp[a] = hi - lo;
    ptp_max[a / 6] = std::max(ptp_max[a / 6], ptp[a]);
  }
  const auto last_second = static_cast<std::size_t>(std::llround(1.0 / dt_s_));
  for (int a = 0; a < kAxes && n > 0; ++a) {
    double sq = 0.0, worst = 0.0;
    for (const auto& s : samples_) {
      const double e = s.measured[a] - s.reference[a];
      sq += e * e;
      worst = std::max(worst, std::abs(e));
    }
    const bool rotation = a >= 6;
    const bool rendered = !rotation || rotational_template_.has_value();
    if (rendered) peak[a] = worst;
    if (!rendered || ptp_max[a / 6] <= 1e-9 || ptp[a] < kMovingAxisFraction * ptp_max[a / 6]) continue;
    nrmse[a] = std::sqrt(sq / static_cast<double>(n)) / ptp[a];
    if (step_profile_ && n >= last_second) {
      // The template's static displacement for the mean measured force (torque) of the last second.
      Vec3 force = Vec3::Zero(), torque = Vec3::Zero();
      double measured = 0.0;
      for (std::size_t i = n - last_second; i < n; ++i) {
        force += samples_[i].force_world_n;
        torque += samples_[i].torque_world_nm;
        measured += samples_[i].measured[a];
      }
      force /= static_cast<double>(last_second);
      torque /= static_cast<double>(last_second);
      measured /= static_cast<double>(last_second);
      const auto& tp = params_.template_params;
      const auto& rp = params_.rotational_template;
      const bool base = a % 6 < 3;
      const Vec3 fk = rotation ? (base ? wbc::steady_state_base_rad(rp, torque) : wbc::steady_state_ee_rad(rp, torque))
                               : (base ? wbc::steady_state_base_m(tp, force) : wbc::steady_state_ee_m(tp, force));
      const double target = fk[a % 3];
      if (std::abs(target) > 1e-9) steady[a] = std::abs(measured - target) / std::abs(target);
    }
    if (chirp_) {
      // Short-time fits at the chirp's own phase: windows one local period long, centred
      // where the sweep passes 0.25, 0.31, ... 3 Hz (rising or falling), or, for a constant
      // frequency, every period along the chirp.
      const sim::ForceProfile& p = *chirp_;
      const double rate = (p.end_frequency_hz - p.start_frequency_hz) / p.duration_s;
      const bool constant = std::abs(rate) * p.duration_s < 1e-9;
      double worst_db = 0.0;
      bool any = false;
      const auto fit_window = [&](double tc, double f) {  // one local period centred at tc
        const double half = 0.5 / f;
        if (tc - half < p.start_s || tc + half > p.start_s + p.duration_s) return;
        std::vector<double> ym, yt, ph;
        for (const auto& s : samples_) {
          if (s.time_s < tc - half || s.time_s > tc + half) continue;
          ym.push_back(s.measured[a]);
          yt.push_back(s.reference[a]);
          ph.push_back(chirp_phase_rad(p, s.time_s));
        }
        if (ym.size() <= 20) return;
        const double am = fitted_amplitude(ym, ph), at = fitted_amplitude(yt, ph);
        if (at > 0.0 && am > 0.0) {
          worst_db = std::max(worst_db, std::abs(20.0 * std::log10(am / at)));
          any = true;
        }
      };
      if (constant) {
        const double f = p.start_frequency_hz;
        for (double k = 1.0; f > 0.0 && k / f <= p.duration_s; k += 1.0) fit_window(p.start_s + k / f, f);
      } else {
        // Each centre a quarter of the local frequency above the last (overlapping windows).
        for (double f = 0.25; f <= 3.0 + 1e-9; f += 0.5 * f * 0.5) {
          fit_window(p.start_s + (f - p.start_frequency_hz) / rate, f);
        }
      }
      if (any) chirp_db[a] = worst_db;
    }
  }
  // Every axis's RMS error, rendered or not: translations against the template [m],
  // orientations against the rotational template or, where it is off, the rest pose [rad]; and W_b^d
  // against what the solution applied.
  std::string rms = "{";
  Vec6 wrench_sq = Vec6::Zero();
  for (int a = 0; a < kAxes; ++a) {
    double sq = 0.0;
    for (const auto& s : samples_) {
      const double e = s.measured[a] - s.reference[a];
      sq += e * e;
    }
    rms += fmt::format("{}\"{}\": {}", a ? ", " : "", kAxisKeys[a],
                       n > 0 ? fmt::format("{:.6g}", std::sqrt(sq / static_cast<double>(n))) : "null");
  }
  rms += "}";
  for (const auto& s : samples_) wrench_sq += s.base_wrench_error.cwiseAbs2();
  if (n > 0) wrench_sq /= static_cast<double>(n);
  const Vec6 wrench_rms = wrench_sq.cwiseSqrt();
  const auto most_at_limit = std::max_element(torque_limit_ticks_.begin(), torque_limit_ticks_.end());
  std::string j;
  j += fmt::format("  \"wbc_start_s\": {:.6f},\n", n > 0 ? samples_.front().time_s - dt_s_ : 0.0);
  j += fmt::format("  \"rms_error\": {},\n", rms);
  j += fmt::format("  \"base_wrench_error_rms\": {{\"fx_n\": {:.6g}, \"fy_n\": {:.6g}, \"fz_n\": {:.6g}, "
                   "\"tx_nm\": {:.6g}, \"ty_nm\": {:.6g}, \"tz_nm\": {:.6g}}},\n",
                   wrench_rms[0], wrench_rms[1], wrench_rms[2], wrench_rms[3], wrench_rms[4], wrench_rms[5]);
  j += fmt::format("  \"torque_limit_s\": {{\"any\": {:.6g}, \"most\": {:.6g}, \"most_joint\": \"{}\"}},\n",
                   static_cast<double>(any_torque_limit_ticks_) * dt_s_, static_cast<double>(*most_at_limit) * dt_s_,
                   robot::kJoints[static_cast<std::size_t>(most_at_limit - torque_limit_ticks_.begin())].name);
  j += fmt::format("  \"arm_overloaded_s\": {:.6g},\n", static_cast<double>(arm_overloaded_ticks_) * dt_s_);
  j += fmt::format("  \"support_limited_s\": {:.6g},\n", static_cast<double>(support_limited_ticks_) * dt_s_);
  j += fmt::format("  \"push_stepping\": {{\"times\": {}, \"s\": {:.6g}}},\n", push_steppings_,
                   static_cast<double>(push_stepping_ticks_) * dt_s_);
  j += fmt::format("  \"max_joint_speed_ratio\": {:.6g},\n", max_speed_ratio_);
  j += fmt::format("  \"max_joint_speed_joint\": \"{}\",\n", robot::kJoints[static_cast<std::size_t>(max_speed_joint_)].name);
  j += fmt::format("  \"nrmse\": {},\n", json_axes(nrmse));
  j += fmt::format("  \"steady_state_error\": {},\n", json_axes(steady));
  j += fmt::format("  \"peak_deviation\": {},\n", json_axes(peak));
  j += fmt::format("  \"chirp_gain_db_error\": {},\n", chirp_ ? json_axes(chirp_db) : std::string("null"));
  j += fmt::format("  \"qp_failures\": {},\n", controller().wbc().qp_failures());
  j += fmt::format("  \"failed_ticks\": {},\n", failed_ticks_);
  j += fmt::format("  \"supervisor\": {{\"mode\": \"{}\", \"faults\": {}}},\n", safety::to_string(firmware_->supervisor().mode()),
                   firmware_->supervisor().faults());
  {
    std::string refused;
    for (const std::string& r : refusals_) refused += fmt::format("{}\"{}\"", refused.empty() ? "" : ", ", r);
    j += fmt::format("  \"operator_refusals\": [{}],\n", refused);
  }
  j += fmt::format("  \"qp_from_hint_ticks\": {},\n", qp_from_hint_ticks_);
  j += fmt::format("  \"max_torque_ratio\": {:.6g},\n", max_torque_ratio_);
  j += fmt::format("  \"joint_limit_hit\": {},\n", joint_limit_hit_ ? "\"" + joint_limit_joint_ + "\"" : "null");
  if (trot_) {
    const gait::TrotParams& g = controller().params().gait.trot;
    // The trunk's mean velocity over the last 3 s, in its horizontal frame, and the command then.
    const std::size_t last = std::min(trunk_velocity_h_.size(), static_cast<std::size_t>(std::llround(3.0 / dt_s_)));
    Vec3 mean = Vec3::Zero();
    for (std::size_t i = trunk_velocity_h_.size() - last; i < trunk_velocity_h_.size(); ++i) mean += trunk_velocity_h_[i];
    if (last > 0) mean /= static_cast<double>(last);
    const Vec3& command = controller().walking_velocity();
    j += fmt::format("  \"gait\": {{\"step_frequency_hz\": {:.6g}, \"duty_factor\": {:.6g}, \"step_height_m\": {:.6g}, "
                     "\"stance_changes\": {}, \"early_touchdowns\": {}, \"late_touchdowns\": {}, \"mean_velocity\": {{\"x\": {:.6g}, \"y\": {:.6g}, \"yaw\": {:.6g}}}, "
                     "\"commanded_velocity\": {{\"x\": {:.6g}, \"y\": {:.6g}, \"yaw\": {:.6g}}}}},\n",
                     g.step_frequency_hz, g.duty_factor, g.step_height_m, controller().stance_changes(),
                     controller().trot().plan().early_touchdowns, controller().trot().plan().late_touchdowns, mean.x(), mean.y(),
                     mean.z(), command.x(), command.y(), command.z());
  } else {
    j += "  \"gait\": null,\n";
  }
  j += fmt::format("  \"state_source\": \"{}\",\n", use_estimator_ ? "estimated" : "truth");
  j += "  \"estimator\": " + estimator_errors_.json() + ",\n";
  // The slowest tick and what it met: a page fault or a context switch during it (the OS),
  // else the WBC's first tick (its code and data come from memory, not from a cache: 60-75 us
  // with memory locked and no QP iteration), else a solve of more QP iterations than the
  // run's p99 (the QP's worst case), else neither.
  const double iterations_p99 = percentile(qp_iterations_all_, 0.99);
  const char* cause = slowest_.faults > 0                          ? "page_fault"
                      : slowest_.switches > 0                      ? "context_switch"
                      : slowest_.first                             ? "first_tick"
                      : slowest_.qp_iterations > iterations_p99 ? "qp_solve"
                                                                   : "unattributed";
  j += fmt::format("  \"tick_us\": {{\"median\": {:.3f}, \"p99\": {:.3f}, \"p99_9\": {:.3f}, \"max\": {:.3f}, \"max_at_s\": {:.3f}, "
                   "\"max_cause\": \"{}\", \"max_page_faults\": {}, \"max_context_switches\": {}, "
                   "\"max_qp_iterations\": {}, \"max_qp_from_hint\": {}}},\n",
                   percentile(tick_us_all_, 0.5), percentile(tick_us_all_, 0.99), percentile(tick_us_all_, 0.999),
                   percentile(tick_us_all_, 1.0),
                   slowest_.time_s, cause, slowest_.faults, slowest_.switches, slowest_.qp_iterations,
                   slowest_.qp_from_hint ? "true" : "false");
  return j;
}

}  // namespace springbok::simtool
