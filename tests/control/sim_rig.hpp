// The firmware's controller (control::RobotController) under the safety supervisor on
// the Bullet robot, ticked as every binary ticks it (observe, the mode's controller,
// finish, write, step), with the simulator's ground truth as the base state.
#pragma once

#include <cmath>
#include <limits>
#include <memory>

#include <gtest/gtest.h>

#include "springbok/control/robot_controller.hpp"
#include "springbok/dynamics/dynamics.hpp"
#include "springbok/safety/supervisor.hpp"
#include "springbok/sim_hal/bullet_robot.hpp"
#include "springbok/wbc/stand_controller.hpp"

namespace springbok::test {

inline constexpr double kDt_s = 0.001;
inline constexpr double kSettle_s = 0.5;

struct Rig {
  // A trot, GP2 (1.4 Hz, d_f 0.65).
  static control::ControlParams trot_params() {
    control::ControlParams cp;
    cp.gait.kind = control::GaitKind::trot;
    cp.gait.trot.step_frequency_hz = 1.4;
    cp.gait.trot.duty_factor = 0.65;
    return cp;
  }

  std::unique_ptr<sim::BulletRobot> robot;
  std::unique_ptr<control::RobotController> control;
  safety::Supervisor supervisor{safety::SupervisorConfig{}};
  std::unique_ptr<wbc::StandController> stand;
  hal::Measurements m;
  hal::JointCommands cmd;
  control::TickStatus status = control::TickStatus::ok;

  explicit Rig(const control::ControlParams& cp = trot_params()) {
    sim::SimConfig config;
    config.initial_q.tail<kNj>() = wbc::nominal_stance();
    config.initial_q.segment<kArmJoints>(7 + kFirstArmJoint) << 0.0, 0.6, 0.0, 1.9, 0.0, 0.9, 0.0;
    const dyn::Model model;
    auto data = std::make_unique<dyn::Data>();
    dyn::forward_kinematics(model, *data, config.initial_q);
    double lowest = 1e9;
    for (int f : kFootFrames) lowest = std::min(lowest, data->frames[f].translation.z());
    config.initial_q[2] = kFootRadius_m - lowest;  // the feet just on the ground
    robot = std::make_unique<sim::BulletRobot>(config);
    EXPECT_TRUE(robot->configure().ok);
    EXPECT_TRUE(robot->activate().ok);
    control = std::make_unique<control::RobotController>(cp);
    stand = std::make_unique<wbc::StandController>(wbc::StandGains{}, config.initial_q.tail<kNj>());
  }

  // One tick as the binaries run it: observe, the mode's controller, finish, write,
  // step. `corrupt_base`: the base state handed to the controller has a NaN height.
  void tick(bool corrupt_base = false) {
    EXPECT_EQ(robot->read(m), hal::IoStatus::ok);
    const sim::GroundTruth& truth = robot->ground_truth();
    supervisor.observe(m, hal::IoStatus::ok, 0, 0);
    if (supervisor.mode() == safety::Mode::idle) (void)supervisor.request(safety::OperatorCommand::start);
    if (supervisor.mode() == safety::Mode::stand) (void)supervisor.request(safety::OperatorCommand::mode_control);
    safety::ControllerReport report;
    if (supervisor.mode() == safety::Mode::stand_up) {
      control->observe(m, kDt_s, true);
      stand->tick(truth.q, cmd);
      report.posture_reached = truth.time_s + 1.5 * kDt_s >= kSettle_s;
    } else if (supervisor.mode() == safety::Mode::control) {
      control::BaseTruth base;
      base.pose = truth.q.head<7>();
      base.twist = truth.v.head<6>();
      if (corrupt_base) base.pose[2] = std::numeric_limits<double>::quiet_NaN();
      status = control->tick(m, kDt_s, cmd, &base);
      report.ok = status == control::TickStatus::ok;
    }
    supervisor.finish(m, report, cmd);
    EXPECT_EQ(robot->write(cmd), hal::IoStatus::ok);
    robot->step();
  }

  // Ticks until the left front foot is at `fraction` of a swing, at least `after_s` in.
  void run_to_swing(double fraction, double after_s) {
    const double df = control->params().gait.trot.duty_factor;
    for (int k = 0; k < 5000; ++k) {
      tick();
      const gait::ContactPlan& plan = control->trot().plan();
      if (robot->ground_truth().time_s >= after_s && plan.foot[0] == gait::FootPhase::swing &&
          (plan.phase[0] - df) / (1.0 - df) >= fraction) {
        return;
      }
    }
    ADD_FAILURE() << "the left front foot never reached " << fraction << " of its swing";
  }

  // A constant force on the hand (world) from start_s on.
  void push_hand(const Vec3& force_n, double start_s) {
    sim::ExternalWrench push;
    push.frame = *sim::find_frame("arm_end_effector_link");
    push.axis_world = force_n.normalized();
    push.profile.shape = sim::ProfileShape::step;
    push.profile.amplitude = force_n.norm();
    push.profile.start_s = start_s;
    EXPECT_TRUE(robot->add_external_wrench(push));
  }
  // A torque step at the hand from start_s on (world axes).
  void twist_hand(const Vec3& torque_nm, double start_s) {
    sim::ExternalWrench twist;
    twist.frame = *sim::find_frame("arm_end_effector_link");
    twist.kind = sim::WrenchKind::torque;
    twist.axis_world = torque_nm.normalized();
    twist.profile.shape = sim::ProfileShape::step;
    twist.profile.amplitude = torque_nm.norm();
    twist.profile.start_s = start_s;
    EXPECT_TRUE(robot->add_external_wrench(twist));
  }

  bool fallen() const {
    const sim::GroundTruth& t = robot->ground_truth();
    return t.q[2] < 0.45 || t.non_foot_ground_contact;
  }
};

}  // namespace springbok::test
