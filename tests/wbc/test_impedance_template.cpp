// The template's exact discrete response against independent oracles: the
// closed-form single mass-spring-damper step response, a fine RK4, the static
// solution, and the analytic frequency response.
#include <cmath>
#include <complex>

#include <Eigen/LU>
#include <gtest/gtest.h>

#include "alloc_trap.hpp"
#include "springbok/wbc/impedance_template.hpp"

namespace {
using springbok::wbc::AxisSystem;
using springbok::wbc::TemplateParams;
using springbok::wbc::TemplateReference;

TemplateParams paper_base_case(double mb, double db) {
  TemplateParams p;
  p.mass_base_kg.setConstant(mb);
  p.damping_base_ns_per_m.setConstant(db);
  return p;
}

// Fine fourth-order Runge-Kutta of the continuous system: an independent integrator.
Eigen::Vector4d rk4(const AxisSystem& s, Eigen::Vector4d x, double force, double t_end, double h) {
  auto f = [&](const Eigen::Vector4d& y) -> Eigen::Vector4d { return s.a * y + s.b * force; };
  for (double t = 0; t < t_end - 1e-12; t += h) {
    const Eigen::Vector4d k1 = f(x), k2 = f(x + 0.5 * h * k1), k3 = f(x + 0.5 * h * k2), k4 = f(x + h * k3);
    x += h / 6.0 * (k1 + 2 * k2 + 2 * k3 + k4);
  }
  return x;
}

TEST(ImpedanceTemplate, StepMatchesFineRk4ForEveryPaperCase) {
  const double cases[][2] = {{4, 126.5}, {92, 610}, {184, 858}};
  for (const auto& c : cases) {
    const TemplateParams p = paper_base_case(c[0], c[1]);
    TemplateReference ref(p, 1e-3);
    const Eigen::Vector3d f(50.0, -20.0, 5.0);
    for (int k = 0; k < 1500; ++k) ref.step(f);
    for (int axis = 0; axis < 3; ++axis) {
      const Eigen::Vector4d x = rk4(springbok::wbc::axis_system(p, axis), Eigen::Vector4d::Zero(), f[axis], 1.5, 1e-5);
      EXPECT_NEAR(ref.base_m()[axis], x[0], 1e-9) << "M_b " << c[0] << " axis " << axis;
      EXPECT_NEAR(ref.ee_m()[axis], x[1], 1e-9);
      EXPECT_NEAR(ref.base_velocity_m_s()[axis], x[2], 1e-8);
      EXPECT_NEAR(ref.ee_velocity_m_s()[axis], x[3], 1e-8);
    }
  }
}

TEST(ImpedanceTemplate, SteadyStateIsForceOverStiffness) {
  TemplateParams p = paper_base_case(92, 610);
  TemplateReference ref(p, 1e-3);
  const Eigen::Vector3d f(50.0, 0.0, -30.0);
  for (int k = 0; k < 30000; ++k) ref.step(f);
  EXPECT_NEAR(ref.base_m().x(), 50.0 / 1000.0, 1e-9);
  EXPECT_NEAR(ref.ee_m().x(), 50.0 / 1000.0 + 50.0 / 500.0, 1e-9);
  EXPECT_NEAR(ref.ee_m().y(), 0.0, 1e-15);
  EXPECT_NEAR(ref.ee_m().z(), -30.0 / 1000.0 - 30.0 / 500.0, 1e-9);
  EXPECT_TRUE((ref.base_m() - springbok::wbc::steady_state_base_m(p, f)).isZero(1e-9));
  EXPECT_TRUE((ref.ee_m() - springbok::wbc::steady_state_ee_m(p, f)).isZero(1e-9));
}

// With an (almost) immovable base, the end-effector is a single mass-spring-damper
// whose step response has a closed form.
TEST(ImpedanceTemplate, HeavyBaseReducesToClosedFormOscillator) {
  TemplateParams p;
  p.mass_base_kg.setConstant(1e12);
  p.stiffness_base_n_per_m.setConstant(1e12);
  p.damping_base_ns_per_m.setConstant(1e12);
  const double m = 4.0, k = 500.0, d = 20.0, force = 50.0;  // underdamped on purpose
  p.mass_ee_kg.setConstant(m);
  p.stiffness_ee_n_per_m.setConstant(k);
  p.damping_ee_ns_per_m.setConstant(d);
  TemplateReference ref(p, 1e-3);
  const double wn = std::sqrt(k / m), zeta = d / (2 * std::sqrt(k * m)), wd = wn * std::sqrt(1 - zeta * zeta);
  double max_err = 0;
  for (int i = 1; i <= 2000; ++i) {
    ref.step(Eigen::Vector3d(force, 0, 0));
    const double t = i * 1e-3;
    const double closed = force / k *
                          (1 - std::exp(-zeta * wn * t) * (std::cos(wd * t) + zeta / std::sqrt(1 - zeta * zeta) * std::sin(wd * t)));
    max_err = std::max(max_err, std::abs(ref.ee_m().x() - closed));
  }
  EXPECT_LT(max_err, 1e-9 * force / k * 1e3);  // the base moves ~F/1e12
  EXPECT_GT(ref.ee_m().x(), 0.0);
}

TEST(ImpedanceTemplate, SinusoidalGainMatchesTransferFunction) {
  const TemplateParams p = paper_base_case(92, 610);
  const AxisSystem s = springbok::wbc::axis_system(p, 0);
  const double dt = 1e-3, f_hz = 2.0, w = 2 * M_PI * f_hz;
  TemplateReference ref(p, dt);
  // Run 20 s of a sine (force constant over each tick, sampled mid-tick) and measure the
  // amplitude of the last 5 s.
  double peak_b = 0, peak_e = 0;
  for (int i = 0; i < 20000; ++i) {
    ref.step(Eigen::Vector3d(20.0 * std::sin(w * (i + 0.5) * dt), 0, 0));
    if (i >= 15000) {
      peak_b = std::max(peak_b, std::abs(ref.base_m().x()));
      peak_e = std::max(peak_e, std::abs(ref.ee_m().x()));
    }
  }
  const Eigen::Matrix4cd sI_minus_a = std::complex<double>(0, w) * Eigen::Matrix4cd::Identity() - s.a.cast<std::complex<double>>();
  const Eigen::Vector4cd g = sI_minus_a.partialPivLu().solve(s.b.cast<std::complex<double>>());
  EXPECT_NEAR(peak_b, 20.0 * std::abs(g[0]), 2e-3 * 20.0 * std::abs(g[0]));
  EXPECT_NEAR(peak_e, 20.0 * std::abs(g[1]), 2e-3 * 20.0 * std::abs(g[1]));
}

TEST(ImpedanceTemplate, PolesAreStableAndCriticalDampingIsRecognisable) {
  // Paper tuning d = 2 sqrt(m k) makes each subsystem critically damped on its own;
  // coupled, all four poles stay in the left half plane.
  for (double mb : {4.0, 92.0, 184.0}) {
    TemplateParams p = paper_base_case(mb, 2 * std::sqrt(mb * 1000.0));
    for (const auto& pole : springbok::wbc::template_poles(p, 0)) EXPECT_LT(pole.real(), 0.0);
  }
}

TEST(ImpedanceTemplate, StepDoesNotAllocate) {
  TemplateReference ref(paper_base_case(92, 610), 1e-3);
  const auto n = springbok::test::count_allocations([&] {
    for (int i = 0; i < 100; ++i) ref.step(Eigen::Vector3d(1, 2, 3));
  });
  EXPECT_EQ(n, 0u);
}
}  // namespace
