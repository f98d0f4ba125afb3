#include "springbok/drive_emulator/sensors.hpp"

#include "springbok/can/sensors.hpp"

namespace springbok::emu {

using can::Frame;
namespace st = can::sensor_status;

bool SensorEmulator::Channel::active(FaultKind k) const noexcept {
  for (const Fault& f : faults) {
    if (f.kind != k || tick < f.at_tick) continue;
    if (k == FaultKind::silent || tick < f.at_tick + f.count) return true;
  }
  return false;
}

SensorEmulator::SensorEmulator(const can::SensorsConfig& cfg, const std::vector<Fault>& faults) : cfg_(cfg) {
  ee_to_sensor_ = cfg.wrist_ft.has_offset ? can::wrench_transform(cfg.wrist_ft.offset) : can::WrenchTransform{};
  for (const Fault& f : faults) {
    if (f.sensor == SensorId::imu) imu_.faults.push_back(f);
    if (f.sensor == SensorId::wrist_ft) ft_.faults.push_back(f);
  }
}

std::uint8_t SensorEmulator::next_counter(Channel& ch) const noexcept {
  if (ch.tick > 1 && ch.active(FaultKind::stale_counter)) return ch.counter;
  return ch.tick == 1 ? 0 : static_cast<std::uint8_t>(ch.counter + 1);
}

template <std::size_t N>
void SensorEmulator::emit(Channel& ch, std::array<Frame, N>& frames, std::vector<Frame>& out) {
  // Frames held back from the previous sample go first (split across ticks).
  for (const Frame& f : ch.held) out.push_back(f);
  frames_out_ += ch.held.size();
  ch.held.clear();
  if (ch.active(FaultKind::silent) || ch.active(FaultKind::drop)) return;
  for (Frame& f : frames) {
    if (ch.active(FaultKind::saturate)) {
      f.data[0] = 0xFF;
      f.data[1] = 0x7F;
      f.data[7] = static_cast<std::uint8_t>(f.data[7] | st::clipping);
    }
    if (ch.active(FaultKind::status_invalid)) f.data[7] = static_cast<std::uint8_t>(f.data[7] & ~st::valid);
    if (ch.active(FaultKind::not_ready)) f.data[7] = static_cast<std::uint8_t>(f.data[7] | st::not_ready);
    if (ch.active(FaultKind::wrong_dlc)) f.len = static_cast<std::uint8_t>(f.len - 1);
  }
  const std::size_t now = ch.active(FaultKind::split) ? N - 1 : N;
  for (std::size_t i = 0; i < N; ++i) {
    if (i < now) {
      out.push_back(frames[i]);
      ++frames_out_;
    } else {
      ch.held.push_back(frames[i]);
    }
  }
}

void SensorEmulator::publish(const hal::Imu& imu, const hal::Wrench& wrist, std::vector<Frame>& imu_out,
                             std::vector<Frame>& ft_out) {
  if (cfg_.imu.enabled) {
    ++imu_.tick;
    imu_.counter = next_counter(imu_);
    can::ImuReading r;
    r.orientation = imu.orientation;
    r.angular_rate_rad_s = imu.angular_rate_rad_s;
    r.linear_accel_m_s2 = imu.linear_accel_m_s2;
    std::array<Frame, can::kImuFrames> frames{};
    // The sample's clipping (sim_hal's sensor model saturated a field) is the status bit the
    // host's clipping streak counts (CAN.md 6).
    const auto status = static_cast<std::uint8_t>((imu.valid ? st::valid : 0) | (imu.clipping ? st::clipping : 0));
    if (!can::encode_imu_sample(cfg_.imu, r, imu_.counter, status, frames)) {
      can::encode_imu_sample(cfg_.imu, can::ImuReading{}, imu_.counter, 0, frames);  // not finite: not valid
    }
    if (imu_.active(FaultKind::corrupt_quaternion)) {
      for (int i = 0; i < 6; i += 2) {
        frames[can::imu_frame::orientation].data[static_cast<std::size_t>(i)] = 0xFF;
        frames[can::imu_frame::orientation].data[static_cast<std::size_t>(i + 1)] = 0x7F;
      }
    }
    emit(imu_, frames, imu_out);
  }
  if (cfg_.wrist_ft.enabled) {
    ++ft_.tick;
    ft_.counter = next_counter(ft_);
    Eigen::Vector3d force_s = wrist.force_n, torque_s = wrist.torque_nm;
    if (cfg_.wrist_ft.has_offset) can::wrench_ee_to_sensor(ee_to_sensor_, wrist.force_n, wrist.torque_nm, force_s, torque_s);
    std::array<Frame, can::kFtFrames> frames{};
    const auto status = static_cast<std::uint8_t>((wrist.valid ? st::valid : 0) | (wrist.clipping ? st::clipping : 0));
    if (!can::encode_ft_sample(cfg_.wrist_ft, force_s, torque_s, ft_.counter, status, frames)) {
      can::encode_ft_sample(cfg_.wrist_ft, Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero(), ft_.counter, 0, frames);
    }
    emit(ft_, frames, ft_out);
  }
}

}  // namespace springbok::emu
