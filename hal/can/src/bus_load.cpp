#include "springbok/can/bus_load.hpp"

#include <cmath>
#include <cstdio>

namespace springbok::can {

double fd_frame_us(int n, double nominal_bps, double data_bps) noexcept {
  const int crc = n <= 16 ? 17 : 21;
  const int fixed_stuff = n <= 16 ? 6 : 7;
  const int data_bits = 5 + 8 * n + (5 + 8 * n) / 4 + 1 + 4 + crc + fixed_stuff + 1;
  return 33.0 / nominal_bps * 1e6 + static_cast<double>(data_bits) / data_bps * 1e6;
}

double frame_us(const BusConfig& bus, int n) noexcept {
  if (bus.fd) return fd_frame_us(n, bus.bitrate, bus.data_bitrate);
  return static_cast<double>(classic_frame_bits(n)) / static_cast<double>(bus.bitrate) * 1e6;
}

BusLoad worst_case_load(const BusConfig& bus, double tick_us) noexcept {
  BusLoad l;
  bool any_cia = false;
  for (const DriveConfig& d : bus.drives) {
    if (d.protocol == Protocol::mit) {
      l.bus_time_us += frame_us(bus, mit::kCommandLen);
      l.bus_time_us += frame_us(bus, d.mit_vendor_reply ? mit::kReplyLenVendor : mit::kReplyLen);
      l.frames_per_tick += 2;
    } else {
      any_cia = true;
      l.bus_time_us += frame_us(bus, 4);  // RPDO1
      if (d.mapping == cia402::Mapping::compact) {
        l.bus_time_us += frame_us(bus, 8);
        l.frames_per_tick += 2;
      } else {
        l.bus_time_us += 2.0 * frame_us(bus, 6);
        l.frames_per_tick += 3;
      }
    }
  }
  if (any_cia) {
    l.bus_time_us += frame_us(bus, 0);  // SYNC
    l.frames_per_tick += 1;
  }
  l.load = l.bus_time_us / tick_us;
  return l;
}

BusLoad worst_case_load(const BusConfig& bus, double tick_us, const SensorsConfig& sensors) noexcept {
  BusLoad l = worst_case_load(bus, tick_us);
  // Sensor frames are classic CAN even on an FD bus: 8 data bytes at the nominal rate.
  const double frame_8_us = static_cast<double>(classic_frame_bits(kSensorFrameLen)) / static_cast<double>(bus.bitrate) * 1e6;
  const auto add = [&](int frames_per_sample, double rate_hz) {
    const double frames = frames_per_sample * rate_hz * tick_us * 1e-6;
    l.bus_time_us += frames * frame_8_us;
    l.frames_per_tick += static_cast<int>(std::ceil(frames - 1e-9));
  };
  if (sensors.imu.enabled && sensors.imu.bus == bus.name) add(kImuFrames, sensors.imu.rate_hz);
  if (sensors.wrist_ft.enabled && sensors.wrist_ft.bus == bus.name) add(kFtFrames, sensors.wrist_ft.rate_hz);
  l.load = l.bus_time_us / tick_us;
  return l;
}

std::string check_bus_loads(const CanConfig& c) {
  for (const BusConfig& b : c.buses) {
    const BusLoad l = worst_case_load(b, c.timing.tick_us, c.sensors);
    if (l.load > c.max_bus_load) {
      char msg[256];
      std::snprintf(msg, sizeof msg,
                    "bus '%s' (%s): worst-case load %.1f %% (%d frames, %.1f us per %u us tick) is above the %.0f %% limit",
                    b.name.c_str(), b.interface.c_str(), 100.0 * l.load, l.frames_per_tick, l.bus_time_us,
                    c.timing.tick_us, 100.0 * c.max_bus_load);
      return msg;
    }
  }
  return {};
}

}  // namespace springbok::can
