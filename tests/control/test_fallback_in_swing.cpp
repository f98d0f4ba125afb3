// A failed tick in mid-swing, on the Bullet robot: the firmware's controller
// (control::RobotController) trots under the safety supervisor as in every binary,
// and its tick fails for real (a corrupt base state: the QP has no solution) while
// the left front foot is in the middle of its swing. The supervisor alone decides
// the command then: the last good one, i.e. the trot's (torque mode, the swinging
// leg's swing torques), not a four-feet stance or a joint-PD hold. Two failed ticks
// (below the streak of 3): the trot goes on, the foot lands, nothing faults. Three
// in a row: the streak latches the damping mode.
#include <gtest/gtest.h>

#include "sim_rig.hpp"

namespace {
using namespace springbok;
using test::Rig;

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
