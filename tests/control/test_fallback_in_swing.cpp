// A failed tick in mid-swing, on the Bullet robot: the firmware's controller
// (control::WholeBodyControl) trots under the safety supervisor as in every binary,
// and its tick fails for real (a corrupt base state: the QP has no solution) while
// the left front foot is in the middle of its swing. The supervisor alone decides
// the command then: the last good one, i.e. the trot's (torque mode, the swinging
// leg's swing torques), not a four-feet stance or a joint-PD hold. Two failed ticks
// (below the streak of 3): the trot goes on, the foot lands, nothing faults. Three
// in a row: the streak latches the damping mode.
#include <cmath>
#include <limits>
#include <memory>

#include <gtest/gtest.h>

#include "springbok/control/whole_body_control.hpp"
#include "springbok/dynamics/dynamics.hpp"
#include "springbok/safety/supervisor.hpp"
#include "springbok/sim_hal/bullet_robot.hpp"
#include "springbok/wbc/stand_controller.hpp"

namespace {
using namespace springbok;

constexpr double kDt_s = 0.001;
constexpr double kSettle_s = 0.5;

struct Rig {
  std::unique_ptr<sim::BulletRobot> robot;
  std::unique_ptr<control::WholeBodyControl> control;
  safety::Supervisor supervisor{safety::SupervisorConfig{}};
  std::unique_ptr<wbc::StandController> stand;
  hal::Measurements m;
  hal::JointCommands cmd;
  control::TickStatus status = control::TickStatus::ok;

  Rig() {
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
    control::ControlParams cp;
    cp.gait.kind = control::GaitKind::trot;
    cp.gait.trot.step_frequency_hz = 1.4;
    cp.gait.trot.duty_factor = 0.65;
    control = std::make_unique<control::WholeBodyControl>(cp);
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

  bool fallen() const {
    const sim::GroundTruth& t = robot->ground_truth();
    return t.q[2] < 0.45 || t.non_foot_ground_contact;
  }
};

TEST(FallbackInSwing, TwoFailedTicksMidSwingKeepTheTrotsLastCommandAndTheTrotGoesOn) {
  Rig rig;
  rig.run_to_swing(0.5, 2.0);
  ASSERT_EQ(rig.supervisor.mode(), safety::Mode::control);
  ASSERT_FALSE(rig.control->state().stance[0]);
  const hal::JointCommands last_good = rig.cmd;
  // The trot's command: torque mode, the swinging leg driven (its swing torques).
  EXPECT_EQ(last_good.kp_nm_per_rad, VecNj::Zero());
  EXPECT_GT(last_good.tau_ff_nm.head<kLegJoints>().cwiseAbs().maxCoeff(), 1.0);
  for (int k = 0; k < 2; ++k) {
    rig.tick(/*corrupt_base=*/true);
    EXPECT_EQ(rig.status, control::TickStatus::qp_failed);
    EXPECT_EQ(rig.supervisor.mode(), safety::Mode::control);
    // The supervisor's fallback: the last good command (re-bounded at this state, which
    // changes nothing within the limits), swing torques for the swinging leg included.
    EXPECT_EQ(rig.cmd.tau_ff_nm, last_good.tau_ff_nm);
    EXPECT_EQ(rig.cmd.kp_nm_per_rad, VecNj::Zero());
    EXPECT_EQ(rig.cmd.kd_nms_per_rad, last_good.kd_nms_per_rad);
  }
  // The trot goes on: the foot lands, both diagonals keep stepping, nothing faults.
  bool landed = false;
  int lf_lifts = 0;
  bool was_down = false;
  for (int k = 0; k < 2000; ++k) {
    rig.tick();
    ASSERT_EQ(rig.status, control::TickStatus::ok) << k;
    ASSERT_FALSE(rig.fallen()) << k;
    const bool down = rig.control->state().stance[0];
    landed = landed || down;
    if (was_down && !down) ++lf_lifts;
    was_down = down;
  }
  EXPECT_TRUE(landed);
  EXPECT_GE(lf_lifts, 2);  // 2 s at 1.4 Hz
  EXPECT_EQ(rig.supervisor.faults(), 0u);
  EXPECT_EQ(rig.supervisor.mode(), safety::Mode::control);
}

TEST(FallbackInSwing, ThreeFailedTicksInARowLatchTheDampingMode) {
  Rig rig;
  rig.run_to_swing(0.5, 1.5);
  for (int k = 0; k < 3; ++k) rig.tick(/*corrupt_base=*/true);
  EXPECT_EQ(rig.supervisor.mode(), safety::Mode::damping);
  EXPECT_NE(rig.supervisor.faults() & safety::fault::kQpFailureStreak, 0u);
}

}  // namespace
