// Random robot states and the configuration-space operations the property
// tests need (integration along v, the conventions of CONVENTIONS.md).
#pragma once

#include <cmath>
#include <random>

#include <Eigen/Geometry>

#include "springbok/dynamics/dynamics.hpp"

namespace springbok::test {

struct RandomState {
  VecNq q;
  VecNv v, vdot;
};

// Base position in [-0.5, 0.5]^2 x [0, 1], orientation uniform, joints within
// their limits (continuous ones in [-pi, pi]), v and vdot ~ N(0, 1).
inline RandomState random_state(std::mt19937_64& rng) {
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  std::normal_distribution<double> normal(0.0, 1.0);
  RandomState s;
  s.q[0] = unit(rng) - 0.5;
  s.q[1] = unit(rng) - 0.5;
  s.q[2] = unit(rng);
  Eigen::Vector4d quat;
  for (int k = 0; k < 4; ++k) quat[k] = normal(rng);
  s.q.segment<4>(3) = quat.normalized();
  for (int i = 0; i < kNj; ++i) {
    const auto& lim = robot::kJoints[i].limits;
    const double lo = lim.bounded ? lim.lower_rad : -M_PI;
    const double hi = lim.bounded ? lim.upper_rad : M_PI;
    s.q[7 + i] = lo + (hi - lo) * unit(rng);
  }
  for (int k = 0; k < kNv; ++k) s.v[k] = normal(rng);
  for (int k = 0; k < kNv; ++k) s.vdot[k] = normal(rng);
  return s;
}

inline Eigen::Quaterniond base_quaternion(const VecNq& q) {
  return Eigen::Quaterniond(q[6], q[3], q[4], q[5]).normalized();
}

inline Mat3 skew(const Vec3& w) {
  Mat3 m;
  m << 0, -w.z(), w.y(), w.z(), 0, -w.x(), -w.y(), w.x(), 0;
  return m;
}

// q (+) dt*v: T_WB <- T_WB exp_SE3(dt [v_B; w_B]), joints += dt v.
inline VecNq integrate(const VecNq& q, const VecNv& v, double dt) {
  const Vec3 lin = dt * v.segment<3>(0), ang = dt * v.segment<3>(3);
  const double th = ang.norm();
  const Mat3 w = skew(ang);
  // Left Jacobian of SO(3): V = I + (1 - cos th)/th^2 [w] + (th - sin th)/th^3 [w]^2.
  const double a = th < 1e-8 ? 0.5 - th * th / 24.0 : (1.0 - std::cos(th)) / (th * th);
  const double b = th < 1e-8 ? 1.0 / 6.0 - th * th / 120.0 : (th - std::sin(th)) / (th * th * th);
  const Mat3 vmat = Mat3::Identity() + a * w + b * w * w;
  const Eigen::Quaterniond quat = base_quaternion(q);
  const Eigen::Quaterniond step(Eigen::AngleAxisd(th, th > 0 ? Vec3(ang / th) : Vec3::UnitX()));
  VecNq out = q;
  out.head<3>() = q.head<3>() + quat.toRotationMatrix() * (vmat * lin);
  Eigen::Quaterniond next = (quat * step).normalized();
  if (next.w() < 0) next.coeffs() *= -1.0;
  out.segment<4>(3) = next.coeffs();  // x y z w
  out.tail<kNj>() = q.tail<kNj>() + dt * v.tail<kNj>();
  return out;
}

}  // namespace springbok::test
