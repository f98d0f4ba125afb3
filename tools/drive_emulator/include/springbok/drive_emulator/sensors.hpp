// The sensor side of CAN.md 6.5: the trunk IMU and the wrist F/T publishing one sample
// per world step, byte-exact as hal/can decodes them, with scripted faults (silence, a
// stale counter, status invalid, a corrupt quaternion, saturation, frames of a sample
// split across ticks, ...). No I/O: samples in, frames out.
#pragma once

#include <array>
#include <cstdint>
#include <vector>

#include "springbok/can/config.hpp"
#include "springbok/can/frame.hpp"
#include "springbok/drive_emulator/drives.hpp"
#include "springbok/hal/types.hpp"

namespace springbok::emu {

class SensorEmulator {
 public:
  // `faults`: the script's sensor faults (others are ignored).
  SensorEmulator(const can::SensorsConfig& cfg, const std::vector<Fault>& faults);

  // One sample of each configured sensor, as sim_hal measures them: the IMU in its frame
  // (orientation IMU-to-world), the wrist wrench in the end-effector frame (converted to
  // the sensor frame when the config gives an offset). Frames are appended to `imu_out`
  // and `ft_out` (each sensor may be on its own bus).
  void publish(const hal::Imu& imu, const hal::Wrench& wrist, std::vector<can::Frame>& imu_out,
               std::vector<can::Frame>& ft_out);

  std::uint64_t imu_samples() const noexcept { return imu_.tick; }
  std::uint64_t ft_samples() const noexcept { return ft_.tick; }
  std::uint64_t frames_out() const noexcept { return frames_out_; }

 private:
  struct Channel {
    std::vector<Fault> faults;
    std::uint64_t tick = 0;         // samples so far (the fault script's tick)
    std::uint8_t counter = 0;       // of the last sample sent
    std::vector<can::Frame> held;   // split: frames waiting for the next sample
    bool active(FaultKind k) const noexcept;
  };
  template <std::size_t N>
  void emit(Channel& ch, std::array<can::Frame, N>& frames, std::vector<can::Frame>& out);
  std::uint8_t next_counter(Channel& ch) const noexcept;

  can::SensorsConfig cfg_;
  can::WrenchTransform ee_to_sensor_;
  Channel imu_, ft_;
  std::uint64_t frames_out_ = 0;
};

}  // namespace springbok::emu
