// The oracle of a rendered push: the template (SPEC section 2, the double
// mass-spring-damper) along one axis, integrated here by RK4 from the force on
// the hand, independent of the firmware's own discretisation
// (wbc::ImpedanceTemplate); and the score of measured trunk and hand
// displacements against it (NRMSE = RMS(measured - template) / peak-to-peak
// (template), and the mean displacement over the push's last window).
// Used by the HIL case over CAN and by its in-process twin (tests/app/timing).
#pragma once

#include <algorithm>
#include <array>
#include <cmath>

namespace springbok::test {

// x_b, x_e: the trunk's and the hand's displacements from rest.
struct TemplateAxis {
  double mb, db, kb, me, de, ke;
  double xb = 0.0, xe = 0.0, vb = 0.0, ve = 0.0;
  void step(double f, double dt) {
    const auto deriv = [&](const std::array<double, 4>& s) {
      const double spring = de * (s[3] - s[2]) + ke * (s[1] - s[0]);
      return std::array<double, 4>{s[2], s[3], (spring - db * s[2] - kb * s[0]) / mb, (f - spring) / me};
    };
    const std::array<double, 4> s0{xb, xe, vb, ve};
    const auto add = [](const std::array<double, 4>& a, const std::array<double, 4>& d, double h) {
      return std::array<double, 4>{a[0] + h * d[0], a[1] + h * d[1], a[2] + h * d[2], a[3] + h * d[3]};
    };
    const auto k1 = deriv(s0), k2 = deriv(add(s0, k1, dt / 2)), k3 = deriv(add(s0, k2, dt / 2)),
               k4 = deriv(add(s0, k3, dt));
    std::array<double, 4> n{};
    for (int i = 0; i < 4; ++i) n[i] = s0[i] + dt / 6.0 * (k1[i] + 2 * k2[i] + 2 * k3[i] + k4[i]);
    xb = n[0];
    xe = n[1];
    vb = n[2];
    ve = n[3];
  }
};

// The template's axis x from a controller's parameters (wbc::TemplateParams: per-axis vectors).
template <class Params>
TemplateAxis template_axis_x(const Params& tp) {
  return TemplateAxis{tp.mass_base_kg.x(), tp.damping_base_ns_per_m.x(), tp.stiffness_base_n_per_m.x(),
                      tp.mass_ee_kg.x(),   tp.damping_ee_ns_per_m.x(),   tp.stiffness_ee_n_per_m.x()};
}

// Feed one sample per step from the push's start (the template starts at rest there);
// displacements from the pose just before the push.
class PushScore {
 public:
  PushScore(const TemplateAxis& axis, double start_s, double end_s, double end_window_s)
      : axis_(axis), start_s_(start_s), end_s_(end_s), end_window_s_(end_window_s), t_prev_s_(start_s - 0.001) {}

  void add(double t_s, double force_n, double base_m, double hand_m) {
    if (t_s < start_s_ - 1e-6 || t_s > end_s_) return;
    axis_.step(force_n, t_s - t_prev_s_);
    t_prev_s_ = t_s;
    sq_b_ += (base_m - axis_.xb) * (base_m - axis_.xb);
    sq_e_ += (hand_m - axis_.xe) * (hand_m - axis_.xe);
    lo_b_ = std::min(lo_b_, axis_.xb);
    hi_b_ = std::max(hi_b_, axis_.xb);
    lo_e_ = std::min(lo_e_, axis_.xe);
    hi_e_ = std::max(hi_e_, axis_.xe);
    ++n_;
    if (t_s >= end_s_ - end_window_s_) {
      end_b_ += base_m;
      end_e_ += hand_m;
      ++n_end_;
    }
  }

  int samples() const { return n_; }
  int end_samples() const { return n_end_; }
  double nrmse_base() const { return std::sqrt(sq_b_ / n_) / (hi_b_ - lo_b_); }
  double nrmse_hand() const { return std::sqrt(sq_e_ / n_) / (hi_e_ - lo_e_); }
  double end_base_m() const { return end_b_ / n_end_; }
  double end_hand_m() const { return end_e_ / n_end_; }
  // The template's static displacements for a constant force: F/K_b and F/K_b + F/K_e.
  double static_base_m(double force_n) const { return force_n / axis_.kb; }
  double static_hand_m(double force_n) const { return force_n / axis_.kb + force_n / axis_.ke; }

 private:
  TemplateAxis axis_;
  double start_s_, end_s_, end_window_s_, t_prev_s_;
  double sq_b_ = 0.0, sq_e_ = 0.0, lo_b_ = 1e9, hi_b_ = -1e9, lo_e_ = 1e9, hi_e_ = -1e9, end_b_ = 0.0, end_e_ = 0.0;
  int n_ = 0, n_end_ = 0;
};

}  // namespace springbok::test
