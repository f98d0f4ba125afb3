#include "springbok/app/control_mode.hpp"

namespace springbok::app {
namespace {
constexpr est::Stance kAllFeet{true, true, true, true};
}

ControlMode::ControlMode(const AppConfig& config)
    : kind_(config.control_mode),
      hold_(config),
      estimator_(std::make_unique<est::BaseEstimator>(config.estimator)),
      wbc_(std::make_unique<wbc::WholeBodyController>(config.wbc)),
      input_(std::make_unique<wbc::WbcInput>()) {}

ControlMode::~ControlMode() = default;

// rt: no alloc
safety::ControllerReport ControlMode::hold(const ControlInput& in, hal::JointCommands& cmd) noexcept {
  (void)hold_.compute(in, cmd);
  ++failed_ticks_;
  safety::ControllerReport report;
  report.ok = false;
  return report;
}

// rt: no alloc, no block
safety::ControllerReport ControlMode::compute(const ControlInput& in, hal::JointCommands& cmd) noexcept {
  if (kind_ == ControlModeKind::joint_pd) return hold_.compute(in, cmd);
  const hal::Measurements& m = *in.meas;
  if (in.ticks_in_mode == 0) {
    engaged_ = estimator_->reset(m, kAllFeet, Eigen::Vector2d::Zero()) == est::EstimateStatus::ok;
    if (engaged_) wbc_->set_reference(estimator_->estimate().q);
  } else if (engaged_) {
    (void)estimator_->update(m, kAllFeet, in.dt_s);
  }
  if (!engaged_ || estimator_->estimate().status != est::EstimateStatus::ok) return hold(in, cmd);

  wbc::WbcInput& w = *input_;
  w.q = estimator_->estimate().q;
  w.v = estimator_->estimate().v;
  w.stance = kAllFeet;
  const bool wrist = m.wrist.valid && m.wrist.force_n.allFinite() && m.wrist.torque_nm.allFinite();
  w.wrist_force_n = wrist ? m.wrist.force_n : Vec3::Zero();
  w.wrist_torque_nm = wrist ? m.wrist.torque_nm : Vec3::Zero();
  const wbc::WbcOutput& o = wbc_->tick(w);
  cmd.mode = hal::CommandMode::enabled;
  cmd.tau_ff_nm = o.tau_nm;
  cmd.q_des_rad = m.q_rad;
  cmd.qd_des_rad_s.setZero();
  cmd.kp_nm_per_rad.setZero();
  cmd.kd_nms_per_rad.setZero();
  safety::ControllerReport report;
  report.ok = !o.fallback;
  if (o.fallback) ++failed_ticks_;  // the WBC's own safe torques (gravity compensation + damping)
  return report;
}

}  // namespace springbok::app
