// The simulated robot's sensors "as they are": what the IMU, the joint encoders, the drives'
// torque estimate and the wrist F/T report, given the world's exact values. One model, used
// by sim::BulletRobot for what read() returns and, through it, by the drive emulator for what
// it puts on the bus (tools/drive_emulator). Deterministic given the seed; after configure()
// every call is allocation-free and noexcept (fixed-size state, std::mt19937_64 engines).
//
// ---- the equations (per axis i of a triad; k the tick, dt the tick, T = 1 / rate the sample
// period of a sensor, n ~ N(0, 1) a fresh draw) ----
//   IMU triad (gyro in rad/s, accelerometer in m/s^2), at its sample instants:
//     b_i      = b0_i + w_i                    b0_i = bias_offset_i + N(0, turn_on_bias^2), drawn once per run
//     w_i     += bias_walk * sqrt(T) * n       the bias random walk (density bias_walk, per sqrt(Hz))
//     y_i      = (1 + s_i) x_i + b_i + noise * sqrt(rate) * n       s_i ~ N(0, scale_factor_std^2), once
//     y_i      = clamp(y_i, -range, range)     (clipping set when |y_i| >= range; range 0: none)
//     y_i      = lsb * round(y_i / lsb)        (lsb 0: none)
//   rate: sample_rate_hz (0: the tick rate). Below the tick rate the output holds the last
//   sample between samples; above it every tick gets a fresh sample of that rate's noise. The
//   output is delayed by delay_ticks whole ticks.
//   Orientation (IMU to world), sampled and delayed with the gyro:
//     R_meas = Exp(d + e) R_true,  d += drift sqrt(T) n  (world axes),
//     e ~ N(0, noise_rad^2) per axis and sample; both 0: exact.
//   Joint encoders: q = D round(q_true / D), D = 2 pi / (counts_per_rev gear_ratio_j);
//     qd: exact | difference (q_k - q_{k-1}) / dt | lowpass: v += a ((q_k - q_{k-1}) / dt - v),
//     a = 1 - exp(-2 pi f_c dt) (the drive's own first-order filter of its differenced encoder).
//   Joint torque (from the current): tau = tau_true + o_j + noise_j n, o_j ~ N(0, offset_j^2) once.
//   Wrist F/T, per axis: y = clamp(x + o_i + noise n, -range_i, range_i) quantised to lsb,
//     o_i(0) ~ N(0, offset^2), o_i += offset_walk sqrt(dt) n every tick (an offset that drifts).
// `ideal` (every parameter 0) reproduces the input exactly: today's sensors.
//
// ---- presets (sensor_preset(); tools/scenarios/README.md "Sensor models" gives the same table)
// Values marked (ds) are from the datasheet text we could read; (typ) are typical values we
// assume (the datasheet's specification table was not available to us, or gives no such figure).
// "+-X" offsets are read as 3-sigma bounds; a bias instability B as the walk reaching it in 100 s.
//   ideal     every sensor exact.
//   mems      IMU: Bosch BMI088 class (BST-BMI088-DS001).
//               gyro: +-2000 deg/s on 16 bits, 16.384 LSB/(deg/s) (ds: register 0x02-0x07, +-32767 for
//               +-2000 deg/s); noise density 0.014 deg/s/sqrt(Hz) (typ: the family's figure); zero-rate
//               offset +-1 deg/s read as a 3-sigma bound: turn-on std 1/3 deg/s = 5.8 mrad/s (typ);
//               bias stability 2 deg/h (typ) as a walk reaching it in 100 s; scale 0.33 % std (typ);
//               ODR 1000 Hz (a datasheet setting), delay 1 tick (typ: the ODR filter's group delay).
//               accelerometer: +-24 g on 16 bits (ds: the +-24 g range; LSB 24 g / 32768); noise
//               175 ug/sqrt(Hz) (typ; 175-190 is quoted for the axes); zero-g offset +-20 mg
//               as a 3-sigma bound: std 6.7 mg (typ); bias instability 40 ug (typ) as a walk
//               reaching it in 100 s; scale 0.33 % std (typ); ODR 800 Hz (held: one tick in five
//               repeats), delay 1 tick (typ).
//               Orientation exact: the BMI088 has no orientation output (a controller reading
//               hal::Imu::orientation reads an oracle; set imu.orientation to model an AHRS).
//   tactical  IMU: KVH 1775 class (FOG gyros, MEMS accelerometers; KVH 54-0938 technical manual).
//               gyro: angle random walk 0.012 deg/sqrt(h) (typ); bias instability 0.05 deg/h (typ) as a
//               walk reaching it in 100 s; turn-on bias std 0.5 deg/h (typ); scale 50 ppm std (typ);
//               +-490 deg/s (typ); no quantisation (float output); 1000 Hz (ds: 1 to 5000 Hz
//               selectable), delay 1 tick (typ).
//               accelerometer: 0.12 mg/sqrt(Hz) (typ); bias instability 0.05 mg (typ) as above;
//               turn-on std 0.3 mg (typ); scale 100 ppm std (typ); +-10 g (ds: the 01-0363-01
//               variant; -25 is +-25 g); 1000 Hz, delay 1 tick (typ). Orientation exact (none output).
//   mems and tactical also set the `realistic` encoders, joint torque and wrist F/T:
//     encoders   2^14 counts per motor revolution through a 10:1 gear (typ: the robot files carry
//                no gear ratio; gear_ratio takes one per joint): 38 urad at the joint; velocity by
//                differencing over the tick.
//     torque     noise std 0.5 %, offset std 1 % of each joint's effort limit (typ for a torque
//                estimated from the motor current).
//     wrist F/T  ATI Mini45 class (SI-145-5 calibration, typ): +-145 N (x, y), +-290 N (z),
//                +-5 N m; resolution 1/16 N and 1/752 N m; noise std one resolution step; a
//                turn-on offset of 1 N / 0.02 N m std (the controller's tare removes it) that
//                drifts 0.005 N/sqrt(s), 1e-4 N m/sqrt(s).
#pragma once

#include <array>
#include <cstdint>
#include <random>
#include <string>

#include "springbok/hal/types.hpp"
#include "springbok/model/model.hpp"

namespace springbok::sim {

// One triad of inertial sensors (the gyro in rad/s, the accelerometer in m/s^2: "unit" below).
struct InertialTriadConfig {
  double noise_per_sqrt_hz = 0.0;      // white noise density [unit/sqrt(Hz)]; per sample std = it * sqrt(rate)
  double bias_walk_per_sqrt_hz = 0.0;  // bias random walk density [unit/s/sqrt(Hz)]: var grows by it^2 per s
  double turn_on_bias = 0.0;           // std of the per-run constant bias [unit]
  // A known part of the turn-on bias, added to the drawn one [unit] (a test's bias of given size).
  Vec3 bias_offset = Vec3::Zero();
  double scale_factor_std = 0.0;       // std of the per-run, per-axis scale factor error [-]
  double lsb = 0.0;                    // quantisation step [unit]; 0: none
  double range = 0.0;                  // saturation at +-range [unit]; 0: none
  double sample_rate_hz = 0.0;         // output data rate; 0: the tick rate (above it: a fresh sample every tick)
  int delay_ticks = 0;                 // whole ticks, [0, kMaxSensorDelayTicks]
};

// The error of the IMU's orientation output (where it has one): a small rotation, world axes,
// R_meas = Exp(e) R_true, e = a random walk plus white noise. Both 0: exact.
struct OrientationErrorConfig {
  double drift_rad_per_sqrt_s = 0.0;   // random walk density [rad/sqrt(s)] per axis
  double noise_rad = 0.0;              // white noise std per sample and axis [rad]
};

struct ImuModelConfig {
  InertialTriadConfig gyro;            // rad/s
  InertialTriadConfig accel;           // m/s^2 (specific force)
  OrientationErrorConfig orientation;  // sampled and delayed with the gyro
};

enum class EncoderVelocity : std::uint8_t {
  exact = 0,       // the joint's velocity (ideal)
  difference = 1,  // (q_k - q_{k-1}) / dt of the quantised positions
  lowpass = 2,     // that difference through a first-order low-pass of velocity_cutoff_hz
};

struct EncoderConfig {
  double counts_per_rev = 0.0;         // counts per motor revolution; 0: the position exact
  VecNj gear_ratio = VecNj::Ones();    // motor revolutions per joint revolution (> 0)
  EncoderVelocity velocity = EncoderVelocity::exact;
  double velocity_cutoff_hz = 0.0;     // lowpass only (> 0 then)
};

struct JointTorqueConfig {
  VecNj noise_std_nm = VecNj::Zero();   // white noise std per tick
  VecNj offset_std_nm = VecNj::Zero();  // std of the per-run, per-joint offset
};

struct WristFtConfig {
  double force_noise_std_n = 0.0, torque_noise_std_nm = 0.0;            // white noise per tick and axis
  double force_offset_std_n = 0.0, torque_offset_std_nm = 0.0;          // turn-on offset std
  double force_offset_walk_n_per_sqrt_s = 0.0, torque_offset_walk_nm_per_sqrt_s = 0.0;  // its drift
  Vec3 force_range_n = Vec3::Zero(), torque_range_nm = Vec3::Zero();    // per axis; 0: none
  double force_lsb_n = 0.0, torque_lsb_nm = 0.0;                        // 0: none
};

struct SensorModelConfig {
  std::uint64_t seed = 1;              // every stream and per-run draw
  ImuModelConfig imu;
  EncoderConfig encoders;
  JointTorqueConfig joint_torque;
  WristFtConfig wrist_ft;
};

inline constexpr int kMaxSensorDelayTicks = 16;

enum class ImuPreset : std::uint8_t { ideal, mems, tactical };
enum class PartPreset : std::uint8_t { ideal, realistic };  // encoders, joint torque, wrist F/T

ImuModelConfig imu_preset(ImuPreset p) noexcept;
EncoderConfig encoder_preset(PartPreset p) noexcept;
JointTorqueConfig joint_torque_preset(PartPreset p) noexcept;
WristFtConfig wrist_ft_preset(PartPreset p) noexcept;
// ideal: everything exact; mems / tactical: that IMU and the realistic encoders, joint torque
// and wrist F/T. The seed stays 1.
SensorModelConfig sensor_preset(ImuPreset p) noexcept;

// Whether each part is exactly today's sensor (every parameter 0, the encoders exact).
bool is_ideal(const ImuModelConfig& c) noexcept;
bool is_ideal(const EncoderConfig& c) noexcept;
bool is_ideal(const JointTorqueConfig& c) noexcept;
bool is_ideal(const WristFtConfig& c) noexcept;
bool is_ideal(const SensorModelConfig& c) noexcept;

// The legacy sim.imu model (sim::ImuNoise: a white noise std per sample and a turn-on bias
// std at the tick rate) on this one: noise density = std * sqrt(step_s), turn_on_bias = std.
// The per-sample std the model then draws is std to within rounding (1e-16 relative), and its
// random stream is the legacy one: the same seed gives the same samples.
void apply_legacy_imu(double gyro_noise_rad_s, double accel_noise_m_s2, double gyro_bias_rad_s,
                      double accel_bias_m_s2, double step_s, ImuModelConfig& out) noexcept;

// Empty when `c` is usable at this tick, else what is wrong, naming the field
// ("imu.gyro.sample_rate_hz must be ..."). Start-up only (it allocates the message).
std::string check_sensor_model(const SensorModelConfig& c, double step_s);

// The exact quantities one tick's sensors measure.
struct ImuTruth {
  Vec3 angular_rate_rad_s = Vec3::Zero();   // IMU frame
  Vec3 specific_force_m_s2 = Vec3::Zero();  // IMU frame
  Quat orientation = Quat::Identity();      // IMU frame to world
};

// What the model drew and holds now (for tests and for the estimator's experiments: the
// truth of the biases an estimator estimates).
struct ImuErrorState {
  Vec3 gyro_bias_rad_s = Vec3::Zero();       // turn-on plus walk, at the newest sample
  Vec3 accel_bias_m_s2 = Vec3::Zero();
  Vec3 gyro_scale_factor = Vec3::Zero();     // s_i (y = (1 + s) x)
  Vec3 accel_scale_factor = Vec3::Zero();
  Vec3 orientation_drift_rad = Vec3::Zero(); // the walk of the orientation error, world axes
};
struct WristFtErrorState {
  Vec3 force_offset_n = Vec3::Zero();
  Vec3 torque_offset_nm = Vec3::Zero();
};

// The model. configure() once (start-up: checks, seeds, draws the per-run constants), then
// one call of each part per tick, `first` on the first tick and after a teleport (the hold
// restarts, the delay line fills with this sample, the encoders' differences restart).
class SensorModel {
 public:
  SensorModel() = default;  // ideal until configured

  std::string configure(const SensorModelConfig& c, double step_s, std::uint64_t imu_seed);
  std::string configure(const SensorModelConfig& c, double step_s) { return configure(c, step_s, c.seed); }

  // rt: no alloc, no block
  void imu(const ImuTruth& in, bool first, hal::Imu& out) noexcept;
  // rt: no alloc, no block
  void joints(const VecNj& q_rad, const VecNj& qd_rad_s, const VecNj& tau_nm, bool first, VecNj& q_out,
              VecNj& qd_out, VecNj& tau_out) noexcept;
  // rt: no alloc, no block. force and torque in the sensor frame; `out`'s force, torque and clipping.
  void wrist(const Vec3& force_n, const Vec3& torque_nm, hal::Wrench& out) noexcept;

  const SensorModelConfig& config() const noexcept { return config_; }
  ImuErrorState imu_errors() const noexcept;
  const WristFtErrorState& wrist_errors() const noexcept { return ft_; }
  const VecNj& joint_torque_offsets_nm() const noexcept { return tau_offset_nm_; }

 private:
  struct Triad {
    Vec3 bias0 = Vec3::Zero(), walk = Vec3::Zero(), scale = Vec3::Zero();
    std::int64_t ticks = 0;               // calls since the hold restarted
    std::int64_t last_sample_tick = 0;
    Vec3 held = Vec3::Zero();
    bool held_clip = false;
    struct Slot {
      Vec3 value = Vec3::Zero();
      bool clip = false;
      std::uint32_t age = 0;
    };
    std::array<Slot, kMaxSensorDelayTicks + 1> line{};
    std::int64_t written = 0;             // slots written since configure
  };
  struct Orientation {
    Quat held = Quat::Identity();
    std::array<Quat, kMaxSensorDelayTicks + 1> line{};
  };
  bool due(const InertialTriadConfig& c, Triad& t, bool first) const noexcept;
  void sample(const InertialTriadConfig& c, double white_std, Triad& t, const Vec3& truth) noexcept;
  static void delay(const InertialTriadConfig& c, Triad& t, bool first, Vec3& value, bool& clip,
                    std::uint32_t& age) noexcept;
  // One engine and its own normal distribution per stream (the distribution caches the second
  // draw of a pair: shared, one stream's settings would shift another's).
  struct Stream {
    std::mt19937_64 engine;
    std::normal_distribution<double> unit{0.0, 1.0};
    void seed(std::uint64_t s) noexcept {
      engine.seed(s);
      unit.reset();
    }
    double operator()() noexcept { return unit(engine); }
    // The legacy ImuNoise draw, kept as written there (so that its streams are unchanged).
    Vec3 gaussian3(double std_dev) noexcept { return Vec3(unit(engine), unit(engine), unit(engine)) * std_dev; }
  };

  SensorModelConfig config_;
  double step_s_ = 0.001;
  double gyro_white_std_ = 0.0, accel_white_std_ = 0.0;
  Stream imu_rng_, torque_rng_, ft_rng_;
  Triad gyro_, accel_;
  Orientation orientation_;
  Vec3 orientation_drift_ = Vec3::Zero();
  // encoders
  VecNj counts_to_rad_ = VecNj::Zero();   // D_j
  VecNj previous_q_ = VecNj::Zero();
  VecNj filtered_qd_ = VecNj::Zero();
  double lowpass_gain_ = 0.0;
  VecNj tau_offset_nm_ = VecNj::Zero();
  WristFtErrorState ft_;
};

}  // namespace springbok::sim
