// Worst-case bus time and load per tick, CAN.md section 3.
#pragma once

#include <string>

#include "springbok/can/config.hpp"

namespace springbok::can {

// Classic base frame (11-bit id) with n data bytes, worst-case stuffing, bits.
constexpr int classic_frame_bits(int n) noexcept { return 47 + 8 * n + (34 + 8 * n - 1) / 4; }
// CAN FD base frame with bit-rate switch, n data bytes (a valid FD length), microseconds.
double fd_frame_us(int n, double nominal_bps, double data_bps) noexcept;
// A frame of n bytes on this bus, microseconds.
double frame_us(const BusConfig& bus, int n) noexcept;

struct BusLoad {
  int frames_per_tick = 0;   // host commands + drive replies (+ SYNC)
  double bus_time_us = 0.0;  // worst case per tick
  double load = 0.0;         // bus_time / tick
};
// The drives' frames only (commands, replies, SYNC).
BusLoad worst_case_load(const BusConfig& bus, double tick_us) noexcept;
// The drives' frames plus the frames of the sensors of `sensors` on this bus (CAN.md 6.3:
// classic 8-byte frames at the nominal rate, 3 per IMU sample and 2 per F/T sample, at the
// sensor's rate_hz; frames_per_tick rounds the sensors' share up).
BusLoad worst_case_load(const BusConfig& bus, double tick_us, const SensorsConfig& sensors) noexcept;

// Empty when every bus, its sensors included, is at or below c.max_bus_load; else names
// the first bus above it.
std::string check_bus_loads(const CanConfig& c);

}  // namespace springbok::can
