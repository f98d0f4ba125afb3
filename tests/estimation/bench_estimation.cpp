// bench_estimation: the state estimators' ticks.
//   BM_EkfUpdate  InertialKinematicEkf::update: 4 feet in contact, the ground measurement and
//                 the leg velocity on (prediction + 4 sequential 7-row updates), the yaw aid off
//   BM_EkfUpdateYaw  the same with the yaw aid
// The inputs cycle through 1024 precomputed ticks of a trunk swaying on its 4 feet (IMU and
// kinematics with noise). The filter is compiled for the build's ISA (SPRINGBOK_ARCH; it has
// no per-level kernels), which the label names. Run with repetitions for the spread:
//   bench_estimation --benchmark_repetitions=30 --benchmark_report_aggregates_only=true
// Besides the aggregates, each reports the per-call latency median and 99th percentile of
// 20000 individually timed calls (counters call_p50_us, call_p99_us; steady_clock's own
// overhead included), and the velocity estimate's rms error over those calls (the measurements
// are consistent: it stays at the noise's level).
#include <benchmark/benchmark.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <random>
#include <vector>

#include "springbok/estimation/inertial_kinematic_ekf.hpp"

namespace {
using namespace springbok::est;
using Vec3 = Eigen::Vector3d;
using Mat3 = Eigen::Matrix3d;

constexpr int kTicks = 1024;
constexpr double kDt = 1e-3;

const char* isa_label() {
#if defined(__AVX512F__)
  return "avx512 (x86-64-v4 or native)";
#elif defined(__AVX2__) && defined(__FMA__)
  return "avx2+fma (x86-64-v3 or native)";
#elif defined(__x86_64__)
  return "x86-64 baseline (sse2)";
#elif defined(__aarch64__)
  return "armv8-a";
#else
  return "unknown";
#endif
}

struct Fixture {
  Fixture() {
    std::mt19937_64 rng{42};
    std::normal_distribution<double> n(0.0, 1.0);
    const std::array<Vec3, kEkfFeet> feet{Vec3(0.36, 0.22, 0), Vec3(0.36, -0.22, 0), Vec3(-0.36, 0.22, 0),
                                          Vec3(-0.36, -0.22, 0)};
    // One period over the 1024 ticks (the cycle closes): the trunk circles 2 cm and rolls 50 mrad.
    const double w = 2 * 3.14159265358979 / (kTicks * kDt);
    const double sg = 5e-4 / std::sqrt(kDt), sa = 2e-3 / std::sqrt(kDt), ss = 1e-3, sv = 1e-2;  // the filter's defaults
    inputs.resize(kTicks);
    for (int k = 0; k < kTicks; ++k) {
      const double t = k * kDt;
      const Vec3 p(0.02 * std::sin(w * t), 0.02 * std::cos(w * t), 0.55);
      const Vec3 v(0.02 * w * std::cos(w * t), -0.02 * w * std::sin(w * t), 0.0);
      const Vec3 a = -w * w * Vec3(p.x(), p.y(), 0.0);
      const Mat3 rot = Eigen::AngleAxisd(0.05 * std::sin(w * t), Vec3::UnitX()).toRotationMatrix();
      const Vec3 rate_b(0.05 * w * std::cos(w * t), 0, 0);
      EkfInput& in = inputs[static_cast<std::size_t>(k)];
      velocity_w_m_s.push_back(v);
      in.imu.rate_i_rad_s = rate_b + sg * Vec3(n(rng), n(rng), n(rng));
      in.imu.specific_force_i_m_s2 = rot.transpose() * (a + Vec3(0, 0, 9.81)) + sa * Vec3(n(rng), n(rng), n(rng));
      for (int f = 0; f < kEkfFeet; ++f) {
        FootMeasurement& m = in.feet[static_cast<std::size_t>(f)];
        const Vec3 s_b = rot.transpose() * (feet[static_cast<std::size_t>(f)] - p);
        m.contact = true;
        m.contact_point_b_m = s_b + ss * Vec3(n(rng), n(rng), n(rng));
        m.covariance_b_m2 = Mat3::Identity() * ss * ss;
        // The foot still on the ground: the legs move it against the trunk by -R^T v - w x s.
        m.velocity_valid = true;
        m.velocity_b_m_s = -rot.transpose() * v - rate_b.cross(s_b) + sv * Vec3(n(rng), n(rng), n(rng));
        m.velocity_covariance_b_m2_s2 = Mat3::Identity() * sv * sv;
      }
      in.orientation_valid = true;
      in.orientation_wi = Eigen::Quaterniond(rot);
    }
    start.position_w_m = Vec3(0, 0.02, 0.55);
    start.velocity_w_m_s = Vec3(0.02 * w, 0, 0);
  }
  std::vector<EkfInput> inputs;
  std::vector<Vec3> velocity_w_m_s;  // the trunk's true velocity at each input
  EkfInitialState start;
};

Fixture& fixture() {
  static Fixture f;
  return f;
}

void run(benchmark::State& state, const EkfParams& params) {
  Fixture& f = fixture();
  InertialKinematicEkf ekf(ImuMounting{}, params);
  if (ekf.start_at(f.start, f.inputs[0].feet) != EkfStatus::ok) state.SkipWithError("start failed");
  std::size_t k = 0;
  for (auto _ : state) {
    benchmark::DoNotOptimize(ekf.update(f.inputs[k], kDt));
    benchmark::ClobberMemory();
    k = (k + 1) % f.inputs.size();
  }
  // After the timed loop: individually timed calls, and how many feet were not fused (a
  // rejected foot skips its update: the case measured is all four anchored).
  std::vector<double> us(20000);
  int not_anchored = 0;
  double velocity_error_sq = 0.0;
  for (double& u : us) {
    const auto t0 = std::chrono::steady_clock::now();
    benchmark::DoNotOptimize(ekf.update(f.inputs[k], kDt));
    benchmark::ClobberMemory();
    u = std::chrono::duration<double, std::micro>(std::chrono::steady_clock::now() - t0).count();
    velocity_error_sq += (ekf.velocity_w_m_s() - f.velocity_w_m_s[k]).squaredNorm();
    k = (k + 1) % f.inputs.size();
    for (int foot = 0; foot < kEkfFeet; ++foot) not_anchored += ekf.foot_mode(foot) == FootMode::anchored ? 0 : 1;
  }
  std::sort(us.begin(), us.end());
  state.counters["call_p50_us"] = us[us.size() / 2];
  state.counters["call_p99_us"] = us[us.size() * 99 / 100];
  state.counters["feet_not_anchored_per_1000_ticks"] = 1000.0 * not_anchored / static_cast<double>(us.size());
  state.counters["velocity_error_rms_mm_s"] = 1e3 * std::sqrt(velocity_error_sq / static_cast<double>(us.size()));
  if (ekf.status() != EkfStatus::ok) state.SkipWithError(to_string(ekf.status()));
  state.SetLabel(isa_label());
}

void BM_EkfUpdate(benchmark::State& state) { run(state, EkfParams{}); }
void BM_EkfUpdateYaw(benchmark::State& state) {
  EkfParams p;
  p.orientation_aid = OrientationAid::yaw;
  run(state, p);
}

double p99(const std::vector<double>& v) {
  std::vector<double> s = v;
  std::sort(s.begin(), s.end());
  return s[std::min(s.size() - 1, s.size() * 99 / 100)];
}

BENCHMARK(BM_EkfUpdate)->ComputeStatistics("p99", p99)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_EkfUpdateYaw)->ComputeStatistics("p99", p99)->Unit(benchmark::kMicrosecond);

}  // namespace

BENCHMARK_MAIN();
