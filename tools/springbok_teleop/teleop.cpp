#include "teleop.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "springbok/gait/trot.hpp"

namespace springbok::teleop {
namespace {

// The trot's limit of a velocity field (gait::kTrotFields): the smaller of its two ends.
double trot_limit(double gait::TrotParams::*member) {
  for (const auto& f : gait::kTrotFields) {
    if (f.member == member) return std::min(std::abs(f.lo), std::abs(f.hi));
  }
  return 0.0;
}

}  // namespace

Teleop::Teleop(const TeleopConfig& config) : config_(config) {
  const double k = std::clamp(config.speed_fraction, 0.0, 1.0);
  max_ = {k * trot_limit(&gait::TrotParams::velocity_x_m_s), k * trot_limit(&gait::TrotParams::velocity_y_m_s),
          k * trot_limit(&gait::TrotParams::yaw_rate_rad_s)};
}

void Teleop::set_axis_range(int code, AxisRange range) {
  for (auto& [c, r] : ranges_) {
    if (c == code) {
      r = range;
      return;
    }
  }
  ranges_.emplace_back(code, range);
}

// The stick's position in [-1, 1] from its centre, 0 inside the dead zone, then rising from 0.
double Teleop::axis(int code) const {
  AxisRange range;
  for (const auto& [c, r] : ranges_) {
    if (c == code) range = r;
  }
  int value = (range.min + range.max) / 2;
  for (const auto& [c, v] : values_) {
    if (c == code) value = v;
  }
  const double half = 0.5 * (static_cast<double>(range.max) - range.min);
  if (half <= 0.0) return 0.0;
  const double x = std::clamp((value - 0.5 * (static_cast<double>(range.max) + range.min)) / half, -1.0, 1.0);
  const double dz = std::clamp(config_.dead_zone, 0.0, 0.99);
  if (std::abs(x) <= dz) return 0.0;
  return std::copysign((std::abs(x) - dz) / (1.0 - dz), x);
}

std::array<double, 3> Teleop::velocity() const {
  return {-axis(config_.axis_forward) * max_[0], -axis(config_.axis_sideways) * max_[1],
          -axis(config_.axis_yaw) * max_[2]};
}

void Teleop::event(double t_s, int type, int code, int value) {
  last_event_s_ = t_s;
  connected_ = true;
  if (type == EV_ABS) {
    for (auto& [c, v] : values_) {
      if (c == code) {
        v = value;
        return;
      }
    }
    values_.emplace_back(code, value);
    return;
  }
  if (type != EV_KEY || value == 2) return;  // 2: the key's auto-repeat
  if (code == config_.button_dead_man) {
    dead_man_ = value == 1;
    if (dead_man_) armed_ = true;
    return;
  }
  if (value != 1) return;
  for (const ButtonCommand& b : kButtons) {
    if (b.code == code) queued_.emplace_back(b.line);
  }
}

void Teleop::unplugged(double t_s) {
  connected_ = false;
  dead_man_ = false;
  armed_ = false;
  values_.clear();
  last_event_s_ = t_s;
}

void Teleop::stop(std::vector<std::string>& out) {
  walking_ = false;
  armed_ = false;
  out.emplace_back("walk 0 0 0");
  out.emplace_back("gait stand");
}

void Teleop::poll(double t_s, std::vector<std::string>& out) {
  for (std::string& line : queued_) out.push_back(std::move(line));
  queued_.clear();
  const bool timed_out = t_s - last_event_s_ > config_.event_timeout_s;
  if (walking_ && (!dead_man_ || !connected_ || timed_out)) {
    stop(out);
    return;
  }
  if (!walking_ && armed_ && dead_man_ && connected_ && !timed_out) {
    walking_ = true;
    next_walk_s_ = t_s;
  }
  if (walking_ && t_s >= next_walk_s_) {
    const std::array<double, 3> v = velocity();
    const auto mm = [](double x) { return std::round(x * 1000.0) / 1000.0 + 0.0; };  // + 0.0: no "-0.000"
    char line[96];
    std::snprintf(line, sizeof line, "walk %.3f %.3f %.3f", mm(v[0]), mm(v[1]), mm(v[2]));
    out.emplace_back(line);
    next_walk_s_ += config_.period_s;
    if (next_walk_s_ <= t_s) next_walk_s_ = t_s + config_.period_s;  // late: from now on
  }
}

}  // namespace springbok::teleop
