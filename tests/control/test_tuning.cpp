// Live tuning on the Bullet robot (the firmware's controller under the supervisor, in
// stance, a 30 N push at the hand held): a retune of the template ramps its values
// linearly from the tick it is taken, the commanded torques never step (the largest
// change per tick stays that of the steady hold, where the same retune applied at once
// steps them), and the robot then renders the new template (the base settles at the new
// F / K_b). Values outside the config's ranges are refused and change nothing.
#include <algorithm>
#include <cstdio>
#include <cmath>
#include <limits>

#include <gtest/gtest.h>

#include "sim_rig.hpp"

namespace {
using namespace springbok;
using test::Rig;

control::ControlParams stance_params() {
  control::ControlParams cp;  // gait: stand
  cp.wbc.template_params.mass_base_kg.setConstant(92.0);
  cp.wbc.template_params.damping_base_ns_per_m.setConstant(610.0);
  cp.wbc.template_params.stiffness_base_n_per_m.setConstant(1000.0);
  cp.wbc.template_params.mass_ee_kg.setConstant(10.0);
  cp.wbc.template_params.damping_ee_ns_per_m.setConstant(142.0);
  cp.wbc.template_params.stiffness_ee_n_per_m.setConstant(500.0);
  return cp;
}

control::TuningRequest stiffer_base_lighter_hand(double ramp_s) {
  control::TuningRequest r;
  r.set[control::TuningRequest::base_stiffness] = true;
  r.value[control::TuningRequest::base_stiffness] = {2000.0, 2000.0, 2000.0};
  r.set[control::TuningRequest::ee_mass] = true;
  r.value[control::TuningRequest::ee_mass] = {4.0, 4.0, 4.0};
  r.set[control::TuningRequest::ee_damping] = true;
  r.value[control::TuningRequest::ee_damping] = {90.0, 90.0, 90.0};
  r.ramp_s = ramp_s;
  return r;
}

// The largest change of a commanded joint torque from one tick to the next over `ticks`.
double max_torque_step(Rig& rig, int ticks) {
  double worst = 0.0;
  VecNj last = rig.cmd.tau_ff_nm;
  for (int k = 0; k < ticks; ++k) {
    rig.tick();
    EXPECT_EQ(rig.status, control::TickStatus::ok);
    worst = std::max(worst, (rig.cmd.tau_ff_nm - last).cwiseAbs().maxCoeff());
    last = rig.cmd.tau_ff_nm;
  }
  return worst;
}

// Runs to 3 s (the push from 1 s, settled), then returns the steady hold's largest step.
double settle(Rig& rig) {
  rig.push_hand(Vec3(30.0, 0.0, 0.0), 1.0);
  while (rig.robot->ground_truth().time_s < 2.5) rig.tick();
  EXPECT_EQ(rig.supervisor.mode(), safety::Mode::control);
  return max_torque_step(rig, 500);
}

TEST(LiveTuning, ARetuneRampsTheTemplateWithoutSteppingTheTorquesAndTheNewOneIsRendered) {
  Rig rig(stance_params());
  const double steady = settle(rig);
  ASSERT_EQ(rig.control->request_tuning(stiffer_base_lighter_hand(1.0)), nullptr);
  // Half way: half way between the old and the new values.
  double worst = max_torque_step(rig, 500);
  const wbc::TemplateParams& mid = rig.control->wbc().params().template_params;
  EXPECT_NEAR(mid.stiffness_base_n_per_m.x(), 1500.0, 2.0);
  EXPECT_NEAR(mid.mass_ee_kg.y(), 7.0, 0.01);
  EXPECT_EQ(mid.mass_base_kg.x(), 92.0);  // not asked: unchanged
  EXPECT_TRUE(rig.control->tuning());
  worst = std::max(worst, max_torque_step(rig, 520));
  EXPECT_FALSE(rig.control->tuning());
  const wbc::TemplateParams& end = rig.control->wbc().params().template_params;
  EXPECT_EQ(end.stiffness_base_n_per_m, Vec3::Constant(2000.0));
  EXPECT_EQ(end.mass_ee_kg, Vec3::Constant(4.0));
  EXPECT_EQ(end.damping_ee_ns_per_m, Vec3::Constant(90.0));
  // The torques never step: measured 0.008 N m per tick at most during the ramp (the steady
  // hold 0.001), against 4.4 N m for the same retune at once (the next test).
  std::printf("largest torque change per tick: steady hold %.3f N m, during the 1 s retune %.3f N m\n", steady, worst);
  EXPECT_LT(worst, 2.0 * steady + 0.05) << "steady " << steady << " N m, during the ramp " << worst;
  // The new template rendered: the base settles at F / K_b = 30 / 2000 m.
  while (rig.robot->ground_truth().time_s < 7.0) rig.tick();
  EXPECT_NEAR(rig.control->output().base_displacement_m.x(), 30.0 / 2000.0, 0.05 * 30.0 / 2000.0);
  EXPECT_FALSE(rig.fallen());
  EXPECT_EQ(rig.supervisor.faults(), 0u);
}

TEST(LiveTuning, TheSameRetuneAtOnceStepsTheTorques) {
  Rig rig(stance_params());
  const double steady = settle(rig);
  ASSERT_EQ(rig.control->request_tuning(stiffer_base_lighter_hand(0.0)), nullptr);
  const double at_once = max_torque_step(rig, 20);
  std::printf("largest torque change per tick: steady hold %.3f N m, the same retune at once %.3f N m\n", steady, at_once);
  EXPECT_GT(at_once, 1.0) << "steady " << steady << " N m, at once " << at_once;
}

// The rotational template retuned live (the hand's stiffness 50 -> 100 N m/rad and its inertia
// 0.1 -> 0.2 kg m^2 over 1 s under a 3 N m torque about y): no torque step, and the hand then
// settles at the new T/K_rb + T/K_re; without the rotational template its keys are refused.
TEST(LiveTuning, TheRotationalTemplateRetunesLiveToo) {
  control::ControlParams cp = stance_params();
  cp.wbc.rotational_template_enabled = true;
  cp.wbc.rotational_template.inertia_ee_kgm2.setConstant(0.1);
  cp.wbc.rotational_template.damping_ee_nms_per_rad.setConstant(4.5);
  cp.wbc.rotational_template.stiffness_ee_nm_per_rad.setConstant(50.0);
  Rig rig(cp);
  rig.twist_hand(Vec3(0.0, 3.0, 0.0), 1.0);
  while (rig.robot->ground_truth().time_s < 2.5) rig.tick();
  ASSERT_EQ(rig.supervisor.mode(), safety::Mode::control);
  const double steady = max_torque_step(rig, 500);
  control::TuningRequest r;
  r.set[control::TuningRequest::rot_ee_stiffness] = true;
  r.value[control::TuningRequest::rot_ee_stiffness] = {100.0, 100.0, 100.0};
  r.set[control::TuningRequest::rot_ee_inertia] = true;
  r.value[control::TuningRequest::rot_ee_inertia] = {0.2, 0.2, 0.2};
  r.set[control::TuningRequest::rot_ee_damping] = true;
  r.value[control::TuningRequest::rot_ee_damping] = {9.0, 9.0, 9.0};
  ASSERT_EQ(rig.control->request_tuning(r), nullptr);
  const Vec3 base_inertia = rig.control->wbc().base_rotational_inertia_kgm2();
  double worst = max_torque_step(rig, 500);
  EXPECT_NEAR(rig.control->wbc().params().rotational_template.stiffness_ee_nm_per_rad.y(), 75.0, 0.2);
  worst = std::max(worst, max_torque_step(rig, 520));
  EXPECT_FALSE(rig.control->tuning());
  std::printf("largest torque change per tick: steady hold %.4f N m, during the 1 s rotational retune %.4f N m\n", steady,
              worst);
  EXPECT_LT(worst, 2.0 * steady + 0.05) << "steady " << steady << " N m, during the ramp " << worst;
  EXPECT_EQ(rig.control->wbc().base_rotational_inertia_kgm2(), base_inertia);  // I_b as engaged
  // The hand settles at T/K_rb + T/K_re about y: 3/500 + 3/100 = 36 mrad from its rest orientation.
  while (rig.robot->ground_truth().time_s < 6.0) rig.tick();
  const wbc::WbcReference& ref = rig.control->wbc().reference();
  const Eigen::AngleAxisd turned(rig.control->output().ee_rotation * ref.ee_rotation.transpose());
  EXPECT_NEAR((turned.angle() * turned.axis()).y(), 3.0 / 500.0 + 3.0 / 100.0, 0.01 * 0.036);
  EXPECT_FALSE(rig.fallen());

  Rig off(stance_params());
  while (off.supervisor.mode() != safety::Mode::control) off.tick();
  EXPECT_STREQ(off.control->request_tuning(r), "the rotational template is off (control.wbc.rotational_template)");
}

TEST(LiveTuning, ValuesOutsideTheConfigsRangesAreRefusedAndChangeNothing) {
  Rig rig(stance_params());
  while (rig.supervisor.mode() != safety::Mode::control) rig.tick();
  rig.tick();
  const wbc::TemplateParams before = rig.control->wbc().params().template_params;
  for (double bad : {0.0, -5.0, 1e9, std::numeric_limits<double>::quiet_NaN()}) {
    control::TuningRequest r;
    r.set[control::TuningRequest::base_stiffness] = true;
    r.value[control::TuningRequest::base_stiffness] = {1000.0, bad, 1000.0};
    EXPECT_STREQ(rig.control->request_tuning(r), "tuning values out of range") << bad;
  }
  control::TuningRequest ramp;
  ramp.ramp_s = -1.0;
  EXPECT_STREQ(rig.control->request_tuning(ramp), "tuning values out of range");
  control::TuningRequest kp;
  kp.set_posture_kp = true;
  kp.posture_kp_per_s2 = std::numeric_limits<double>::infinity();
  EXPECT_STREQ(rig.control->request_tuning(kp), "tuning values out of range");
  for (int k = 0; k < 10; ++k) rig.tick();
  EXPECT_EQ(rig.control->wbc().params().template_params.stiffness_base_n_per_m, before.stiffness_base_n_per_m);
  EXPECT_FALSE(rig.control->tuning());
}

}  // namespace
