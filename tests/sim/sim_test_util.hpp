// Helpers shared by the simulator tests: reading the reference states and
// turning one Bullet step into generalized accelerations in our conventions.
#pragma once

#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "springbok/model/model.hpp"
#include "springbok/sim_hal/bullet_robot.hpp"

namespace springbok::test {

// Blocks of one reference state file (tests/data/reference/FORMAT.md).
inline std::map<std::string, Eigen::MatrixXd> read_reference_state(const std::string& path) {
  std::ifstream in(path);
  std::map<std::string, Eigen::MatrixXd> blocks;
  std::string line;
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#') continue;
    std::istringstream header(line);
    std::string name;
    int rows = 0, cols = 0;
    header >> name >> rows >> cols;
    Eigen::MatrixXd m(rows, cols);
    for (int r = 0; r < rows; ++r) {
      std::getline(in, line);
      std::istringstream values(line);
      for (int c = 0; c < cols; ++c) values >> m(r, c);
    }
    blocks[name] = m;
  }
  return blocks;
}

// Base velocity as Bullet stores it: angular and COM linear velocity in world axes.
struct WorldBaseVelocity {
  Vec3 omega_world;
  Vec3 com_velocity_world;
};

inline Mat3 base_rotation(const VecNq& q) { return Quat(q[6], q[3], q[4], q[5]).normalized().toRotationMatrix(); }

inline Vec3 base_com_offset() {
  const auto& c = robot::kBaseInertia.com_m;
  return {c[0], c[1], c[2]};
}

inline WorldBaseVelocity world_base_velocity(const VecNq& q, const VecNv& v) {
  const Mat3 r = base_rotation(q);
  const Vec3 w = v.segment<3>(3);
  return {r * w, r * (v.head<3>() + w.cross(base_com_offset()))};
}

// Bullet integrates semi-implicitly (v1 = v0 + dt a(q0, v0)), so one step from
// (q0, v0) to (q1, v1) gives a(q0, v0) exactly; converted to vdot (CONVENTIONS.md).
inline VecNv acceleration_from_step(const VecNq& q0, const VecNv& v0, const VecNq& q1, const VecNv& v1,
                                    double dt_s) {
  const WorldBaseVelocity b0 = world_base_velocity(q0, v0);
  const WorldBaseVelocity b1 = world_base_velocity(q1, v1);
  const Mat3 r0 = base_rotation(q0);
  const Vec3 c = base_com_offset();
  const Vec3 w = v0.segment<3>(3);
  const Vec3 vb = v0.head<3>();
  VecNv a;
  const Vec3 wdot = r0.transpose() * (b1.omega_world - b0.omega_world) / dt_s;
  const Vec3 com_acc_base = r0.transpose() * (b1.com_velocity_world - b0.com_velocity_world) / dt_s;
  a.segment<3>(3) = wdot;
  a.head<3>() = com_acc_base - wdot.cross(c) - w.cross(vb + w.cross(c));
  a.tail<kNj>() = (v1.tail<kNj>() - v0.tail<kNj>()) / dt_s;
  return a;
}

// Applies a generalized base force tau[0:6] (force at the trunk origin and
// moment, trunk axes) as two constant external wrenches at the trunk frame.
inline void add_base_wrench(sim::BulletRobot& robot, const VecNq& q, const Vec6& tau_base) {
  const Mat3 r = base_rotation(q);
  const auto trunk = sim::find_frame("trunk");
  for (int part = 0; part < 2; ++part) {
    const Vec3 world = r * tau_base.segment<3>(3 * part);
    if (world.norm() == 0.0) continue;
    sim::ExternalWrench w;
    w.frame = *trunk;
    w.kind = part == 0 ? sim::WrenchKind::force : sim::WrenchKind::torque;
    w.axis_world = world.normalized();
    w.profile.shape = sim::ProfileShape::constant;
    w.profile.amplitude = world.norm();
    robot.add_external_wrench(w);
  }
}

}  // namespace springbok::test
