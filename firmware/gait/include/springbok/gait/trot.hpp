// Trotting in place (SPEC section 5): the diagonal pairs {lf, rh} and {rf, lh}
// alternate, half a cycle apart, at step frequency f_s with duty factor d_f
// (stance time over cycle time); with d_f > 0.5 all four feet are on the ground
// for (d_f - 0.5) / f_s twice per cycle.
//
// Footholds: under the hip, i.e. the foot's nominal position relative to the
// trunk (taken at start()), moved by the base velocity as in the Reactive
// Control Framework's heuristic (Barasuol et al., ICRA 2013):
//     rho_td = rho_nominal + s + (T_stance / 2) v_hip + k_v (v_xy - v_xy^d),
//     v_hip = v_xy + w_z e_z x rho_nominal (the hip's velocity when the trunk turns),
// where s shifts the whole pattern so that its centre, where the two diagonals
// cross, lies on the ground under the point the robot's weight and external load
// call for (the static zero-moment point, dyn::static_zmp). A trot stands on one diagonal at
// a time; ground forces on the feet of a diagonal have no moment about the line
// through them, so a load whose ZMP is off that line tips the trunk about it
// (with d_f 0.55, 90 % of the cycle). With the arm forward and to one side the
// hips' pattern leaves the ZMP 3-6 cm off both diagonals.
// The foothold is re-planned on every tick of the swing (fixed at lift-off it answered a
// sideways sway a third of a second late: with d_f 0.55 a 0.43 Hz sway grew until the
// robot fell after 10 s).
// Swing: from the lift-off point to the foothold in T_swing = (1 - d_f) / f_s,
// horizontally along a quintic (zero velocity and acceleration at both ends),
// vertically the same plus a bump of height h, 64 s^3 (1 - s)^3 (peak h at
// mid-swing, zero velocity and acceleration at both ends).
//
// Frames: the plan is made in the trunk's horizontal frame H (origin at the trunk
// origin, axes the trunk's yaw only), so a tilted trunk neither moves the
// footholds on the ground nor lands a foot early or late (in trunk axes a 4.5 deg
// roll and 2 deg pitch put a hind foot's target 3 cm above the ground: it touched
// down 60 ms late and left the robot on one leg). The references handed to the WBC's swing task
// are in trunk axes, rotated by the trunk's current tilt R_t (roll and pitch:
// R = R_yaw R_t).
//
// Touch-down from the leg's own measurements (the estimated ground force on each
// foot, springbok::est::FootForceObserver; touchdown_force > 0): a foot in the second
// half of its swing whose normal force has exceeded touchdown_force for
// kTouchdownConfirmTicks ticks is in stance from then on (early touch-down: it lands
// where it is instead of being driven on into the ground). A foot the schedule puts
// down that has not touched keeps going down at kLateTouchdownSpeed_m_s below its
// foothold until it touches, for at most late_touchdown seconds (late touch-down:
// lower ground, or a trunk higher than planned), then stance regardless.
// Force ramps (force_ramp > 0, with the estimated forces): over T_r = min(force_ramp,
// (d_f - 0.5) / f_s), the time both diagonals are down, a foot about to lift is unloaded
// linearly from the normal force it had when the ramp began to ~0, and a foot that has
// touched down may take at most the same fraction of a diagonal foot's share of the
// load (half the feet's summed normal force then) (ContactPlan::normal_force_cap_n,
// the WBC's bound on f_z). Unloading starts only once the other diagonal is down.
// Without ramps a stance foot's force stepped by ~500 N at lift-off.
#pragma once

#include <array>
#include <cstdint>
#include <limits>

#include <Eigen/Core>

#include "springbok/model/model.hpp"
#include "springbok/model/robot_state.hpp"

namespace springbok::gait {

struct TrotParams {
  double step_frequency_hz = 1.4;
  double duty_factor = 0.65;
  double step_height_m = 0.08;
  double velocity_gain_s = 0.0;      // k_v of the foothold correction
  double touchdown_depth_m = 0.005;  // the foothold this far below the nominal (the foot lands, not hovers)
  double touchdown_force_n = 25.0;   // estimated normal force that is a touch-down (0: the schedule only)
  double late_touchdown_s = 0.04;    // a late foot reaches down for at most this long
  double force_ramp_s = 0.03;        // normal force ramps at touch-down and lift-off (0: none)
  // The commanded trunk velocity in its horizontal frame H (walking; 0: in place): the
  // template's rest pose moves along it (springbok::control) and the footholds follow.
  double velocity_x_m_s = 0.0;
  double velocity_y_m_s = 0.0;
  double yaw_rate_rad_s = 0.0;
};

// The one table of the trot's parameters: key, member, range (the config's reader,
// springbok::params, and the operator's requests alike).
struct TrotField {
  const char* key;
  double TrotParams::*member;
  double lo, hi;
};
inline constexpr std::array<TrotField, 11> kTrotFields{{
    {"step_frequency", &TrotParams::step_frequency_hz, 0.1, 5.0},
    {"duty_factor", &TrotParams::duty_factor, 0.5, 0.95},
    {"step_height", &TrotParams::step_height_m, 0.0, 0.3},
    {"velocity_gain", &TrotParams::velocity_gain_s, 0.0, 1.0},
    {"touchdown_depth", &TrotParams::touchdown_depth_m, 0.0, 0.05},
    {"touchdown_force", &TrotParams::touchdown_force_n, 0.0, 2000.0},
    {"late_touchdown", &TrotParams::late_touchdown_s, 0.0, 0.2},
    {"force_ramp", &TrotParams::force_ramp_s, 0.0, 0.2},
    {"velocity_x", &TrotParams::velocity_x_m_s, -0.5, 0.5},   // what the trot is built for:
    {"velocity_y", &TrotParams::velocity_y_m_s, -0.2, 0.2},   // 0.5 m/s forward, 0.2 sideways,
    {"yaw_rate", &TrotParams::yaw_rate_rad_s, -0.5, 0.5},     // 0.5 rad/s
}};
static_assert(kTrotFields[kTrotFields.size() - 3].member == &TrotParams::velocity_x_m_s &&
                  kTrotFields[kTrotFields.size() - 2].member == &TrotParams::velocity_y_m_s &&
                  kTrotFields[kTrotFields.size() - 1].member == &TrotParams::yaw_rate_rad_s,
              "the walking velocity is kTrotFields' last three (params::read_walking_velocity)");
// The key of the first parameter outside kTrotFields' ranges (or not finite),
// nullptr when all are within. rt: no alloc
const char* trot_params_error(const TrotParams& p) noexcept;

struct SwingReference {
  Vec3 position_m = Vec3::Zero();      // foot relative to the trunk origin, trunk axes
  Vec3 velocity_m_s = Vec3::Zero();
  Vec3 acceleration_m_s2 = Vec3::Zero();
};

// Touch-down detection's constants (the thresholds are TrotParams').
inline constexpr int kTouchdownConfirmTicks = 2;       // consecutive ticks above touchdown_force
inline constexpr double kTouchdownWindow = 0.5;         // from this fraction of the swing on
inline constexpr double kLateTouchdownSpeed_m_s = 0.25; // a late foot's descent below its foothold

inline constexpr double kNoCap = std::numeric_limits<double>::infinity();

// Where a foot is in its cycle.
enum class FootPhase : std::uint8_t {
  stance = 0,        // on the ground by the schedule
  swing = 1,
  landed_early = 2,  // touched down before the schedule's end of swing: in stance
  late = 3,          // the schedule's stance began and it has not touched: reaching down
};

struct ContactPlan {
  Stance stance = kAllFeet;
  std::array<SwingReference, kFeet> swing{};  // meaningful where !stance
  std::array<double, kFeet> phase{};          // the foot's phase in its cycle, [0, 1): stance below d_f
  std::array<FootPhase, kFeet> foot{};        // stance where stance[f] is stance or landed_early
  // The force ramps' bound on each stance foot's normal force, N (infinity: none).
  std::array<double, kFeet> normal_force_cap_n{kNoCap, kNoCap, kNoCap, kNoCap};
  std::uint64_t early_touchdowns = 0;         // since start()
  std::uint64_t late_touchdowns = 0;
};

// The estimated normal force on each foot (world z, N) for touch-down detection;
// valid = false: the schedule alone decides.
struct ContactSense {
  std::array<double, kFeet> normal_force_n{};
  bool valid = false;
};

// Quintic blend 10 s^3 - 15 s^4 + 6 s^5 and the bump 64 s^3 (1 - s)^3 with their
// first two derivatives in s, for s in [0, 1].
struct Profile {
  double value, rate, curvature;
};
Profile quintic_blend(double s) noexcept;
Profile swing_bump(double s) noexcept;

class TrotGait {
 public:
  explicit TrotGait(const TrotParams& params) noexcept;

  // Starts the cycle at time 0 with every foot in stance at `nominal_feet_h`
  // (foot positions relative to the trunk, frame H: the footholds' pattern).
  void start(const std::array<Vec3, kFeet>& nominal_feet_h) noexcept;

  // The plan at time t_s since start(), given the feet's current positions, the
  // trunk's linear velocity and the shift s of the footholds' pattern (all in
  // frame H), and the trunk's tilt R_t (trunk axes to H axes). A foot's lift-off
  // point is its position on its first swing tick; its foothold is re-planned on
  // every tick of the swing from that tick's velocity and shift.
  // The swing references come out in trunk axes. rt: no alloc
  // `commanded_velocity_h` is v^d (x, y in H), `yaw_rate_rad_s` the trunk's measured w_z.
  // `sense` (may be null) is this tick's touch-down evidence.
  const ContactPlan& update(double t_s, const std::array<Vec3, kFeet>& feet_h, const Vec3& base_velocity_h,
                            const Vec3& pattern_shift_h = Vec3::Zero(), const Mat3& tilt = Mat3::Identity(),
                            const Vec3& commanded_velocity_h = Vec3::Zero(), double yaw_rate_rad_s = 0.0,
                            const ContactSense* sense = nullptr) noexcept;

  // The centre of the nominal footholds (mean of start()'s feet), frame H.
  const Vec3& nominal_centre_h() const noexcept { return nominal_centre_h_; }

  const ContactPlan& plan() const noexcept { return plan_; }
  const TrotParams& params() const noexcept { return params_; }
  double stance_duration_s() const noexcept { return params_.duty_factor / params_.step_frequency_hz; }
  double swing_duration_s() const noexcept { return (1.0 - params_.duty_factor) / params_.step_frequency_hz; }

 private:
  TrotParams params_;
  std::array<Vec3, kFeet> nominal_h_{};
  Vec3 nominal_centre_h_ = Vec3::Zero();
  std::array<Vec3, kFeet> liftoff_h_{};
  std::array<Vec3, kFeet> touchdown_h_{};
  std::array<double, kFeet> touchdown_s_{};  // when each foot last touched down (start: long ago)
  std::array<double, kFeet> late_since_s_{};
  std::array<int, kFeet> touching_ticks_{};
  std::array<double, kFeet> ramp_from_n_{};  // a foot's normal force when its ramp began (NaN: not begun)
  ContactPlan plan_;
};

}  // namespace springbok::gait
