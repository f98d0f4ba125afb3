// springbok::control::RobotController on its own: the centre of mass from the mass
// matrix against the dynamics' oracle, the wrist F/T tare, gait switching (a stop
// lands every swinging foot and lifts none), refused gait requests, failed ticks
// that leave the command to the supervisor, and allocation-free ticks.
#include <cmath>
#include <limits>
#include <random>

#include <tuple>

#include <gtest/gtest.h>

#include "alloc_trap.hpp"
#include "springbok/control/robot_controller.hpp"
#include "springbok/wbc/stand_controller.hpp"

namespace {
using namespace springbok;
using control::GaitKind;
using control::GaitState;
using control::TickStatus;
using control::RobotController;

constexpr double kDt_s = 0.001;

VecNq standing_q() {
  VecNq q = VecNq::Zero();
  q[2] = 0.61233 + kFootRadius_m;
  q[6] = 1.0;
  q.segment<kNj>(7) = wbc::nominal_stance();
  q.segment<kArmJoints>(7 + kFirstArmJoint) << 0.0, 0.6, 0.0, 1.9, 0.0, 0.9, 0.0;
  return q;
}

// A robot standing still, as its sensors report it: joints at q, IMU level at rest.
hal::Measurements standing_measurements(std::uint64_t sequence) {
  hal::Measurements m;
  m.sequence = sequence;
  m.q_rad = standing_q().tail<kNj>();
  m.imu.valid = true;
  static const dyn::Model model;
  const Mat3& r_bi = model.frame_placement[kImuFrame].rotation;  // the IMU's mounting in the trunk
  m.imu.orientation = Quat(r_bi);                                // trunk level: world_from_imu = R_BI
  m.imu.linear_accel_m_s2 = r_bi.transpose() * Vec3(0.0, 0.0, kGravity_m_s2);
  m.wrist.valid = true;
  return m;
}

TEST(CenterOfMass, FromTheMassMatrixEqualsTheDynamicsOracle) {
  dyn::Model model;
  auto data = std::make_unique<dyn::Data>();
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (int i = 0; i < 20; ++i) {
    RobotState s;
    s.q.head<3>() = Vec3(u(rng), u(rng), u(rng));
    Quat quat(u(rng), u(rng), u(rng), u(rng));
    quat.normalize();
    s.q.segment<4>(3) = quat.coeffs();
    for (int j = 0; j < kNj; ++j) s.q[7 + j] = u(rng);
    s.set_rotation_from_q();
    dyn::compute_tick(model, *data, s.q, s.v);
    const Vec3 oracle = dyn::center_of_mass(model, *data, s.q);
    EXPECT_LT((control::center_of_mass_from_inertia(data->M, s) - oracle).norm(), 1e-12) << "state " << i;
  }
}

struct Control : ::testing::Test {
  control::ControlParams params;
  std::unique_ptr<RobotController> c;
  hal::JointCommands cmd;
  std::uint64_t sequence = 0;

  void make() { c = std::make_unique<RobotController>(params); }
  hal::Measurements next() { return standing_measurements(++sequence); }
};

TEST_F(Control, TheTareIsTheMeanOfItsReadingsAndIsSubtracted) {
  params.tare_samples = 4;
  make();
  const Vec3 forces[4] = {{1, 2, 3}, {3, 2, 1}, {2, 2, 2}, {2, 2, 6}};  // mean (2, 2, 3)
  for (const Vec3& f : forces) {
    hal::Measurements m = next();
    m.wrist.force_n = f;
    m.wrist.torque_nm = 0.5 * f;
    c->observe(m, kDt_s, true);
  }
  EXPECT_FALSE(c->tare().running);
  EXPECT_EQ(c->tare().completed, 1u);
  EXPECT_EQ(c->tare().force_n, Vec3(2, 2, 3));
  EXPECT_EQ(c->tare().torque_nm, Vec3(1, 1, 1.5));
  hal::Measurements m = next();
  m.wrist.force_n = Vec3(12, 2, 3);
  ASSERT_EQ(c->tick(m, kDt_s, cmd), TickStatus::ok);
  EXPECT_EQ(c->wrist_force_n(), Vec3(10, 0, 0));
  {  // the WBC, the footholds and the unmeasured pushes take it in world axes: the sensor's
     // rotation at the tick's pose (kinematics computed here from the tick's state)
    const dyn::Model model;
    auto data = std::make_unique<dyn::Data>();
    dyn::compute_tick(model, *data, c->input().state.q, c->input().state.v);
    const Mat3& r = data->frames[kWristFtFrame].rotation;
    EXPECT_LT((c->input().wrist_force_world_n - r * Vec3(10, 0, 0)).norm(), 1e-12);
    EXPECT_LT((c->input().wrist_torque_world_nm - r * (m.wrist.torque_nm - Vec3(1, 1, 1.5))).norm(), 1e-12);
    EXPECT_EQ(c->output().external_force_world_n, c->input().wrist_force_world_n);
    EXPECT_GT((r * Vec3(10, 0, 0) - Vec3(10, 0, 0)).norm(), 1.0) << "the sensor's axes are not the world's here";
  }
  // A re-tare collects in stand only, never in the control mode (a push is not a bias);
  // a reading that is not valid counts as no wrench and is not collected.
  c->request_tare();
  for (int i = 0; i < 10; ++i) ASSERT_EQ(c->tick(m, kDt_s, cmd), TickStatus::ok);
  EXPECT_EQ(c->tare().samples, 0u);
  EXPECT_TRUE(c->tare().running);
  EXPECT_EQ(c->tare().force_n, Vec3(2, 2, 3));  // the last tare holds meanwhile
  m = next();
  m.wrist.force_n = Vec3(std::numeric_limits<double>::quiet_NaN(), 0, 0);
  c->observe(m, kDt_s, true);
  ASSERT_EQ(c->tick(next(), kDt_s, cmd), TickStatus::ok);
  EXPECT_EQ(c->tare().samples, 0u);
  m = next();
  m.wrist.force_n = Vec3(std::numeric_limits<double>::quiet_NaN(), 0, 0);
  ASSERT_EQ(c->tick(m, kDt_s, cmd), TickStatus::ok);
  EXPECT_EQ(c->wrist_force_n(), Vec3::Zero());
}

TEST_F(Control, ObservingWhileMovingDoesNotTare) {
  params.tare_samples = 2;
  make();
  for (int i = 0; i < 5; ++i) {
    hal::Measurements m = next();
    m.wrist.force_n = Vec3(5, 0, 0);
    c->observe(m, kDt_s, false);  // stand-up: the arm moves
  }
  EXPECT_EQ(c->tare().samples, 0u);
  EXPECT_EQ(c->tare().completed, 0u);
}

TEST_F(Control, AFailedEstimateLeavesTheCommandToTheSupervisor) {
  make();
  c->observe(next(), kDt_s, true);
  hal::Measurements m = next();
  m.imu.valid = false;  // the IMU lost
  cmd.tau_ff_nm.setConstant(42.0);
  EXPECT_EQ(c->tick(m, kDt_s, cmd), TickStatus::estimate_failed);
  EXPECT_EQ(cmd.tau_ff_nm, VecNj::Constant(42.0));
  EXPECT_EQ(c->failed_ticks(), 1u);
}

// The tick's report is what the controller did this tick: the WBC's output and rest pose,
// the estimate, the counts; a failed tick's status; an observe tick keeps the last control
// tick's status and the WBC's last values.
TEST_F(Control, TheTickReportIsTheTicksOutputAndStatus) {
  make();
  c->observe(next(), kDt_s, true);
  EXPECT_EQ(c->report().status, TickStatus::ok);
  EXPECT_FALSE(c->report().engaged);
  EXPECT_EQ(c->report().base_pose, c->estimate().q.head<7>());
  hal::Measurements m = next();
  m.wrist.force_n = Vec3(4, 0, 0);
  ASSERT_EQ(c->tick(m, kDt_s, cmd), TickStatus::ok);
  const control::TickReport& r = c->report();
  EXPECT_TRUE(r.engaged);
  EXPECT_EQ(r.status, TickStatus::ok);
  EXPECT_EQ(r.base_pose, c->estimate().q.head<7>());
  EXPECT_EQ(r.base_twist, c->estimate().v.head<6>());
  EXPECT_EQ(r.wrist_force_n, c->wrist_force_n());
  EXPECT_EQ(r.qp_status, qp::Status::optimal);
  EXPECT_EQ(r.qp_iterations, c->output().qp_iterations);
  EXPECT_EQ(r.base_rest_m, c->wbc().reference().base_position_m);
  EXPECT_EQ(r.hand_rest_m, c->wbc().reference().ee_position_m);
  EXPECT_EQ(r.hand_rest_rotation, c->wbc().reference().ee_rotation);
  EXPECT_EQ(r.hand_displacement_m, c->output().ee_displacement_m);
  EXPECT_EQ(r.hand_rotation, c->output().ee_rotation);
  EXPECT_EQ(r.external_force_world_n, c->input().wrist_force_world_n);
  EXPECT_EQ(r.unmeasured_force_world_n, c->input().unmeasured_force_world_n);
  for (int f = 0; f < kFeet; ++f) EXPECT_EQ(r.foot_force_n[f], c->output().foot_force_n[f]) << "foot " << f;
  const Vec3 hand_rest = r.hand_rest_m;
  m = next();
  m.imu.valid = false;
  ASSERT_EQ(c->tick(m, kDt_s, cmd), TickStatus::estimate_failed);
  EXPECT_EQ(c->report().status, TickStatus::estimate_failed);
  EXPECT_EQ(c->report().failed_ticks, 1u);
  EXPECT_EQ(c->report().hand_rest_m, hand_rest);  // the WBC did not run
  c->observe(next(), kDt_s, true);
  EXPECT_EQ(c->report().status, TickStatus::estimate_failed);  // the last control tick's
}

TEST_F(Control, GaitRequestsOutsideTheTrotRangesAreRefused) {
  make();
  control::GaitCommand trot;
  trot.kind = GaitKind::trot;
  trot.trot.duty_factor = 0.4;
  EXPECT_FALSE(c->request_gait(trot));
  trot.trot.duty_factor = 0.65;
  trot.trot.step_frequency_hz = std::numeric_limits<double>::quiet_NaN();
  EXPECT_FALSE(c->request_gait(trot));
  trot.trot.step_frequency_hz = 1.4;
  EXPECT_TRUE(c->request_gait(trot));
}

// Stand -> trot -> stand on measurements of a robot standing still: the trot
// alternates the diagonals; a stop lifts no new foot and stands once the swinging
// pair has landed (within one swing time).
TEST_F(Control, StandTrotStand) {
  make();
  c->observe(next(), kDt_s, true);
  ASSERT_EQ(c->tick(next(), kDt_s, cmd), TickStatus::ok);
  EXPECT_EQ(c->gait_state(), GaitState::stand);
  control::GaitCommand trot;
  trot.kind = GaitKind::trot;
  trot.trot.step_frequency_hz = 2.0;
  trot.trot.duty_factor = 0.6;
  ASSERT_TRUE(c->request_gait(trot));
  bool lifted = false;
  for (int i = 0; i < 400 && !lifted; ++i) {  // the first lift-off is within one cycle (500 ms)
    ASSERT_EQ(c->tick(next(), kDt_s, cmd), TickStatus::ok);
    EXPECT_EQ(c->gait_state(), GaitState::trot);
    lifted = c->state().stance != kAllFeet;
  }
  ASSERT_TRUE(lifted);
  const Stance down_at_stop = c->state().stance;
  EXPECT_NE(down_at_stop[0], down_at_stop[1]);  // one diagonal up
  EXPECT_EQ(down_at_stop[0], down_at_stop[3]);
  control::GaitCommand stand;
  ASSERT_TRUE(c->request_gait(stand));
  ASSERT_EQ(c->tick(next(), kDt_s, cmd), TickStatus::ok);
  EXPECT_EQ(c->gait_state(), GaitState::stopping);
  // A swinging foot lands by the plan; here it never touches (the measurements are of a
  // robot that does not move: no leg feels the ground), so it reaches down for the
  // trot's late_touchdown_s before it is put down regardless.
  const int swing_ticks = static_cast<int>(std::ceil((1.0 - 0.6) / 2.0 / kDt_s + trot.trot.late_touchdown_s / kDt_s));
  int ticks = 0;
  while (c->gait_state() != GaitState::stand && ticks <= swing_ticks + 1) {
    ASSERT_EQ(c->tick(next(), kDt_s, cmd), TickStatus::ok);
    for (int f = 0; f < kFeet; ++f) {
      if (down_at_stop[f]) {
        EXPECT_TRUE(c->state().stance[f]) << "foot " << f << " was down and lifted";
      }
    }
    ++ticks;
  }
  EXPECT_EQ(c->gait_state(), GaitState::stand);
  EXPECT_EQ(c->state().stance, kAllFeet);
  for (int i = 0; i < 600; ++i) ASSERT_EQ(c->tick(next(), kDt_s, cmd), TickStatus::ok);
  EXPECT_EQ(c->state().stance, kAllFeet);  // stays standing
}

// Walking: the template's rest pose moves with the commanded velocity, ramped; a stand
// request ramps it back to rest where it got to. Velocities outside the trot's ranges are
// refused.
TEST_F(Control, TheRestPoseWalksWithTheCommandedVelocity) {
  make();
  c->observe(next(), kDt_s, true);
  ASSERT_EQ(c->tick(next(), kDt_s, cmd), TickStatus::ok);
  const wbc::WbcReference engaged = c->wbc().reference();
  EXPECT_FALSE(c->request_velocity(Vec3(0.6, 0.0, 0.0)));
  EXPECT_FALSE(c->request_velocity(Vec3(0.0, 0.0, std::numeric_limits<double>::quiet_NaN())));
  control::GaitCommand trot;
  trot.kind = GaitKind::trot;
  trot.trot.velocity_x_m_s = 0.2;
  trot.trot.yaw_rate_rad_s = 0.3;
  ASSERT_TRUE(c->request_gait(trot));
  // The measurements stand still (the robot does not follow here): only the rest pose moves.
  constexpr int kTicks = 1000;
  for (int i = 0; i < kTicks; ++i) (void)c->tick(next(), kDt_s, cmd);
  // Ramped at 0.5 m/s^2 and 1 rad/s^2: 0.2 m/s after 0.4 s, 0.3 rad/s after 0.3 s.
  EXPECT_NEAR(c->walking_velocity().x(), 0.2, 1e-12);
  EXPECT_NEAR(c->walking_velocity().z(), 0.3, 1e-12);
  const wbc::WbcReference& now = c->wbc().reference();
  // Yaw: 0.3 rad/s for 0.7 s plus the ramp's 0.3 s at half that: 0.255 rad (+- a tick).
  const double yaw = std::atan2(now.base_rotation(1, 0), now.base_rotation(0, 0));
  EXPECT_NEAR(yaw, 0.3 * 0.7 + 0.5 * 0.3 * 0.3, 0.3 * 2 * kDt_s);
  EXPECT_NEAR((now.base_angular_velocity_rad_s - Vec3(0.0, 0.0, 0.3)).norm(), 0.0, 1e-12);
  // The base moves along its turning heading at 0.2 m/s; the hand's rest point turns with it.
  EXPECT_NEAR(now.base_velocity_m_s.norm(), 0.2, 1e-12);
  EXPECT_NEAR(std::atan2(now.base_velocity_m_s.y(), now.base_velocity_m_s.x()), yaw, 1e-9);
  const Vec3 arm0 = engaged.ee_position_m - engaged.base_position_m, arm = now.ee_position_m - now.base_position_m;
  EXPECT_NEAR(arm.norm(), arm0.norm(), 1e-12);
  EXPECT_NEAR(arm.z(), arm0.z(), 1e-12);
  EXPECT_LT((now.ee_velocity_m_s - (now.base_velocity_m_s + Vec3(0.0, 0.0, 0.3).cross(arm))).norm(), 1e-12);
  EXPECT_NEAR(now.base_position_m.z(), engaged.base_position_m.z(), 1e-12);
  // Stand: ramped to rest, and the rest pose stays where it got to.
  ASSERT_TRUE(c->request_gait(control::GaitCommand{}));
  for (int i = 0; i < 1500; ++i) (void)c->tick(next(), kDt_s, cmd);
  EXPECT_EQ(c->walking_velocity(), Vec3::Zero());
  const wbc::WbcReference stopped = c->wbc().reference();
  EXPECT_EQ(stopped.base_velocity_m_s, Vec3::Zero());
  EXPECT_EQ(stopped.base_acceleration_m_s2, Vec3::Zero());
  EXPECT_GT((stopped.base_position_m - engaged.base_position_m).norm(), 0.1);
  (void)c->tick(next(), kDt_s, cmd);
  EXPECT_EQ(c->wbc().reference().base_position_m, stopped.base_position_m);
}

// Stepping to catch a push (PushStepping), on the controller alone: a wrist push held at the
// hand whose static centre of pressure (the WBC's support_distance_m) comes within
// trigger_inside_m of the feet's edge starts, delay_s later, a trot in place (no velocity, the
// configured cycle); the robot's sensors report it standing still, so it has settled settle_s
// later and stands again (through stopping). A push that keeps the CoP further in, or the
// feature off, never steps; an operator's gait request ends it. kPush_n, sideways in world axes,
// puts the CoP a few cm from the left edge (the sensor's rotation from the tick's kinematics).
// A leg joint at its torque limit standing is a posture the stance cannot hold (a hydraulic hip
// or knee near its range's end is weak): with the WBC allowed 35 % of the joints' limits, the
// knees saturate holding the robot up with no push at all, the CoP well inside the feet: it
// steps within delay_s. With leg_torque_ratio above 1 (off), or at the full limits, it stands.
TEST_F(Control, ALegJointAtItsTorqueLimitStandingStepsInPlace) {
  for (const auto& [scale, ratio, steps] : {std::tuple{0.35, 0.95, true}, std::tuple{0.35, 1.5, false},
                                            std::tuple{1.0, 0.95, false}}) {
    params.wbc.torque_limit_scale = scale;
    params.push_stepping.leg_torque_ratio = ratio;
    make();
    hal::Measurements m = next();
    int ticks_to_step = -1;
    double knee_ratio = 0.0;
    for (int i = 0; i < 600 && ticks_to_step < 0; ++i) {
      m = next();
      m.tau_nm = cmd.tau_ff_nm;
      ASSERT_EQ(c->tick(m, kDt_s, cmd), TickStatus::ok);
      const wbc::WbcOutput& o = c->output();
      knee_ratio = std::abs(o.tau_nm[robot::kJoint_lf_kfe_joint]) / o.torque_limit_nm[robot::kJoint_lf_kfe_joint];
      if (c->stepping_for_push()) ticks_to_step = i;
    }
    EXPECT_GT(c->output().support_distance_m, 0.1) << scale << " " << ratio << ": the CoP is well inside";
    if (steps) {
      EXPECT_NEAR(knee_ratio, scale, 1e-6) << "the knee at its scaled limit";
      ASSERT_GE(ticks_to_step, 0) << "it never stepped";
      EXPECT_EQ(c->gait_state(), GaitState::trot);
    } else {
      EXPECT_EQ(ticks_to_step, -1) << scale << " " << ratio;
      EXPECT_EQ(c->gait_state(), GaitState::stand);
    }
  }
}

TEST_F(Control, APushNearTheFeetsEdgeStepsInPlaceUntilItSettles) {
  constexpr double kPush_n = 250.0;
  const dyn::Model model;
  auto data = std::make_unique<dyn::Data>();
  dyn::compute_tick(model, *data, standing_q(), VecNv::Zero());
  const Mat3 wrist_rotation = data->frames[kWristFtFrame].rotation;
  auto push_measurements = [&](double force_n) {
    hal::Measurements m = next();
    m.wrist.force_n = wrist_rotation.transpose() * Vec3(0.0, force_n, 0.0);
    m.tau_nm = cmd.tau_ff_nm;  // the drives give what was commanded (the feet's forces, the unmeasured pushes' balance)
    return m;
  };
  // The sensors report a robot that never moves: the momentum balance reads the trot's changing
  // torques as pushes of +-40 N, which the settle test would take for a changing push (its
  // push criterion is scored in the simulator, SimWbc.APushPastWhatStandingHoldsMakesTheRobotStep).
  params.push_stepping.settle_push_change_n = 1e3;
  for (const bool enabled : {true, false}) {
    params.push_stepping.enabled = enabled;
    make();
    hal::Measurements m = push_measurements(0.0);
    ASSERT_EQ(c->tick(m, kDt_s, cmd), TickStatus::ok);
    for (int i = 0; i < 400; ++i) ASSERT_EQ(c->tick(m = push_measurements(0.0), kDt_s, cmd), TickStatus::ok);
    EXPECT_GT(c->output().support_distance_m, 0.1) << "unpushed, the CoP is well inside";
    int ticks_to_step = -1, ticks_to_stand = -1;
    control::GaitState stepping_state = control::GaitState::stand;
    Vec3 stepping_velocity = Vec3::Constant(1.0);
    gait::TrotParams stepping_trot;
    test::AllocationTrap trap;  // the stepping's start and end, tick by tick
    for (int i = 0; i < 1000 && ticks_to_step < 0; ++i) {
      m = push_measurements(kPush_n);
      ASSERT_EQ(c->tick(m, kDt_s, cmd), TickStatus::ok);
      if (c->stepping_for_push()) {
        ticks_to_step = i;
        stepping_state = c->gait_state();
        stepping_velocity = c->walking_velocity();
        stepping_trot = c->trot().params();
      }
    }
    if (ticks_to_step >= 0) {
      for (int i = 0; i < 3000 && ticks_to_stand < 0; ++i) {
        m = push_measurements(kPush_n);
        ASSERT_EQ(c->tick(m, kDt_s, cmd), TickStatus::ok);
        if (c->gait_state() == control::GaitState::stand) ticks_to_stand = i;
      }
    }
    EXPECT_EQ(trap.disarm(), 0u);
    if (!enabled) {
      EXPECT_EQ(ticks_to_step, -1) << "off";
      EXPECT_EQ(c->gait_state(), control::GaitState::stand);
      EXPECT_LT(c->output().support_distance_m, params.push_stepping.trigger_inside_m) << "the push is near the edge";
      continue;
    }
    ASSERT_GE(ticks_to_step, 0) << "it never stepped";
    EXPECT_EQ(stepping_state, control::GaitState::trot);
    EXPECT_EQ(stepping_velocity, Vec3::Zero());
    EXPECT_EQ(stepping_trot.step_frequency_hz, params.gait.trot.step_frequency_hz);
    EXPECT_EQ(stepping_trot.velocity_x_m_s, 0.0);
    EXPECT_EQ(stepping_trot.velocity_gain_s, params.push_stepping.velocity_gain_s);
    // The CoP crossed trigger_inside_m some ticks after the push began (the WBC's figure is last
    // tick's), then delay_s.
    EXPECT_GE(ticks_to_step + 1, static_cast<int>(params.push_stepping.delay_s / kDt_s));
    ASSERT_GE(ticks_to_stand, 0) << "it never stood again";
    EXPECT_GE(ticks_to_stand + 1, static_cast<int>(params.push_stepping.settle_s / kDt_s));
    EXPECT_FALSE(c->stepping_for_push());
    // Stepping again, then an operator's stand request: the operator's gait from then on.
    params.push_stepping.settle_s = 1e3;
    make();
    for (int i = 0; i < 400; ++i) ASSERT_EQ(c->tick(push_measurements(0.0), kDt_s, cmd), TickStatus::ok);
    for (int i = 0; i < 1000 && !c->stepping_for_push(); ++i) ASSERT_EQ(c->tick(m = push_measurements(kPush_n), kDt_s, cmd), TickStatus::ok);
    ASSERT_TRUE(c->stepping_for_push());
    ASSERT_TRUE(c->request_gait(control::GaitCommand{}));
    ASSERT_EQ(c->tick(push_measurements(kPush_n), kDt_s, cmd), TickStatus::ok);
    EXPECT_FALSE(c->stepping_for_push());
    EXPECT_NE(c->gait_state(), control::GaitState::trot);
    params.push_stepping.settle_s = control::PushStepping{}.settle_s;
  }
}

class ControlWithEachFilter : public Control, public ::testing::WithParamInterface<est::BaseFilter> {};

TEST_P(ControlWithEachFilter, TicksDoNotAllocate) {
  params.estimator.filter = GetParam();
  make();
  c->observe(next(), kDt_s, true);
  c->tick(next(), kDt_s, cmd);
  control::GaitCommand trot;
  trot.kind = GaitKind::trot;
  std::size_t n = 0;
  {
    test::AllocationTrap trap;
    (void)c->request_gait(trot);
    for (int i = 0; i < 300; ++i) c->tick(next(), kDt_s, cmd);
    (void)c->request_velocity(Vec3(0.3, 0.1, -0.2));
    for (int i = 0; i < 100; ++i) c->tick(next(), kDt_s, cmd);
    // Live tuning (its ramp) and a hand move (the moving rest point) tick by tick.
    control::TuningRequest tune;
    tune.set[control::TuningRequest::base_stiffness] = true;
    tune.value[control::TuningRequest::base_stiffness] = {1500.0, 1500.0, 1500.0};
    tune.ramp_s = 0.05;
    const bool taken = c->request_tuning(tune) == nullptr;
    const char* hand = c->request_hand_move(Vec3(0.05, 0.0, 0.02), Vec3::Zero(), 0.3);
    for (int i = 0; i < 350; ++i) c->tick(next(), kDt_s, cmd);
    const bool tuned = !c->tuning();
    c->request_tare();
    for (int i = 0; i < 10; ++i) c->observe(next(), kDt_s, true);
    c->disengage();
    c->tick(next(), kDt_s, cmd);
    n = trap.disarm();
    EXPECT_TRUE(taken);  // checked after the trap: a failure message allocates
    EXPECT_EQ(hand, nullptr);
    EXPECT_TRUE(tuned);
  }
  EXPECT_EQ(n, 0u);
  EXPECT_EQ(c->estimate().status, est::EstimateStatus::ok);
}
INSTANTIATE_TEST_SUITE_P(Filters, ControlWithEachFilter,
                         ::testing::Values(est::BaseFilter::complementary, est::BaseFilter::ekf),
                         [](const auto& info) { return std::string(est::to_string(info.param)); });

}  // namespace
