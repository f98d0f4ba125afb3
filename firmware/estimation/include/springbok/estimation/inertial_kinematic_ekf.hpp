// springbok::est::InertialKinematicEkf: the trunk's state from the raw IMU and the stance
// feet's kinematics, an error-state extended Kalman filter with the IMU's biases in the
// state, after Bloesch et al., "State Estimation for Legged Robots: Consistent Fusion of
// Leg Kinematics and IMU" (RSS 2012). It knows no robot: the caller computes each foot's
// contact point from its encoders (for this robot BaseEstimator::kinematics() and
// contact_point_b() do) and its covariance (contact_point_covariance_b below).
//
// ---- frames and symbols --------------------------------------------------------------
//   W world, z up, gravity g_W = (0, 0, -g). B the trunk frame, I the IMU's frame, fixed in
//   B: R_BI maps IMU-axes vectors to trunk axes, r = p_BI is the IMU's origin relative to
//   the trunk origin in trunk axes (ImuMounting). R = R_WB maps trunk axes to world.
//   w the trunk's angular rate in trunk axes, [a]x the cross-product matrix of a.
//   Exp/Log: the rotation vector <-> rotation (quaternion) maps.
//
// ---- state ------------------------------------------------------------------------------
//   nominal (quaternion, 31 numbers)              error (27), index, how it composes
//   p    the IMU's origin, W [m]                  dp    0..2    p = p^ + dp
//   v    the IMU origin's velocity, W [m/s]       dv    3..5    v = v^ + dv
//   R    q_WB (Hamilton, unit)                    dth   6..8    R = Exp(dth) R^  (LEFT, WORLD axes)
//   d_i  foot i's contact point, W [m]            dd_i  9+3i..  d_i = d_i^ + dd_i, i = LF RF LH RH
//   b_a  accelerometer bias, I axes [m/s^2]       db_a  21..23
//   b_g  gyro bias, I axes [rad/s]                db_g  24..26
// The trunk origin's position and velocity (the outputs) are p_B = p - R r and
// v_B = v - R (w x r). The state holds the IMU point's, not the trunk origin's, because w is
// known only through each tick's gyro sample: with the trunk's velocity in the state, every
// sample's noise would enter it directly through the lever arm (white, sigma_g / sqrt(dt) |r|,
// no random walk), which the model cannot hold; the filter would be overconfident in velocity.
// At the IMU's point the lever arm leaves the propagation and enters, exactly, the kinematics
// (s_i - r) and the outputs (whose covariance carries the gyro's noise through r).
// With the rotation error in world axes the yaw error is dth_z alone and the tilt is
// (dth_x, dth_y). The absolute yaw and position are unobservable from the legs and the IMU
// (turning or moving the trunk and the feet together changes no measurement): their errors
// only drift, the yaw's unless the yaw aid is on. The yaw's drift is observable while the feet
// stand (they fix the trunk's yaw rate), so the gyro bias is, its vertical part too; a step
// carries the yaw's error into the new foothold.
//
// ---- sensors ------------------------------------------------------------------------
//   gyro    w_m = R_BI^T w + b_g + n_g                     (I axes)
//   accel   f_m = R_BI^T R^T (p'' - g_W) + b_a + n_a        (I axes), at the IMU's point p
//           (the trunk origin's acceleration is p'' - R (w' x r + w x (w x r)))
//   feet    s_i = R^T (d_i - p_B) + n_s,i = R^T (d_i - p) + r + n_s,i,
//           n_s,i ~ N(0, Sigma_i) trunk axes (the caller's)
//   legs    e_i = the contact point's velocity relative to the trunk from the joint rates
//           (trunk axes, the caller's), noise N(0, Sigma_v,i): an anchored foot's material
//           contact point stands, so v_B + R (w x s_i + e_i) = 0
//   n_g, n_a white, densities sigma_g [rad/s/sqrt(Hz)], sigma_a [m/s^2/sqrt(Hz)]: a sample
//   over dt has std sigma / sqrt(dt). The earth's rate is neglected (it goes into b_g).
//
// ---- continuous model ----------------------------------------------------------------
//   p' = v
//   v' = R f + g_W,     f = R_BI (f_m - b_a - n_a)   (trunk axes)
//   R' = R [w]x,        w = R_BI (w_m - b_g - n_g)
//   d_i' = u_i + n_d,i  u_i the anchor's known motion while anchored (the caller's, 0 for a
//                       point foot; a rolling sphere's contact point moves with it), n_d,i white,
//                       density sigma_d [m/s/sqrt(Hz)]: small while the foot is anchored, large
//                       while it is free (in swing or rejected as slipping)
//   b_a' = n_ba, b_g' = n_bg   bias random walks [m/s^3/sqrt(Hz)], [rad/s^2/sqrt(Hz)]
//
// ---- mean propagation over one tick (t0 -> t1 = t0 + dt) -------------------------------
// w_0, w_1 and f_0, f_1: the previous and this tick's samples through the mounting, both
// corrected with the current bias estimates (the first tick after a start uses this tick's
// for both, unless the start was given the sample at its instant: the calibration's last
// one, or EkfInitialState::imu). w is taken linear over the tick:
//   R_1 = R_0 Exp(W),  W = dt (w_0 + w_1) / 2 + dt^2 (w_0 x w_1) / 12   (Magnus to 2nd order)
// and the acceleration a_k = R_k f_k + g_W:
//   v_1 = v_0 + dt (a_0 + a_1) / 2,  p_1 = p_0 + dt v_0 + dt^2 (2 a_0 + a_1) / 6
// Both are second order in dt. An anchored foot: d_1 = d_0 + dt u_i.
//
// ---- linearised error dynamics ----------------------------------------------------------
// C = R^ R_BI (IMU axes to world), f_W = (R_0 f_0 + R_1 f_1) / 2 (specific force, world):
//   dp'   = dv
//   dv'   = -[f_W]x dth - C db_a - C n_a
//   dth'  = -C db_g - C n_g
//   dd_i' = n_d,i,   db_a' = n_ba,   db_g' = n_bg
// Discretisation: Phi = exp(F dt) to second order in dt (F^2 is nonzero in three blocks):
//   Phi_pv   = dt I                      Phi_pth  = -dt^2/2 [f_W]x     Phi_pba = -dt^2/2 C
//   Phi_vth  = -dt [f_W]x                Phi_vba  = -dt C              Phi_vbg = dt^2/2 [f_W]x C
//   Phi_thbg = -dt C                     every other block: I on the diagonal, 0 off it
// Process noise, each white input integrated over the tick to its leading order (the noises
// are isotropic, so the rotations C drop out):
//   Q_vv = sigma_a^2 dt I,  Q_pv = sigma_a^2 dt^2/2 I,  Q_pp = sigma_a^2 dt^3/3 I
//   Q_thth = sigma_g^2 dt I,  Q_dd,i = sigma_d,i^2 dt I,  Q_ba = sigma_ba^2 dt I,  Q_bg = sigma_bg^2 dt I
// P1 = Phi P0 Phi^T + Q: Phi = I + N with N nonzero in the p, v, th rows only, so P changes
// only in its first 9 columns (and rows): b = P_{:,0:9} + P N^T (six 27x3-by-3x3 blocks), then
// rows 0..8 of b plus N b (a 9x9 corner); not a dense 27^3 product.
//
// ---- measurements (each foot in turn: a sequential update, exact for independent noise) ---
// Foot kinematics, rotated to world with R^ (an invertible constant for the linearisation):
//   z_i = R^ (s_i - r) = (d_i - p) + R^ n_s,i      predicted  d_i^ - p^
//   H: dp -> -I,  dth -> [d_i^ - p^]x,  dd_i -> I;   noise R^ Sigma_i R^^T
//   (from R^ R^T = Exp(-dth):  R^ R^T (d - p) = (I - [dth]x)(d - p) = (d - p) + [d - p]x dth)
// Leg velocity (option, default on; in the same update as the foot's kinematics, rows after theirs):
// the stance foot's material contact point stands (leg odometry), with a = s_i - r and
// c = w x a + e_i (w this tick's corrected rate):
//   0 = v + R c + n_v,   predicted v^ + R^ c;   innovation y = -(v^ + R^ c)
//   H: dv -> I,  dth -> -[R^ c]x,  db_g -> R^ [a]x R_BI   (w x a = -[a]x w, dw/db_g = -R_BI)
//   noise R^ (Sigma_v,i + [a]x [a]x^T sigma_g^2 / dt) R^^T + leg_velocity_std^2 I
//   (the gyro sample's noise through the lever arm; its correlation with the prediction's
//   use of the same sample is neglected). Without it the velocity is known only as the
//   kinematic position's derivative over the accelerometer's integration: the low
//   frequencies of a tilt error (g dth of false acceleration) stay in the velocity for the
//   position fusion's time constant. A velocity innovation outside slip_gate_chi2, given the
//   kinematic rows (e's last three entries below), is not fused: the kinematics are, alone
//   (a touch-down's impact, a slip starting; the position's gate judges the foot).
// Flat ground (option, default on), with the kinematics of the same foot (one 4-row update):
//   d_i,z = ground height + n_h,  n_h ~ N(0, sigma_h^2);  H: dd_i,z -> 1
// Without it a foot's position and the trunk's tilt enter the kinematics only as d_i - p in
// trunk axes: the legs see no tilt, and standing still a horizontal accelerometer bias b is
// indistinguishable from a tilt of b/g. With it the feet's plane is level: the tilt is
// measured by the legs and the horizontal bias separates from it (motion also separates
// them, more slowly).
// Yaw from the IMU's own orientation output (option, default off: "only where it helps"; the
// IMU's tilt is not used, an IMU's fusion takes it from the same accelerometer):
//   yaw = atan2(R_10, R_00) of R_WI R_BI^T, innovation wrapped to (-pi, pi];
//   H: dth -> (cos(yaw) tan(pitch), sin(yaw) tan(pitch), 1);  skipped above 60 degrees of pitch.
//   It makes the absolute yaw observable (and the vertical gyro bias through steps and flight).
// Update, one per foot (3, 4, 6 or 7 rows: kinematics, ground, leg velocity): K = P H^T S^-1
// with S = H P H^T + N = L L^T, e = L^-1 y; P -= U U^T with U = P H^T L^-T (the optimal
// gain's form of Joseph's; P H^T takes H's nonzero 3-column blocks), dx = U e, injected into
// the mean after each foot (p, v, d, b added; R <- Exp(dth) R). The first rows' entries of e
// and columns of U are those rows' own update (L is lower triangular), which gives the slip
// gate (e's first three) and the update without the velocity rows when they are gated; the
// rows of one foot together are the sequential updates' result but for where H is linearised
// (all at the prior). Within a tick
// only P's lower triangle is written (the prediction and the rank-M updates, half the work);
// at the tick's end it is mirrored (P exactly symmetric) and its diagonal bounded (a row and
// column scaled down to the bound: it stays positive semidefinite).
//
// ---- outputs ------------------------------------------------------------------------
//   p_B = p - R r,  v_B = v - R (w x r),  w = R_BI (w_m - b_g) of the last accepted tick
//   dp_B = dp + [R r]x dth
//   dv_B = dv + [R (w x r)]x dth - R [r]x R_BI (db_g + n_g),  n_g the last sample's noise
//
// ---- contact, slip ------------------------------------------------------------------
// A foot is free (in swing) while the caller's stance word says no contact: its
// measurement is not used and its process noise is the free one. At touch-down its state
// is reset to the kinematic position p_B^ + R^ s_i with a large covariance decoupled from
// the rest (foot_reset_std_m), then fused: the first update puts it on its measurement and
// moves the trunk by almost nothing. An anchored foot whose kinematic innovation's
// Mahalanobis distance y^T S^-1 y (3 dof, S the 3x3 of this update) exceeds slip_gate_chi2
// is rejected: that tick's measurement is not fused, and the foot is treated as free (free
// process noise, no fusion: its weight in the estimate is nil). It is retested each tick
// against the mean of its kinematic world positions since the test began (the anchor it
// would have if it stood still, covariance (1 + 1/n) R^ Sigma R^^T, the trunk's own error
// neglected beside the kinematics'): a failure restarts the mean, slip_accept_s of passes
// accepts it, reset as at a touch-down.
//
// ---- start ------------------------------------------------------------------------
// Either a stationary calibration (the caller feeds IMU samples while the robot stands
// still): b_g = the mean rate (earth rate neglected), roll and pitch from the mean specific
// force, the trunk above the stance feet's mean contact point at the ground height, x, y
// and yaw given; b_a = 0 with its prior, and the tilt's covariance correlated with it
// (standing still the tilt estimate is off by b_a's horizontal part over g:
// dth = [e_z]x C db_a / g). Or a known initial state (start_at). The feet's covariances
// follow from d_i = p_B + R s_i, the IMU point's from p = p_B + R r, v = v_B + R (w x r)
// (w from start_at's IMU sample, 0 without one; 0 at the calibrated start, at rest).
//
// ---- inputs refused --------------------------------------------------------------------
// A non-finite sample, contact point, covariance or orientation in use, a dt outside
// (0, max_dt_s]: the tick is refused, status bad_input, state and covariance held. A tick
// whose result is not finite (it should not happen) is undone: numerical_fault.
//
// Every function called per tick is noexcept, allocation-free (fixed-size Eigen) and does
// no I/O (// rt: no alloc, no block).
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>

#include <Eigen/Cholesky>
#include <Eigen/Core>
#include <Eigen/Geometry>

namespace springbok::est {

inline constexpr int kEkfFeet = 4;      // LF RF LH RH
inline constexpr int kEkfErrorDim = 27;  // p v th d_LF d_RF d_LH d_RH b_a b_g
// Index of each block in the error state.
inline constexpr int kEkfP = 0, kEkfV = 3, kEkfTh = 6, kEkfFoot0 = 9, kEkfBa = 21, kEkfBg = 24;
inline constexpr int ekf_foot_index(int foot) noexcept { return kEkfFoot0 + 3 * foot; }

using EkfCovariance = Eigen::Matrix<double, kEkfErrorDim, kEkfErrorDim>;
using EkfVector = Eigen::Matrix<double, kEkfErrorDim, 1>;

// The IMU's mounting in the trunk (constant).
struct ImuMounting {
  Eigen::Matrix3d rotation_bi = Eigen::Matrix3d::Identity();  // IMU axes -> trunk axes
  Eigen::Vector3d position_bi_m = Eigen::Vector3d::Zero();     // IMU origin rel. trunk origin, trunk axes
};

// One raw IMU sample, the IMU's own axes.
struct ImuSample {
  Eigen::Vector3d rate_i_rad_s = Eigen::Vector3d::Zero();           // gyro
  Eigen::Vector3d specific_force_i_m_s2 = Eigen::Vector3d::Zero();  // accelerometer (at rest: +g up)
};

// One foot's measurement this tick.
struct FootMeasurement {
  bool contact = false;  // the caller's stance word
  // s_i: the ground contact point relative to the trunk origin, trunk axes, from this tick's
  // encoders [m] (for this robot BaseEstimator::kinematics(q), then contact_point_b(foot, R)
  // with the filter's last rotation_wb()).
  Eigen::Vector3d contact_point_b_m = Eigen::Vector3d::Zero();
  // Its covariance, trunk axes [m^2] (contact_point_covariance_b). Symmetric positive definite.
  Eigen::Matrix3d covariance_b_m2 = Eigen::Matrix3d::Identity() * 1e-6;
  // u_i: the anchor's known motion over the ground while in contact, world axes [m/s]: 0 for a
  // point foot; a sphere of radius r rolling without slipping moves its contact point by
  // w_shin x (r e_z) (w_shin its lower leg's angular velocity, world axes), as BaseEstimator's
  // anchors do. Not checked, and not used, without contact.
  Eigen::Vector3d anchor_velocity_w_m_s = Eigen::Vector3d::Zero();
  // e_i: the material contact point's velocity relative to the trunk from the joint rates alone,
  // trunk axes [m/s] (the leg's Jacobian times its rates, plus the rates' part of the lower
  // leg's rotation times the sphere's radius to the contact; the trunk's own rotation, w x s_i,
  // the filter adds), and its covariance [m^2/s^2]. Used with EkfParams::use_leg_velocity, in
  // contact; `velocity_valid` false: not used this tick.
  bool velocity_valid = false;
  Eigen::Vector3d velocity_b_m_s = Eigen::Vector3d::Zero();
  Eigen::Matrix3d velocity_covariance_b_m2_s2 = Eigen::Matrix3d::Identity() * 1e-4;
};
using FootMeasurements = std::array<FootMeasurement, kEkfFeet>;

struct EkfInput {
  ImuSample imu;
  FootMeasurements feet{};
  // The IMU's own orientation output (IMU frame in world), used by OrientationAid::yaw only.
  bool orientation_valid = false;
  Eigen::Quaterniond orientation_wi = Eigen::Quaterniond::Identity();
};

enum class OrientationAid : std::uint8_t {
  off,  // the IMU's orientation output is not used
  yaw,  // its yaw only (its tilt comes from the same accelerometer the filter has)
};

struct EkfParams {
  double gravity_m_s2 = 9.81;
  // IMU datasheet quantities.
  double gyro_noise_rad_s_per_sqrt_hz = 5e-4;        // angular random walk
  double accel_noise_m_s2_per_sqrt_hz = 2e-3;        // velocity random walk
  double gyro_bias_walk_rad_s2_per_sqrt_hz = 1e-5;   // rate random walk
  double accel_bias_walk_m_s3_per_sqrt_hz = 1e-4;
  // Feet: an anchored foot's drift (the contact point rolls and creeps), a free one's.
  double foot_anchored_walk_m_s_per_sqrt_hz = 1e-4;
  double foot_free_walk_m_s_per_sqrt_hz = 10.0;
  double foot_reset_std_m = 1.0;  // a foot's std at touch-down (and its bound)
  // Slip: chi-square gate on a foot's 3-dof kinematic innovation (21.1: p = 1e-4 per tick for
  // a foot that stands still); <= 0 or infinite: no gate. A rejected foot is accepted again
  // after this long standing still.
  double slip_gate_chi2 = 21.1;
  double slip_accept_s = 0.05;
  // Leg velocity: the stance feet's joint rates (leg odometry) as a velocity measurement, with
  // an isotropic term for what the kinematics do not know (impacts, the links' flex) [m/s].
  bool use_leg_velocity = true;
  double leg_velocity_std_m_s = 0.01;
  // Flat ground under the feet.
  bool use_ground = true;
  double ground_height_m = 0.0;  // world z of the contact points
  double ground_std_m = 0.005;   // the ground's departure from that plane
  // The IMU's orientation output.
  OrientationAid orientation_aid = OrientationAid::off;
  double yaw_std_rad = 0.02;
  // Stationary calibration.
  double calibration_time_s = 1.0;       // calibrate_sample says ready after this much
  int min_calibration_samples = 100;
  double max_gyro_spread_rad_s = 0.05;   // per-axis std of the rate samples above it: unstill
  double max_accel_spread_m_s2 = 0.5;    // per-axis std of the specific force above it: unstill
  double max_gravity_error_m_s2 = 1.0;   // | |mean specific force| - g | above it: bad_gravity
  // Prior stds at a start (the calibration's gyro bias and tilt take theirs from the recording).
  double initial_position_std_m = 0.01;
  double initial_velocity_std_m_s = 0.05;
  double initial_tilt_std_rad = 0.02;    // start_at only
  double initial_yaw_std_rad = 0.01;
  double initial_accel_bias_std_m_s2 = 0.2;
  double initial_gyro_bias_std_rad_s = 0.02;  // start_at only
  // Bounds.
  double max_dt_s = 0.05;
  double max_position_std_m = 1e3;
  double max_velocity_std_m_s = 1e2;
  double max_angle_std_rad = 3.0;
  double max_accel_bias_std_m_s2 = 10.0;
  double max_gyro_bias_std_rad_s = 1.0;
};

enum class EkfStatus : std::uint8_t {
  ok,               // at least one anchored foot fused this tick
  no_anchor,        // no foot fused: IMU prediction only (position and velocity drift)
  bad_input,        // a non-finite input in use or a bad dt: refused, state held
  not_started,      // no start has succeeded
  numerical_fault,  // the tick's result was not finite: undone, state held
};
const char* to_string(EkfStatus s) noexcept;

enum class CalibrationStatus : std::uint8_t {
  empty,            // no sample yet
  collecting,       // fewer than calibration_time_s of samples (usable once min_calibration_samples)
  ready,            // calibration_time_s of samples
  too_few_samples,  // evaluated with fewer than min_calibration_samples
  unstill,          // the rate's (or specific force's) spread above its threshold: refused
  bad_gravity,      // the mean specific force is not g: refused
  bad_sample,       // (calibrate_sample's answer) a non-finite sample or dt: not recorded
};
const char* to_string(CalibrationStatus s) noexcept;

struct CalibrationResult {
  CalibrationStatus status = CalibrationStatus::empty;
  int samples = 0;
  double duration_s = 0.0;
  Eigen::Vector3d gyro_bias_i_rad_s = Eigen::Vector3d::Zero();        // the mean rate
  Eigen::Vector3d gyro_spread_i_rad_s = Eigen::Vector3d::Zero();      // per-axis std of the samples
  Eigen::Vector3d specific_force_i_m_s2 = Eigen::Vector3d::Zero();    // the mean
  Eigen::Vector3d specific_force_spread_i_m_s2 = Eigen::Vector3d::Zero();
  double roll_rad = 0.0, pitch_rad = 0.0;  // of the trunk (R = Rz(yaw) Ry(pitch) Rx(roll))
};

enum class FootMode : std::uint8_t {
  free,      // not in contact: no measurement, free process noise
  anchored,  // in contact, fused
  rejected,  // in contact, but its innovation failed the slip gate: treated as free
};
const char* to_string(FootMode m) noexcept;

// A known initial state (start_at).
struct EkfInitialState {
  Eigen::Vector3d position_w_m = Eigen::Vector3d::Zero();
  Eigen::Vector3d velocity_w_m_s = Eigen::Vector3d::Zero();
  Eigen::Quaterniond orientation_wb = Eigen::Quaterniond::Identity();
  Eigen::Vector3d accel_bias_i_m_s2 = Eigen::Vector3d::Zero();
  Eigen::Vector3d gyro_bias_i_rad_s = Eigen::Vector3d::Zero();
  // The gyro bias's prior std per axis (a calibration's); zero: initial_gyro_bias_std_rad_s.
  Eigen::Vector3d gyro_bias_std_rad_s = Eigen::Vector3d::Zero();
  // The IMU's sample at the start instant, if the caller has it: the first tick's previous
  // sample (without it the first tick takes its own sample over the whole interval).
  bool has_imu = false;
  ImuSample imu;
};

// The covariance of a contact point s_i [m^2, trunk axes] from independent joint-angle noise
// (joint_std_rad, per joint) through the leg's Jacobian d s_i / d q_leg (trunk axes, at the
// identity base pose: J_feet[foot]'s three joint columns for this robot), plus an isotropic
// term for what the kinematics do not know (where on the foot it touches, the links' flex,
// the calibration of the joint zeros) [m]. rt: no alloc
Eigen::Matrix3d contact_point_covariance_b(const Eigen::Matrix3d& leg_jacobian_b_m_per_rad,
                                           const Eigen::Vector3d& joint_std_rad, double model_std_m) noexcept;

class InertialKinematicEkf {
 public:
  explicit InertialKinematicEkf(const ImuMounting& mounting, const EkfParams& params = {}) noexcept;

  // ---- start-up -----------------------------------------------------------------------
  // Records one IMU sample of a stationary robot (dt_s: the time since the last one). Returns
  // the recording's status (empty/collecting/ready) or bad_sample (not recorded). rt: no alloc
  CalibrationStatus calibrate_sample(const ImuSample& imu, double dt_s) noexcept;
  // Forgets the recording. rt: no alloc
  void restart_calibration() noexcept;
  // The recording's result so far (status ready, collecting with enough samples, or why it is
  // refused). rt: no alloc
  const CalibrationResult& evaluate_calibration() noexcept;
  const CalibrationResult& calibration() const noexcept { return calibration_; }
  // Starts from the recording: the orientation from its roll and pitch and `yaw_rad`, the trunk
  // at `xy_m` above the stance feet's contact points on the ground plane. ok, or not_started
  // (calibration().status says why), no_anchor (no foot in contact), bad_input. rt: no alloc
  EkfStatus start_from_calibration(const FootMeasurements& feet, const Eigen::Vector2d& xy_m,
                                   double yaw_rad = 0.0) noexcept;
  // Starts from a known state, the params' prior stds; the feet at p + R s_i. ok, no_anchor or
  // bad_input. rt: no alloc
  EkfStatus start_at(const EkfInitialState& initial, const FootMeasurements& feet) noexcept;

  // ---- the tick ----------------------------------------------------------------------
  // One tick of dt_s since the last: predict with this IMU sample (and the last), fuse the
  // feet (and the yaw). rt: no alloc, no block
  EkfStatus update(const EkfInput& in, double dt_s) noexcept;

  // ---- the estimate --------------------------------------------------------------------
  EkfStatus status() const noexcept { return status_; }
  bool started() const noexcept { return started_; }
  // The trunk origin's position and velocity, world axes (outputs), and v_B in trunk axes.
  const Eigen::Vector3d& position_w_m() const noexcept { return x_.p_b; }
  const Eigen::Vector3d& velocity_w_m_s() const noexcept { return x_.v_b; }
  Eigen::Vector3d velocity_b_m_s() const noexcept { return x_.q.toRotationMatrix().transpose() * x_.v_b; }
  // The IMU point's (the state's), world axes.
  const Eigen::Vector3d& imu_position_w_m() const noexcept { return x_.p; }
  const Eigen::Vector3d& imu_velocity_w_m_s() const noexcept { return x_.v; }
  const Eigen::Quaterniond& orientation_wb() const noexcept { return x_.q; }
  Eigen::Matrix3d rotation_wb() const noexcept { return x_.q.toRotationMatrix(); }
  // The last accepted tick's gyro sample less b_g through the mounting, trunk axes [rad/s].
  const Eigen::Vector3d& angular_rate_b_rad_s() const noexcept { return x_.w_b; }
  const Eigen::Vector3d& accel_bias_i_m_s2() const noexcept { return x_.b_a; }
  const Eigen::Vector3d& gyro_bias_i_rad_s() const noexcept { return x_.b_g; }
  const Eigen::Vector3d& foot_position_w_m(int foot) const noexcept { return x_.d[idx(foot)]; }
  FootMode foot_mode(int foot) const noexcept { return x_.mode[idx(foot)]; }
  bool foot_rejected(int foot) const noexcept { return foot_mode(foot) == FootMode::rejected; }
  // The last kinematic innovation's squared Mahalanobis distance of a foot (0 when not tested).
  double foot_mahalanobis2(int foot) const noexcept { return x_.mahalanobis2[idx(foot)]; }
  // The error state's covariance (p, v the IMU point's) and its diagonal.
  const EkfCovariance& covariance() const noexcept { return x_.P; }
  EkfVector covariance_diagonal() const noexcept { return x_.P.diagonal(); }
  // The trunk origin's position and velocity covariances, world axes (see outputs above; the
  // velocity's includes the last gyro sample's noise through the lever arm). rt: no alloc
  Eigen::Matrix3d trunk_position_covariance_w() const noexcept;
  Eigen::Matrix3d trunk_velocity_covariance_w() const noexcept;
  const EkfParams& params() const noexcept { return params_; }
  const ImuMounting& mounting() const noexcept { return mounting_; }

 private:
  static std::size_t idx(int foot) noexcept { return static_cast<std::size_t>(foot); }
  bool input_ok(const EkfInput& in, double dt_s) const noexcept;
  void predict(const EkfInput& in, double dt_s) noexcept;
  enum class Fused : std::uint8_t { yes, gated, failed };  // failed: S not positive definite
  // The foot's kinematics (and the ground, and its leg velocity) fused, or rejected by the
  // gate (nothing fused); w_b: this tick's corrected rate, trunk axes. rt: no alloc
  Fused fuse_foot(int foot, const FootMeasurement& m, const Eigen::Vector3d& w_b, double dt_s, bool gate) noexcept;
  void fuse_yaw(const Eigen::Quaterniond& orientation_wi) noexcept;
  // A rejected foot: one tick of its stillness test; true when it is accepted again.
  bool retest_foot(int foot, const FootMeasurement& m, double dt_s) noexcept;
  void reset_foot(int foot, const FootMeasurement& m) noexcept;
  template <int K, bool kVelocity>  // K = 4: with the ground row; kVelocity: the leg velocity's 3 rows after
  Fused fuse_foot_rows(int foot, const FootMeasurement& m, const Eigen::Vector3d& w_b, double dt_s, bool gate) noexcept;
  // The update by the first M rows: P H^T (kN x M, column-major, overwritten), the Cholesky
  // factor L of S (its lower triangle, column-major, leading dimension ld >= M) and the
  // whitened innovation L^-1 y.
  template <int M>
  void fuse(double* pht, const double* l, int ld, const double* e) noexcept;
  void inject(const EkfVector& dx) noexcept;
  // P's lower triangle mirrored, its diagonal bounded; false if an entry is not finite.
  bool condition_covariance() noexcept;
  void write_outputs(const Eigen::Vector3d& w_b) noexcept;  // the trunk's p_B, v_B from the state
  // The start shared by both: given p_B, v_B, R, the biases and the prior of (p_B, v_B, th,
  // b_a, b_g) in P, the state and its covariance (w_b: the trunk's rate at the start).
  EkfStatus finish_start(const FootMeasurements& feet, const Eigen::Vector3d& w_b) noexcept;

  ImuMounting mounting_;
  EkfParams params_;

  // Everything a tick changes (a tick that ends non-finite is undone from a copy).
  struct Filter {
    Eigen::Vector3d p = Eigen::Vector3d::Zero();
    Eigen::Vector3d v = Eigen::Vector3d::Zero();
    Eigen::Quaterniond q = Eigen::Quaterniond::Identity();
    std::array<Eigen::Vector3d, kEkfFeet> d{};
    Eigen::Vector3d b_a = Eigen::Vector3d::Zero();
    Eigen::Vector3d b_g = Eigen::Vector3d::Zero();
    EkfCovariance P = EkfCovariance::Identity();
    std::array<FootMode, kEkfFeet> mode{FootMode::free, FootMode::free, FootMode::free, FootMode::free};
    std::array<double, kEkfFeet> mahalanobis2{};
    // Rejected feet's stillness test: the mean kinematic world position, its count, time passed.
    std::array<Eigen::Vector3d, kEkfFeet> probe_mean_w_m{};
    std::array<int, kEkfFeet> probe_count{};
    std::array<double, kEkfFeet> probe_passed_s{};
    ImuSample last_imu;
    bool have_last_imu = false;
    Eigen::Vector3d w_b = Eigen::Vector3d::Zero();
    Eigen::Vector3d p_b = Eigen::Vector3d::Zero(), v_b = Eigen::Vector3d::Zero();  // outputs
    double last_dt_s = 1e-3;
  };
  Filter x_, saved_;
  bool started_ = false;
  EkfStatus status_ = EkfStatus::not_started;

  // Calibration recording (Welford's running mean and sum of squared deviations).
  int cal_n_ = 0;
  double cal_time_s_ = 0.0;
  Eigen::Vector3d cal_w_mean_ = Eigen::Vector3d::Zero(), cal_w_m2_ = Eigen::Vector3d::Zero();
  Eigen::Vector3d cal_f_mean_ = Eigen::Vector3d::Zero(), cal_f_m2_ = Eigen::Vector3d::Zero();
  ImuSample cal_last_;  // the newest sample: the first tick's previous one after the start
  CalibrationResult calibration_;
};

}  // namespace springbok::est
