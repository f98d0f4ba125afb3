#include "springbok/drive_emulator/bullet_motion.hpp"

#include <algorithm>
#include <cmath>
#include <optional>
#include <stdexcept>

#include "springbok/sim_hal/stepped_bullet_robot.hpp"

namespace springbok::emu {

namespace {

sim::SimConfig sim_config(const BulletOptions& o) {
  sim::SimConfig c = sim::crouched_sim_config(1000);
  constexpr sim::ImuPreset kPresets[] = {sim::ImuPreset::ideal, sim::ImuPreset::mems, sim::ImuPreset::tactical};
  const sim::SensorModelConfig preset = sim::sensor_preset(kPresets[static_cast<int>(o.sensors_preset)]);
  c.sensors.seed = o.sensors_seed;
  c.sensors.imu = preset.imu;
  c.sensors.imu.gyro.bias_offset = o.gyro_bias_offset_rad_s;
  c.sensors.wrist_ft = preset.wrist_ft;
  c.imu.gyro_noise_rad_s = o.imu_gyro_noise_rad_s;
  c.imu.accel_noise_m_s2 = o.imu_accel_noise_m_s2;
  c.imu.gyro_bias_rad_s = o.imu_gyro_bias_rad_s;
  c.imu.accel_bias_m_s2 = o.imu_accel_bias_m_s2;
  c.imu.seed = o.imu_seed;
  return c;
}

BulletOptions settle_only(double settle_s) {
  BulletOptions o;
  o.settle_s = settle_s;
  return o;
}

}  // namespace

BulletMotion::BulletMotion(std::FILE* trace, int trace_every, double settle_s)
    : BulletMotion(trace, trace_every, settle_only(settle_s)) {}

BulletMotion::BulletMotion(std::FILE* trace, int trace_every, const BulletOptions& options)
    : robot_(std::make_unique<sim::SteppedBulletRobot>(sim_config(options))),
      trace_(nullptr),
      trace_every_(std::max(1, trace_every)) {
  const double settle_s = options.settle_s;
  constexpr double kDt_s = 0.001;
  for (int j = 0; j < kNj; ++j) {
    const double axis_inertia_kgm2 = joint_own_axis_inertia_kgm2(j);
    kd_cap_[static_cast<std::size_t>(j)] = axis_inertia_kgm2 / kDt_s;
    kp_cap_[static_cast<std::size_t>(j)] = axis_inertia_kgm2 / (4.0 * kDt_s * kDt_s);
  }
  const hal::LifecycleResult c = robot_->configure();
  if (!c.ok) throw std::runtime_error("bullet world: " + c.message);
  if (options.hand_force) {
    const HandForce& h = options.hand;
    if (!(std::isfinite(h.force_n) && std::isfinite(h.start_s) && h.start_s >= 0.0 && h.axis_world.allFinite() &&
          h.axis_world.norm() > 0.0)) {
      throw std::runtime_error("hand force: need a finite force, a start >= 0 and a non-zero axis");
    }
    if (!(h.duration_s > 0.0)) {
      throw std::runtime_error("hand force: need a duration > 0");
    }
    const std::optional<sim::FrameRef> ee = sim::find_frame(robot::kFrames[kEeFrame].name);
    if (!ee) throw std::runtime_error("hand force: no end-effector frame in the model");
    sim::ExternalWrench w;
    w.frame = *ee;
    w.kind = sim::WrenchKind::force;
    w.axis_world = h.axis_world.normalized();
    w.profile.shape = sim::ProfileShape::step;
    w.profile.amplitude = h.force_n;
    // Simulated time, which also runs while the robot settles before the drives boot.
    w.profile.start_s = settle_s + h.start_s;
    w.profile.duration_s = h.duration_s;
    hand_ = h;
    hand_force_ = true;
    if (!robot_->robot().add_external_wrench(w)) throw std::runtime_error("hand force: the wrench table is full");
  }
  const hal::LifecycleResult a = robot_->activate();
  if (!a.ok) throw std::runtime_error("bullet world: " + a.message);
  for (int k = 0; k < static_cast<int>(settle_s * 1000.0 + 0.5); ++k) step();  // every drive disabled
  hal::Measurements m;
  (void)robot_->read(m);
  for (int j = 0; j < kNj; ++j) state_[static_cast<std::size_t>(j)] = JointState{m.q_rad[j], m.qd_rad_s[j], 0.0};
  truth_ = TruthSummary{};
  truth_.trunk_z_m = robot_->robot().ground_truth().q[2];
  time_origin_s_ = robot_->robot().ground_truth().time_s;
  trace_ = trace;
  settled_ = true;
}

BulletMotion::~BulletMotion() = default;

JointState BulletMotion::command(int joint, const DriveLaw& law) {
  const auto j = static_cast<std::size_t>(joint);
  if (pending_[j]) force_step();  // the caller did not hold the frame back
  const JointState at_reception = state_[j];
  law_[j] = law;
  pending_[j] = true;
  bool all = true;
  for (std::size_t k = 0; k < pending_.size(); ++k) all = all && (pending_[k] || !enabled_[k]);
  if (all) step();
  return at_reception;
}

void BulletMotion::set_enabled(int joint, bool enabled) {
  const auto j = static_cast<std::size_t>(joint);
  enabled_[j] = enabled;
  if (!enabled) {
    law_[j] = DriveLaw{};
    pending_[j] = false;
  }
}

void BulletMotion::force_step() {
  ++truth_.forced_steps;
  step();
}

JointState BulletMotion::state(int joint) const { return state_[static_cast<std::size_t>(joint)]; }

void BulletMotion::step() {
  // The drive law plus the gearbox's viscous friction b (as in the per-joint JointModel):
  // kd (v_des - qd) - b qd = (kd + b) (v' - qd) with v' = kd v_des / (kd + b). Without it an
  // unpowered joint of small inertia spins up under the half-LSB of a "zero" MIT torque.
  // A real drive closes this law at tens of kHz; evaluated once per 1 ms physics step it is
  // unstable where (kd + b) dt exceeds the joint's inertia (the wrist: 2.4e-4 kg m^2). There
  // the law settles within a tick anyway, so the gains are capped at what one step can
  // render: kd <= I / dt, kp <= I / (4 dt^2), I = the moved body's own inertia about the axis
  // (a lower bound of the joint's inertia: the cap only ever binds on light distal joints).
  const double b = JointModel{}.viscous_nms_per_rad;
  hal::JointCommands cmd;
  cmd.mode = hal::CommandMode::enabled;
  for (int j = 0; j < kNj; ++j) {
    const auto k = static_cast<std::size_t>(j);
    const double kd = enabled_[k] ? law_[k].kd : 0.0;
    const double kd_total = std::min(kd + b, kd_cap_[k]);
    cmd.kd_nms_per_rad[j] = kd_total;
    if (!enabled_[k]) continue;  // power stage off: friction only
    cmd.q_des_rad[j] = law_[k].p_des_rad;
    cmd.qd_des_rad_s[j] = kd_total > 0.0 ? kd * law_[k].v_des_rad_s / (kd + b) : 0.0;
    cmd.kp_nm_per_rad[j] = std::min(law_[k].kp, kp_cap_[k]);
    cmd.tau_ff_nm[j] = law_[k].t_ff_nm;
  }
  (void)robot_->write(cmd);  // applies the drive law in every physics step, then steps the world
  hal::Measurements m;
  (void)robot_->read(m);
  const sim::GroundTruth& gt = robot_->robot().ground_truth();
  for (int j = 0; j < kNj; ++j) {
    state_[static_cast<std::size_t>(j)] = JointState{m.q_rad[j], m.qd_rad_s[j], gt.tau_applied_nm[j]};
  }
  pending_.fill(false);
  ++truth_.steps;
  truth_.time_s = gt.time_s - time_origin_s_;
  truth_.trunk_z_m = gt.q[2];
  const Eigen::Quaterniond q_wb(gt.q[6], gt.q[3], gt.q[4], gt.q[5]);  // stored xyzw
  const double cos_tilt = std::clamp(q_wb.normalized().toRotationMatrix()(2, 2), -1.0, 1.0);
  truth_.trunk_tilt_rad = std::acos(cos_tilt);
  truth_.non_foot_ground_contact = gt.non_foot_ground_contact;
  const sim::ImuErrorState imu_errors = robot_->robot().sensor_model().imu_errors();
  truth_.imu_gyro_bias_rad_s = imu_errors.gyro_bias_rad_s;
  truth_.imu_accel_bias_m_s2 = imu_errors.accel_bias_m_s2;
  truth_.trunk_orientation = q_wb.normalized();
  if (const std::optional<sim::FrameRef> ee = sim::find_frame(robot::kFrames[kEeFrame].name)) {
    truth_.ee_orientation = Eigen::Quaterniond(robot_->robot().frame_placement(*ee).linear()).normalized();
  }
  if (!settled_) return;
  ++settled_steps_;
  if (on_step_) on_step_(m.imu, m.wrist);
  if (trace_ != nullptr && truth_.steps % static_cast<std::uint64_t>(trace_every_) == 0) {
    Eigen::Vector3d hand = Eigen::Vector3d::Zero();
    if (const std::optional<sim::FrameRef> ee = sim::find_frame(robot::kFrames[kEeFrame].name)) {
      hand = robot_->robot().frame_placement(*ee).translation();
    }
    Eigen::Vector3d force = Eigen::Vector3d::Zero();
    if (hand_force_ && truth_.time_s >= hand_.start_s && truth_.time_s < hand_.start_s + hand_.duration_s) {
      force = hand_.force_n * hand_.axis_world.normalized();
    }
    int contacts = 0;
    for (int f = 0; f < kFeet; ++f) contacts |= gt.foot_contact[static_cast<std::size_t>(f)] ? 1 << f : 0;
    std::fprintf(trace_, "%.4f %.5f %.5f %d %.5f %.5f %.5f %.5f %.5f %.3f %.3f %.3f %d %c %llu\n", truth_.time_s,
                 truth_.trunk_z_m, truth_.trunk_tilt_rad, truth_.non_foot_ground_contact ? 1 : 0, gt.q[0], gt.q[1],
                 hand.x(), hand.y(), hand.z(), force.x(), force.y(), force.z(), contacts,
                 static_cast<char>(command_class()), static_cast<unsigned long long>(settled_steps_));
    std::fflush(trace_);
  }
}

// The class of this step's drive laws (MIT's "zero" torque is half an LSB off: ~0.005 N m).
// Damping is the host's damping command (CAN.md 4.2 step 5, 4.4): no stiffness and no position
// or velocity target on any joint (|p_des|, |v_des| within a quantum of zero), damping in the
// drive (kd). A controller's torque command carries the measured positions as p_des (never all
// zero: the knees stand at +-1.4 rad).
CommandClass BulletMotion::command_class() const noexcept {
  // Within a quantum of zero: MIT's p (16 bits over 25 rad) and v (12 bits over 130 rad/s).
  constexpr double kZeroTorque_nm = 0.05, kZeroPosition_rad = 1e-3, kZeroVelocity_rad_s = 0.05;
  bool any_enabled = false, any_kp = false, any_kd = false, any_torque = false, no_target = true;
  for (std::size_t j = 0; j < law_.size(); ++j) {
    if (!enabled_[j]) continue;
    any_enabled = true;
    any_kp = any_kp || law_[j].kp > 0.0;
    any_kd = any_kd || law_[j].kd > 0.0;
    any_torque = any_torque || std::abs(law_[j].t_ff_nm) > kZeroTorque_nm;
    no_target = no_target && std::abs(law_[j].p_des_rad) < kZeroPosition_rad &&
                std::abs(law_[j].v_des_rad_s) < kZeroVelocity_rad_s;
  }
  if (!any_enabled) return CommandClass::off;
  if (any_kp) return CommandClass::position;
  if (!any_kd && !any_torque) return CommandClass::zero;
  return no_target && any_kd ? CommandClass::damping : CommandClass::torque;
}

}  // namespace springbok::emu
