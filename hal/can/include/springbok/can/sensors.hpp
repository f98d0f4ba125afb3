// The two sensors on the CAN bus, CAN.md section 6: the trunk IMU (three frames per
// sample) and the wrist force/torque sensor (two frames per sample). Both push at
// their own rate; fields little-endian int16, byte 6 the sample counter, byte 7 the
// status. Pure codecs and fixed-size assemblers: no I/O, no allocation, noexcept.
#pragma once

#include <array>
#include <cstdint>
#include <limits>
#include <string>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "springbok/can/frame.hpp"

namespace springbok::can {

inline constexpr int kSensorFrameLen = 8;
inline constexpr int kImuFrames = 3;  // orientation, angular rate, acceleration
inline constexpr int kFtFrames = 2;   // force, torque

// Status byte (byte 7), CAN.md 6.1.
namespace sensor_status {
inline constexpr std::uint8_t valid = 0x01;      // 0 = the sensor's own fault: no sample
inline constexpr std::uint8_t not_ready = 0x02;  // IMU: orientation not converged; F/T: bias not taken
inline constexpr std::uint8_t clipping = 0x04;   // a field saturated in this sample
inline constexpr std::uint8_t reserved = 0xF8;   // must be zero
}  // namespace sensor_status

// Frame index within a sample (the order of the ids in the config).
namespace imu_frame {
inline constexpr int orientation = 0;
inline constexpr int rate = 1;
inline constexpr int accel = 2;
}  // namespace imu_frame
namespace ft_frame {
inline constexpr int force = 0;
inline constexpr int torque = 1;
}  // namespace ft_frame

// ---- configuration (start-up data) ---------------------------------------------------
struct ImuScales {
  double orientation_per_count = 1.0 / 32768.0;  // 2^-15
  double rate_rad_s_per_count = 1.0 / 1024.0;    // 2^-10
  double accel_m_s2_per_count = 1.0 / 512.0;     // 2^-9
};

struct ImuConfig {
  bool enabled = false;                 // the `can.sensors.imu` section is present
  std::string bus;                      // the name of the bus it is on
  std::array<std::uint32_t, kImuFrames> ids{0x6A0, 0x6A1, 0x6A2};
  ImuScales scales;
  std::uint32_t stale_ticks = 3;        // newest complete sample older than this: lost
  std::uint32_t clip_streak = 10;       // this many clipped samples in a row: a clipping streak
  double rate_hz = 1000.0;              // samples per second (bus load)
};

// The sensor frame in the end-effector frame, URDF `origin` convention (fixed-axis
// roll-pitch-yaw: R = Rz(yaw) Ry(pitch) Rx(roll)).
struct SensorOffset {
  std::array<double, 3> xyz_m{};
  std::array<double, 3> rpy_rad{};
};

struct FtConfig {
  bool enabled = false;                 // the `can.sensors.wrist_ft` section is present
  std::string bus;
  std::array<std::uint32_t, kFtFrames> ids{0x6B0, 0x6B1};
  double counts_per_n = 64.0;           // CPF
  double counts_per_nm = 1000.0;        // CPT
  std::uint32_t stale_ticks = 3;
  std::uint32_t clip_streak = 10;
  std::uint32_t tare_samples = 500;     // carried for the firmware's tare (CAN.md 6.2); not used here
  bool has_offset = false;              // false: the sensor frame is the end-effector frame
  SensorOffset offset;
  double rate_hz = 1000.0;
};

struct SensorsConfig {
  ImuConfig imu;
  FtConfig wrist_ft;
};

// ---- one frame ------------------------------------------------------------------------------
struct SensorFrameFields {
  std::array<std::int16_t, 3> v{};
  std::uint8_t counter = 0;
  std::uint8_t status = 0;
};

// rt: no alloc, no block. wrong_dlc unless a classic data frame of exactly 8 bytes;
// error_frame for an error frame. The status byte is returned as is (the assembler judges it).
FrameStatus decode_sensor_frame(const Frame& f, SensorFrameFields& out) noexcept;
// rt: no alloc, no block
void encode_sensor_frame(std::uint32_t id, const SensorFrameFields& in, Frame& out) noexcept;

// Counts <-> physical values. `encode_*` round to nearest and saturate at the int16 range,
// returning true when a field saturated (the sensor then sets the clipping bit); a
// non-finite value encodes as 0 and counts as saturated.
// rt: no alloc, no block
Eigen::Vector3d decode_scaled(const std::array<std::int16_t, 3>& v, double unit_per_count) noexcept;
bool encode_scaled(const Eigen::Vector3d& x, double unit_per_count, std::array<std::int16_t, 3>& out) noexcept;
Eigen::Vector3d decode_counts(const std::array<std::int16_t, 3>& v, double counts_per_unit) noexcept;
bool encode_counts(const Eigen::Vector3d& x, double counts_per_unit, std::array<std::int16_t, 3>& out) noexcept;

// The sum of squares a quaternion's vector part may reach (CAN.md 6.1: above is corrupt).
inline constexpr double kMaxQuaternionSquares = 1.0 + 1.0 / 1024.0;
// q_x, q_y, q_z from counts, q_w = +sqrt(max(0, 1 - |q_xyz|^2)). False (q untouched) when
// |q_xyz|^2 > 1 + 2^-10: a corrupt frame.
// rt: no alloc, no block
bool decode_quaternion(const std::array<std::int16_t, 3>& xyz, double per_count, Eigen::Quaterniond& q) noexcept;
// The sensor side: normalised, sign chosen so that q_w >= 0, the vector part encoded. True
// only when q has no direction (not finite, or zero): a component of 1 goes out as 32767
// (within the resolution), which is no clipping.
bool encode_quaternion(const Eigen::Quaterniond& q, double per_count, std::array<std::int16_t, 3>& out) noexcept;

// q_w where the wire leaves it vague. The sender rounds q_x, q_y, q_z to the nearest count, so
// the true |q_xyz| lies within the counts +- half a count each, and q_w = sqrt(1 - |q_xyz|^2)
// anywhere in the matching interval. Its width is about (count x |q_xyz|) / q_w: negligible
// for q_w near 1, but where q_w is small (the trunk IMU is mounted upside down, so in stance
// q_w ~ pitch / 2) up to 0.007, 0.014 rad about one axis, and decode_quaternion's
// sqrt(max(0, .)) of a noisy argument is biased upwards there: the firmware then sees the
// trunk pitched by a few mrad that it is not. The track keeps the set of q_w (signed, in a
// hemisphere that follows the samples: the wire's q_w >= 0 convention flips q_xyz when q_w
// changes sign, which says on which side of zero it is) still consistent with every sample:
// the previous set moved by what the sample's angular rate predicts and widened by the rate's
// uncertainty, intersected with the sample's interval (a fresh start from the sample's
// interval when they disagree). The estimate is the gyro's prediction clamped into that set,
// so it moves smoothly and never leaves what the wire allows; a fresh start takes CAN.md 6.1's
// q_w = sqrt(max(0, 1 - |q_xyz|^2)).
// The gyro misses what turns slower than its count (1 mrad/s) and a still trunk never narrows
// the set: the track then sits where it was, mrad from the truth (the HIL push: the base 1.2
// mm, 4 %, past its static displacement). The accelerometer sees gravity's direction, which
// pins q_w where the wire does not (|d(R^T e_z)/dq_w| ~ 2 for the upside-down IMU): the
// prediction is pulled towards the q_w that fits it, slowly (kAccelTimeConstant_s), and only
// while |a| is within 10 % of g (not an impact, not a stride's push-off).
class OrientationTrack {
 public:
  // Rate uncertainty (rad/s) the set widens by: rounding of the rate plus a gyro's bias.
  static constexpr double kRateUncertainty_rad_s = 0.01;
  // How slowly gravity's direction corrects the gyro's q_w [s]. A trunk that accelerates
  // forwards looks pitched to an accelerometer (the HIL push: 0.33 m/s^2 at the step); at
  // 10 s that costs < 0.4 mrad, at 5 s the push's base NRMSE rose 1.7 -> 2.9 % (the twin).
  static constexpr double kAccelTimeConstant_s = 10.0;

  void reset() noexcept { started_ = false; }
  // One accepted sample: its q_xyz counts, its angular rate (sensor frame) and the time since
  // the previous accepted sample (<= 0 or not finite: start afresh from this sample).
  // `accel_m_s2`: the sample's specific force, sensor frame (not finite: gyro and wire only).
  // Returns the orientation, q_w >= 0, q_xyz as sent (not normalised, as decode_quaternion).
  // The counts must have passed decode_quaternion.
  // rt: no alloc, no block
  Eigen::Quaterniond update(const std::array<std::int16_t, 3>& xyz, double per_count,
                            const Eigen::Vector3d& rate_rad_s, const Eigen::Vector3d& accel_m_s2,
                            double dt_s) noexcept;

 private:
  bool started_ = false;
  Eigen::Quaterniond q_ = Eigen::Quaterniond::Identity();  // the track, in its own hemisphere
  Eigen::Vector3d rate_rad_s_ = Eigen::Vector3d::Zero();   // of the previous sample
  double lo_ = 0.0, hi_ = 0.0;                             // the consistent set of q_w (signed)
};

// The wrench measured in the sensor frame, expressed in (and about the origin of) the
// end-effector frame, for a sensor at `offset` in the EE frame; and back (the emulator).
struct WrenchTransform {
  Eigen::Matrix3d rotation = Eigen::Matrix3d::Identity();      // EE <- sensor
  Eigen::Vector3d translation_m = Eigen::Vector3d::Zero();     // sensor origin in the EE frame
};
WrenchTransform wrench_transform(const SensorOffset& offset) noexcept;
// rt: no alloc, no block
void wrench_sensor_to_ee(const WrenchTransform& t, const Eigen::Vector3d& force_s_n, const Eigen::Vector3d& torque_s_nm,
                         Eigen::Vector3d& force_ee_n, Eigen::Vector3d& torque_ee_nm) noexcept;
void wrench_ee_to_sensor(const WrenchTransform& t, const Eigen::Vector3d& force_ee_n, const Eigen::Vector3d& torque_ee_nm,
                         Eigen::Vector3d& force_s_n, Eigen::Vector3d& torque_s_nm) noexcept;

// ---- assembling samples -------------------------------------------------------------------
// What one pushed frame did.
enum class SensorEvent : std::uint8_t {
  stored = 0,           // kept, its sample not complete yet
  accepted = 1,         // completed the newest sample, which was accepted
  wrong_dlc = 2,        // frame rejected: not 8 data bytes (or an error frame)
  reserved_bits = 3,    // sample rejected: non-zero reserved status bits
  status_invalid = 4,   // sample rejected: valid bit clear in one of its frames
  bad_quaternion = 5,   // sample rejected: |q_xyz|^2 > 1 + 2^-10
  counter_jump = 6,     // sample rejected: counter advanced by more than stale_ticks (counting resyncs to it)
  stale_counter = 7,    // sample rejected: the counter of the last complete sample again
  late_frame = 8,       // frame ignored: its sample is older than the newest complete one
};
const char* to_string(SensorEvent e) noexcept;

// Per-sensor counts for the log and the safety layer.
struct SensorDiagnostics {
  std::uint64_t frames = 0;              // frames with one of the sensor's ids
  std::uint64_t samples_accepted = 0;
  std::uint64_t wrong_dlc = 0;           // frames
  std::uint64_t reserved_bits = 0;       // samples
  std::uint64_t status_invalid = 0;      // samples
  std::uint64_t bad_quaternion = 0;      // samples
  std::uint64_t counter_jumps = 0;       // samples
  std::uint64_t stale_counters = 0;      // samples
  std::uint64_t late_frames = 0;         // frames
  std::uint64_t duplicate_frames = 0;    // a frame of a pending sample replaced by a newer copy
  std::uint64_t incomplete_dropped = 0;  // partial samples superseded by a newer complete one (or evicted)
  std::uint64_t clipped = 0;             // accepted samples with the clipping bit (used, counted)
  std::uint32_t clip_streak = 0;         // accepted samples in a row with the clipping bit, but for one that
                                         // may mean a unit quaternion's 1 (see SampleAssembler::configure)
  std::uint32_t clip_streak_max = 0;
  bool clip_streak_fault = false;        // clip_streak >= the configured clip_streak (now)
  bool have_sample = false;              // a sample was accepted since configure
  std::uint64_t age_ticks = 0;           // ticks since the newest accepted sample (since reset if none)
  bool lost = true;                      // no sample, or age_ticks > stale_ticks
  std::uint64_t lost_events = 0;         // transitions to lost after having had a sample
  bool not_ready = false;                // status bit 1 of the newest accepted sample
  std::uint8_t last_counter = 0;         // of the newest accepted sample
  std::uint8_t last_status = 0;
};

// The newest complete sample of an N-frame sensor, by counter. A fixed table of partial
// samples (kSlots) lets frames of consecutive samples interleave and a sample's frames
// straddle ticks; frames of different counters are never mixed. Counter arithmetic is
// modulo 256 (wrap-around).
template <int N>
class SampleAssembler {
 public:
  static constexpr int kSlots = 4;
  struct Sample {
    std::array<std::array<std::int16_t, 3>, N> fields{};
    std::uint8_t counter = 0;
    std::uint8_t status = 0;  // OR of the frames' status bytes
    std::uint64_t tick = 0;   // when it completed
  };

  SampleAssembler() = default;
  // ranged_frames: the frames (bit i = frame i) whose fields are measurements with a range. A
  // clipped sample counts toward the streak unless the bit may be about a field of another frame
  // at the int16 rail with none of theirs there: a unit quaternion's component of 1 cannot be
  // sent (2^15 counts) and may be flagged by a sensor as saturated, but nothing was out of range
  // (the IMU mounted upside down in hyq_gen3.urdf reads q_y ~ 1 whenever the trunk is level).
  // A saturated measurement need not sit at the rail (an F/T torque range of 32.7 N m is 32700
  // counts; a saturated gauge leaves the six axes anywhere): the bit alone says so.
  void configure(std::uint32_t stale_ticks, std::uint32_t clip_streak, std::uint64_t tick,
                 std::uint32_t ranged_frames = (1u << N) - 1u) noexcept {
    stale_ticks_ = stale_ticks;
    clip_streak_limit_ = clip_streak;
    ranged_frames_ = ranged_frames;
    reset(tick);
  }
  void reset(std::uint64_t tick) noexcept {
    slots_ = {};
    newest_ = Sample{};
    diag_ = SensorDiagnostics{};
    have_ref_ = false;
    ref_counter_ = 0;
    ref_tick_ = tick;
    reset_tick_ = tick;
  }

  // One frame `index` (0..N-1) of this sensor at `tick`. `corrupt`: the caller's content
  // check of this frame failed (the IMU's quaternion).
  // rt: no alloc, no block
  SensorEvent push(int index, const Frame& f, bool corrupt, std::uint64_t tick) noexcept {
    ++diag_.frames;
    SensorFrameFields ff;
    if (index < 0 || index >= N || decode_sensor_frame(f, ff) != FrameStatus::ok) {
      ++diag_.wrong_dlc;
      return SensorEvent::wrong_dlc;
    }
    return push_fields(index, ff, corrupt, tick);
  }

  // rt: no alloc, no block
  SensorEvent push_fields(int index, const SensorFrameFields& ff, bool corrupt, std::uint64_t tick) noexcept {
    const std::uint8_t c = ff.counter;
    // A frame older than the newest complete sample, while the stream is live, is late.
    if (have_ref_ && tick - ref_tick_ <= stale_ticks_ && ahead(ref_counter_, c) >= 128) {
      ++diag_.late_frames;
      return SensorEvent::late_frame;
    }
    Slot* slot = nullptr;
    for (Slot& s : slots_) {
      if (s.used && s.sample.counter == c) slot = &s;
    }
    if (slot == nullptr) {
      for (Slot& s : slots_) {
        if (!s.used && slot == nullptr) slot = &s;
      }
    }
    if (slot == nullptr) {  // evict the partial sample the furthest behind c
      int worst = -1;
      for (Slot& s : slots_) {
        const int behind = ahead(s.sample.counter, c);
        if (behind > worst) {
          worst = behind;
          slot = &s;
        }
      }
      ++diag_.incomplete_dropped;
      slot->used = false;
    }
    if (!slot->used) {
      *slot = Slot{};
      slot->used = true;
      slot->sample.counter = c;
    }
    const auto bit = static_cast<std::uint8_t>(1u << index);
    if ((slot->mask & bit) != 0) ++diag_.duplicate_frames;  // keep the newest copy
    slot->mask = static_cast<std::uint8_t>(slot->mask | bit);
    slot->sample.fields[static_cast<std::size_t>(index)] = ff.v;
    slot->sample.status = static_cast<std::uint8_t>(slot->sample.status | ff.status);
    slot->invalid = slot->invalid || (ff.status & sensor_status::valid) == 0;
    slot->corrupt = slot->corrupt || corrupt;
    if (slot->mask != kComplete) return SensorEvent::stored;
    return complete(*slot, tick);
  }

  // Once per tick, after the tick's frames: age and lost.
  // rt: no alloc, no block
  void update(std::uint64_t tick) noexcept {
    const bool was_lost = diag_.lost;
    diag_.age_ticks = tick - (diag_.have_sample ? newest_.tick : reset_tick_);
    diag_.lost = !diag_.have_sample || diag_.age_ticks > stale_ticks_;
    if (diag_.lost && !was_lost) ++diag_.lost_events;
  }

  // The newest accepted sample is recent enough (update() first).
  bool usable() const noexcept { return !diag_.lost; }
  const Sample& newest() const noexcept { return newest_; }
  const SensorDiagnostics& diagnostics() const noexcept { return diag_; }
  std::uint32_t stale_ticks() const noexcept { return stale_ticks_; }

 private:
  static constexpr std::uint8_t kComplete = static_cast<std::uint8_t>((1u << N) - 1u);
  struct Slot {
    bool used = false;
    std::uint8_t mask = 0;
    bool invalid = false;
    bool corrupt = false;
    Sample sample;
  };
  // How far `to` is ahead of `from`, modulo 256 (0..255; >= 128 reads as behind).
  static int ahead(std::uint8_t from, std::uint8_t to) noexcept { return static_cast<std::uint8_t>(to - from); }

  SensorEvent complete(Slot& slot, std::uint64_t tick) noexcept {
    const Sample s = slot.sample;
    const bool invalid = slot.invalid, corrupt = slot.corrupt;
    slot.used = false;
    // Partial samples older than this complete one can never be used.
    for (Slot& o : slots_) {
      if (o.used && ahead(o.sample.counter, s.counter) > 0 && ahead(o.sample.counter, s.counter) < 128) {
        o.used = false;
        ++diag_.incomplete_dropped;
      }
    }
    if (have_ref_) {
      const int d = ahead(ref_counter_, s.counter);
      if (d == 0) {
        ++diag_.stale_counters;
        return SensorEvent::stale_counter;
      }
      if (static_cast<std::uint32_t>(d) > stale_ticks_) {
        ++diag_.counter_jumps;
        ref_counter_ = s.counter;  // resynchronise: the next sample is judged against this one
        ref_tick_ = tick;
        return SensorEvent::counter_jump;
      }
    }
    have_ref_ = true;
    ref_counter_ = s.counter;
    ref_tick_ = tick;
    if ((s.status & sensor_status::reserved) != 0) {
      ++diag_.reserved_bits;
      return SensorEvent::reserved_bits;
    }
    if (invalid) {
      ++diag_.status_invalid;
      return SensorEvent::status_invalid;
    }
    if (corrupt) {
      ++diag_.bad_quaternion;
      return SensorEvent::bad_quaternion;
    }
    newest_ = s;
    newest_.tick = tick;
    diag_.have_sample = true;
    ++diag_.samples_accepted;
    diag_.last_counter = s.counter;
    diag_.last_status = s.status;
    diag_.not_ready = (s.status & sensor_status::not_ready) != 0;
    if ((s.status & sensor_status::clipping) != 0) ++diag_.clipped;
    if ((s.status & sensor_status::clipping) != 0 && (field_at_rail(s, ranged_frames_) || !field_at_rail(s, ~ranged_frames_))) {
      ++diag_.clip_streak;
      if (diag_.clip_streak > diag_.clip_streak_max) diag_.clip_streak_max = diag_.clip_streak;
    } else {
      diag_.clip_streak = 0;
    }
    diag_.clip_streak_fault = clip_streak_limit_ > 0 && diag_.clip_streak >= clip_streak_limit_;
    return SensorEvent::accepted;
  }

  // A field of one of `frames` (bit i = frame i) at the int16 rail.
  static bool field_at_rail(const Sample& s, std::uint32_t frames) noexcept {
    for (int i = 0; i < N; ++i) {
      if ((frames & (1u << i)) == 0) continue;
      for (const std::int16_t v : s.fields[static_cast<std::size_t>(i)]) {
        if (v == std::numeric_limits<std::int16_t>::max() || v == std::numeric_limits<std::int16_t>::min()) return true;
      }
    }
    return false;
  }

  std::array<Slot, kSlots> slots_{};
  Sample newest_;
  SensorDiagnostics diag_;
  std::uint32_t stale_ticks_ = 3;
  std::uint32_t clip_streak_limit_ = 10;
  std::uint32_t ranged_frames_ = (1u << N) - 1u;
  bool have_ref_ = false;
  std::uint8_t ref_counter_ = 0;
  std::uint64_t ref_tick_ = 0;
  std::uint64_t reset_tick_ = 0;
};

// ---- the two sensors ------------------------------------------------------------------------
struct ImuReading {
  Eigen::Quaterniond orientation = Eigen::Quaterniond::Identity();  // sensor to world
  Eigen::Vector3d angular_rate_rad_s = Eigen::Vector3d::Zero();     // sensor frame
  Eigen::Vector3d linear_accel_m_s2 = Eigen::Vector3d::Zero();      // specific force, sensor frame
};

class ImuAssembler {
 public:
  // Start-up: the config and a reset at `tick`.
  void configure(const ImuConfig& cfg, std::uint64_t tick);
  // Which frame of this sensor `id` is (0..2), or -1.
  int frame_index(std::uint32_t id) const noexcept;
  // rt: no alloc, no block. The frame must carry one of the IMU's ids.
  SensorEvent push(const Frame& f, std::uint64_t tick) noexcept;
  // rt: no alloc, no block
  void update(std::uint64_t tick) noexcept { asm_.update(tick); }
  bool usable() const noexcept { return asm_.usable(); }
  // The newest accepted sample in physical units.
  // rt: no alloc, no block
  ImuReading reading() const noexcept;
  const SampleAssembler<kImuFrames>& assembler() const noexcept { return asm_; }
  const SensorDiagnostics& diagnostics() const noexcept { return asm_.diagnostics(); }
  const ImuConfig& config() const noexcept { return cfg_; }

 private:
  ImuConfig cfg_;
  SampleAssembler<kImuFrames> asm_;
  OrientationTrack track_;
  Eigen::Quaterniond orientation_ = Eigen::Quaterniond::Identity();  // of the newest sample
  std::uint8_t track_counter_ = 0;   // of the last accepted sample
  std::uint64_t track_tick_ = 0;     // when it was accepted
};

struct FtReading {
  Eigen::Vector3d force_n = Eigen::Vector3d::Zero();    // in the end-effector frame (see FtConfig::offset)
  Eigen::Vector3d torque_nm = Eigen::Vector3d::Zero();  // about the EE frame's origin
};

class FtAssembler {
 public:
  void configure(const FtConfig& cfg, std::uint64_t tick);
  int frame_index(std::uint32_t id) const noexcept;
  // rt: no alloc, no block
  SensorEvent push(const Frame& f, std::uint64_t tick) noexcept;
  // rt: no alloc, no block
  void update(std::uint64_t tick) noexcept { asm_.update(tick); }
  bool usable() const noexcept { return asm_.usable(); }
  // rt: no alloc, no block
  FtReading reading() const noexcept;
  const SampleAssembler<kFtFrames>& assembler() const noexcept { return asm_; }
  const SensorDiagnostics& diagnostics() const noexcept { return asm_.diagnostics(); }
  const FtConfig& config() const noexcept { return cfg_; }

 private:
  FtConfig cfg_;
  WrenchTransform to_ee_;
  SampleAssembler<kFtFrames> asm_;
};

// ---- the sensor side (emulator, tests) ---------------------------------------------------------
// The frames of one sample; `status` gets the clipping bit added when a field saturates.
// Returns false (frames untouched) when a value is not finite.
bool encode_imu_sample(const ImuConfig& cfg, const ImuReading& r, std::uint8_t counter, std::uint8_t status,
                       std::array<Frame, kImuFrames>& out) noexcept;
// `force_n` / `torque_nm` in the sensor frame.
bool encode_ft_sample(const FtConfig& cfg, const Eigen::Vector3d& force_n, const Eigen::Vector3d& torque_nm,
                      std::uint8_t counter, std::uint8_t status, std::array<Frame, kFtFrames>& out) noexcept;

}  // namespace springbok::can
