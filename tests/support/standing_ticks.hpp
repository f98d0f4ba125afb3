// The robot standing still on its stance, level, at rest, as its sensors report it tick by tick:
// the IMU (its mounting, gravity) and the encoders with white noise (a MEMS-like 5 mrad/s and
// 0.04 m/s^2 per sample; 1e-4 rad, 0.01 rad/s), the wrist valid and unloaded. For estimator
// tests and benchmarks.
#pragma once

#include <cstdint>
#include <random>
#include <vector>

#include "springbok/dynamics/dynamics.hpp"
#include "springbok/hal/types.hpp"
#include "springbok/wbc/stand_controller.hpp"

namespace springbok::test {

inline std::vector<hal::Measurements> noisy_standing_ticks(int n, std::uint32_t seed) {
  std::vector<hal::Measurements> out(static_cast<std::size_t>(n));
  const dyn::Model model;
  const Mat3& r_bi = model.frame_placement[kImuFrame].rotation;  // world_from_imu = R_BI: trunk level
  std::mt19937 rng(seed);
  std::normal_distribution<double> g(0.0, 1.0);
  for (int k = 0; k < n; ++k) {
    hal::Measurements& m = out[static_cast<std::size_t>(k)];
    m.sequence = static_cast<std::uint64_t>(k + 1);
    m.q_rad = wbc::nominal_stance();
    for (int j = 0; j < kNj; ++j) {
      m.q_rad[j] += 1e-4 * g(rng);
      m.qd_rad_s[j] = 0.01 * g(rng);
    }
    m.imu.valid = true;
    m.imu.orientation = Quat(r_bi);
    m.imu.angular_rate_rad_s = 0.005 * Vec3(g(rng), g(rng), g(rng));
    m.imu.linear_accel_m_s2 = r_bi.transpose() * Vec3(0.0, 0.0, kGravity_m_s2) + 0.04 * Vec3(g(rng), g(rng), g(rng));
    m.wrist.valid = true;
  }
  return out;
}

}  // namespace springbok::test
