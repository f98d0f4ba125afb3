// Plain constexpr types of the compile-time robot description. The values
// come from the generated header (tools/urdf2model reads the robot file and its URDF); nothing
// here knows about a particular robot.
#pragma once

#include <array>
#include <string_view>

namespace springbok::model {

// A rigid transform from a child frame to its parent: p_parent = R p_child + t.
struct Transform {
  std::array<double, 9> rotation;     // row-major 3x3
  std::array<double, 3> translation;  // [m]
};

// Rigid-body inertia: mass, centre of mass and the inertia tensor about the COM,
// all in the body frame.
struct Inertia {
  double mass_kg;
  std::array<double, 3> com_m;
  std::array<double, 6> inertia_com_kgm2;  // ixx iyy izz ixy ixz iyz
};

enum class JointType { revolute, continuous };

struct JointLimits {
  bool bounded;            // false for continuous joints
  double lower_rad;
  double upper_rad;
  double effort_nm;
  double velocity_rad_s;
};

// A linear actuator (a hydraulic cylinder) turning a joint through a lever: one end
// attached at distance a from the joint's axis, the other at b, the angle between the two
// attachments phi = angle_sign q + angle_offset. The cylinder's length is
// c = sqrt(a^2 + b^2 - 2 a b cos(phi)), its lever arm about the joint a b sin(phi) / c, and
// the joint's torque limit force_max times that arm.
struct LeverActuator {
  double force_max_n;        // the cylinder's force limit, the same both directions
  double a_m;
  double b_m;
  double angle_sign;         // +1 or -1
  double angle_offset_rad;
};

// A joint's torque limit: the URDF's flat effort, or that of a lever actuator at the angle.
struct TorqueLimit {
  enum class Kind { flat, lever };
  Kind kind;
  LeverActuator lever;       // kind == lever only
};

// A movable joint; it moves body (index + 1), whose inertia is `inertia`
// (fixed-attached child links already merged). Body 0 is the floating base.
struct Joint {
  std::string_view name;
  std::string_view child_link;
  int parent_body;               // < this joint's body index
  Transform origin;              // joint frame in the parent body frame (q = 0)
  std::array<double, 3> axis;    // unit axis in the joint frame
  JointType type;
  JointLimits limits;
  double damping_nms_per_rad;    // URDF <dynamics>; not part of M or h
  Inertia inertia;
};

// A named frame rigidly attached to a body (a fixed-joint child link).
struct Frame {
  std::string_view name;
  int body;
  Transform placement;           // frame in the body frame
};

// One body's template gains along each axis (SPEC section 2): mass [kg] or rotational inertia
// [kg m^2], damping [N s/m or N m s/rad], stiffness [N/m or N m/rad].
struct TemplateGains {
  double mass;
  double damping;
  double stiffness;
};

// The double mass-spring-damper a robot renders unless its config says otherwise, translational
// and rotational; base_rotation.mass 0 means the robot's composite rotational inertia.
struct DefaultTemplate {
  TemplateGains base;
  TemplateGains ee;
  TemplateGains base_rotation;
  TemplateGains ee_rotation;
};

enum class Shape { box, cylinder, sphere };

// A collision primitive on a body. box: size = (x, y, z) full lengths;
// cylinder: (radius, length, 0) along its local z; sphere: (radius, 0, 0).
struct Collision {
  int body;
  Shape shape;
  std::array<double, 3> size_m;
  Transform origin;              // primitive frame in the body frame
};

}  // namespace springbok::model
