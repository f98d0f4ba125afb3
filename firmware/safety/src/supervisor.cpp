#include "springbok/safety/supervisor.hpp"

#include <algorithm>
#include <cmath>

namespace springbok::safety {

const char* to_string(Mode mode) noexcept {
  switch (mode) {
    case Mode::idle: return "idle";
    case Mode::stand_up: return "stand_up";
    case Mode::stand: return "stand";
    case Mode::control: return "control";
    case Mode::damping: return "damping";
  }
  return "unknown";
}

const char* fault_name(int bit) noexcept {
  switch (bit) {
    case 0: return "overrun_streak";
    case 1: return "overrun_rate";
    case 2: return "non_finite_measurement";
    case 3: return "joint_limit";
    case 4: return "qp_failure_streak";
    case 5: return "drive_lost";
    case 6: return "operator_stop";
    case 7: return "hal_watchdog";
    case 8: return "imu_lost";
    case 9: return "wrist_ft_lost";
    case 10: return "imu_clipping_streak";
    case 11: return "wrist_ft_clipping_streak";
    default: return "unknown";
  }
}

const char* to_string(OperatorCommand command) noexcept {
  switch (command) {
    case OperatorCommand::start: return "start";
    case OperatorCommand::stop: return "stop";
    case OperatorCommand::mode_stand: return "mode stand";
    case OperatorCommand::mode_control: return "mode control";
    case OperatorCommand::reset: return "reset";
  }
  return "unknown";
}

const char* to_string(Verdict verdict) noexcept {
  switch (verdict) {
    case Verdict::accepted: return "accepted";
    case Verdict::not_idle: return "start needs mode idle";
    case Verdict::not_standing: return "mode control needs mode stand";
    case Verdict::not_in_control: return "mode stand needs mode control";
    case Verdict::not_in_damping: return "reset needs mode damping";
    case Verdict::unsafe_moving: return "not safe: a joint is moving";
    case Verdict::unsafe_measurement: return "not safe: measurements stale or not finite";
    case Verdict::unsafe_joint_limit: return "not safe: a joint is beyond its limit";
    case Verdict::unsafe_drive: return "not safe: a drive is lost or in fault";
    case Verdict::unsafe_timing: return "not safe: overrun streak in progress";
    case Verdict::sensor_lost: return "a sensor the controller needs is lost or clipping (imu or wrist F/T)";
    case Verdict::sensor_not_ready: return "the imu's orientation has not converged";
    case Verdict::controller_not_ready: return "the controller is not ready (the wrist f/t's tare is being taken)";
  }
  return "unknown";
}

Supervisor::Supervisor(const SupervisorConfig& config, const JointLimits& limits) noexcept
    : config_(config), limits_(limits) {}

void Supervisor::latch(FaultMask bits) noexcept {
  if (bits == 0) return;
  faults_ |= bits;
  enter(Mode::damping);
}

void Supervisor::enter(Mode mode) noexcept {
  if (mode == mode_) return;
  mode_ = mode;
  ticks_in_mode_ = 0;
  qp_failure_streak_ = 0;
  have_last_good_ = false;
}

bool Supervisor::measurements_finite(const hal::Measurements& m) const noexcept {
  bool finite = m.q_rad.allFinite() && m.qd_rad_s.allFinite() && m.tau_nm.allFinite();
  if (m.imu.valid) {
    finite = finite && m.imu.orientation.coeffs().allFinite() && m.imu.angular_rate_rad_s.allFinite() &&
             m.imu.linear_accel_m_s2.allFinite();
  }
  if (m.wrist.valid) finite = finite && m.wrist.force_n.allFinite() && m.wrist.torque_nm.allFinite();
  return finite;
}

int Supervisor::joint_beyond_limits(const VecNj& q_rad) const noexcept {
  for (int j = 0; j < kNj; ++j) {
    if (!limits_.bounded[static_cast<std::size_t>(j)]) continue;
    if (q_rad[j] < limits_.lower_rad[j] - config_.limit_margin_rad ||
        q_rad[j] > limits_.upper_rad[j] + config_.limit_margin_rad) {
      return j;
    }
  }
  return -1;
}

bool Supervisor::drives_healthy(const hal::Measurements& m) noexcept {
  return std::none_of(m.drives.begin(), m.drives.end(), [](const hal::DriveStatus& d) {
    return d.state == hal::DriveState::lost || d.state == hal::DriveState::fault;
  });
}

void Supervisor::observe(const hal::Measurements& meas, hal::IoStatus io, std::uint32_t overrun_streak,
                         std::uint32_t overruns_in_window) noexcept {  // rt: no alloc
  const bool fresh = (io == hal::IoStatus::ok || io == hal::IoStatus::partial) &&
                     (!have_sequence_ || meas.sequence != last_sequence_);
  if (fresh) {
    stale_ticks_ = 0;
    have_sequence_ = true;
    last_sequence_ = meas.sequence;
  } else if (stale_ticks_ < UINT32_MAX) {
    ++stale_ticks_;
  }
  overrun_streak_ = overrun_streak;

  FaultMask found = 0;
  if (overrun_streak >= config_.overrun_streak_limit) found |= fault::kOverrunStreak;
  if (overruns_in_window > config_.overrun_rate_limit) found |= fault::kOverrunRate;
  if (stale_ticks_ >= config_.hal_watchdog_ticks) found |= fault::kHalWatchdog;
  last_meas_finite_ = measurements_finite(meas);
  const int beyond = last_meas_finite_ ? joint_beyond_limits(meas.q_rad) : -1;
  last_within_limits_ = last_meas_finite_ && beyond < 0;
  last_drives_healthy_ = drives_healthy(meas);
  last_max_speed_rad_s_ = last_meas_finite_ ? meas.qd_rad_s.cwiseAbs().maxCoeff() : 0.0;
  if (!last_meas_finite_) {
    found |= fault::kNonFinite;
  } else if (!last_within_limits_) {
    found |= fault::kJointLimit;
    if ((faults_ & fault::kJointLimit) == 0) {
      limit_joint_ = beyond;
      limit_joint_position_rad_ = meas.q_rad[beyond];
    }
  }
  if (!last_drives_healthy_) found |= fault::kDriveLost;
  sensors_lost_ = (config_.control_needs_imu && meas.imu.lost ? fault::kImuLost : 0u) |
                  (config_.control_needs_wrist_ft && meas.wrist.lost ? fault::kWristFtLost : 0u) |
                  (config_.control_needs_imu && meas.imu.clip_streak ? fault::kImuClipping : 0u) |
                  (config_.control_needs_wrist_ft && meas.wrist.clip_streak ? fault::kWristFtClipping : 0u);
  imu_not_converged_ = config_.control_needs_imu && !meas.imu.converged;
  degraded_buses_ = meas.degraded_buses;
  if (mode_ == Mode::control) found |= sensors_lost_;
  latch(found);
}

Verdict Supervisor::request(OperatorCommand command) noexcept {  // rt: no alloc
  switch (command) {
    case OperatorCommand::start:
      if (mode_ != Mode::idle) return Verdict::not_idle;  // faults always leave idle for damping
      enter(Mode::stand_up);
      return Verdict::accepted;
    case OperatorCommand::stop:
      latch(fault::kOperatorStop);
      return Verdict::accepted;
    case OperatorCommand::mode_control:
      if (mode_ != Mode::stand) return Verdict::not_standing;
      if (sensors_lost_ != 0) return Verdict::sensor_lost;
      if (imu_not_converged_) return Verdict::sensor_not_ready;
      if (!control_ready_) return Verdict::controller_not_ready;
      enter(Mode::control);
      return Verdict::accepted;
    case OperatorCommand::mode_stand:
      if (mode_ != Mode::control) return Verdict::not_in_control;
      enter(Mode::stand);
      return Verdict::accepted;
    case OperatorCommand::reset:
      if (mode_ != Mode::damping) return Verdict::not_in_damping;
      // The safe state is judged on this tick's observation.
      if (!last_meas_finite_ || stale_ticks_ > 0) return Verdict::unsafe_measurement;
      if (!last_within_limits_) return Verdict::unsafe_joint_limit;
      if (!last_drives_healthy_) return Verdict::unsafe_drive;
      if (last_max_speed_rad_s_ > config_.reset_max_speed_rad_s) return Verdict::unsafe_moving;
      if (overrun_streak_ > 0) return Verdict::unsafe_timing;
      faults_ = 0;
      limit_joint_ = -1;
      enter(Mode::idle);
      return Verdict::accepted;
  }
  return Verdict::not_idle;
}

// CAN.md 4.4 step 1: the drives damp (kp = 0, kd = D, v_des = 0, t = 0; CiA 402 computes -D v
// on the host from the measured velocity). Where -D qd at the measured speed exceeds the torque
// limit, the feed-forward part takes the excess back, as clamp_to_limits does.
void Supervisor::damping_command(const hal::Measurements& meas, hal::JointCommands& cmd) const noexcept {
  cmd.mode = hal::CommandMode::enabled;
  cmd.q_des_rad.setZero();
  cmd.qd_des_rad_s.setZero();
  cmd.kp_nm_per_rad.setZero();
  cmd.kd_nms_per_rad = config_.damping_nms_per_rad;
  cmd.tau_ff_nm.setZero();
  for (int j = 0; j < kNj; ++j) {
    const double qd = meas.qd_rad_s[j];
    if (!std::isfinite(qd)) continue;
    const double damping_nm = -config_.damping_nms_per_rad[j] * qd;
    const double limit_nm = torque_limit_nm(j, meas.q_rad[j]);
    cmd.tau_ff_nm[j] = std::clamp(damping_nm, -limit_nm, limit_nm) - damping_nm;
  }
}

void Supervisor::idle_command(hal::JointCommands& cmd) const noexcept {
  cmd.mode = hal::CommandMode::enabled;
  cmd.q_des_rad.setZero();
  cmd.qd_des_rad_s.setZero();
  cmd.kp_nm_per_rad.setZero();
  cmd.kd_nms_per_rad = config_.idle_damping_nms_per_rad;
  cmd.tau_ff_nm.setZero();
}

void Supervisor::clamp_to_limits(const hal::Measurements& meas, hal::JointCommands& cmd) const noexcept {
  cmd.mode = hal::CommandMode::enabled;
  for (int j = 0; j < kNj; ++j) {
    if (limits_.bounded[static_cast<std::size_t>(j)]) {
      cmd.q_des_rad[j] = std::clamp(cmd.q_des_rad[j], limits_.lower_rad[j], limits_.upper_rad[j]);
    }
    // The drive applies tau_ff + kp (q_des - q) + kd (qd_des - qd): bound that
    // torque at the measured state by correcting the feed-forward part.
    const double predicted_nm = hal::drive_torque_nm(cmd, j, meas.q_rad[j], meas.qd_rad_s[j]);
    const double limit_nm = torque_limit_nm(j, meas.q_rad[j]);
    const double bounded_nm = std::clamp(predicted_nm, -limit_nm, limit_nm);
    cmd.tau_ff_nm[j] += bounded_nm - predicted_nm;
  }
}

namespace {
bool command_finite(const hal::JointCommands& c) noexcept {
  return c.tau_ff_nm.allFinite() && c.q_des_rad.allFinite() && c.qd_des_rad_s.allFinite() &&
         c.kp_nm_per_rad.allFinite() && c.kd_nms_per_rad.allFinite() && (c.kp_nm_per_rad.array() >= 0).all() &&
         (c.kd_nms_per_rad.array() >= 0).all();
}
}  // namespace

void Supervisor::finish(const hal::Measurements& meas, const ControllerReport& report,
                        hal::JointCommands& cmd) noexcept {  // rt: no alloc
  const Mode before = mode_;
  if (mode_ == Mode::stand) control_ready_ = report.control_ready;
  if (mode_ == Mode::stand_up || mode_ == Mode::stand || mode_ == Mode::control) {
    const bool ok = report.ok && command_finite(cmd);
    if (ok) {
      qp_failure_streak_ = 0;
    } else if (++qp_failure_streak_ >= config_.qp_failure_streak_limit) {
      latch(fault::kQpFailureStreak);
    }
    if (mode_ != Mode::damping) {
      if (ok) {
        clamp_to_limits(meas, cmd);
        last_good_ = cmd;
        have_last_good_ = true;
        if (mode_ == Mode::stand_up && report.posture_reached) enter(Mode::stand);
      } else if (have_last_good_) {
        const std::uint64_t sequence = cmd.sequence;
        cmd = last_good_;  // the last safe command, re-bounded at this state
        cmd.sequence = sequence;
        clamp_to_limits(meas, cmd);
      } else {
        damping_command(meas, cmd);
      }
    }
  }
  if (mode_ == Mode::damping) {
    damping_command(meas, cmd);
  } else if (mode_ == Mode::idle) {
    idle_command(cmd);
  }
  if (mode_ == before) ++ticks_in_mode_;
}

}  // namespace springbok::safety
