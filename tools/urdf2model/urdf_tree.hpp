// The URDF as urdf2model reads it: links, joints, the tree rooted at the floating base, and the
// bodies it becomes (fixed joints merged, movable joints numbered depth-first in document
// order). Start-up tooling: clarity over speed; every problem is an Error naming the element.
#pragma once

#include <array>
#include <map>
#include <stdexcept>
#include <string>
#include <vector>

namespace springbok::urdf2model {

using Vec3 = std::array<double, 3>;
using Mat3 = std::array<double, 9>;  // row-major

struct Error : std::runtime_error {
  using std::runtime_error::runtime_error;
};

Mat3 mul(const Mat3& a, const Mat3& b);
Vec3 mul(const Mat3& a, const Vec3& v);
Vec3 add(const Vec3& a, const Vec3& b);
Mat3 identity();
// Rotation by `angle_rad` about the unit `axis` (Rodrigues).
Mat3 axis_angle(const Vec3& axis, double angle_rad);

struct Pose {
  Mat3 R = identity();
  Vec3 t{0, 0, 0};
};
Pose compose(const Pose& a, const Pose& b);

// Inertia about the COM in body axes, as a full symmetric matrix.
struct Body {
  double mass = 0;
  Vec3 com{0, 0, 0};
  Mat3 inertia{};  // about com
};

struct Geometry {
  std::string shape;
  Vec3 size{0, 0, 0};
  Pose origin;
};

struct Link {
  std::string name;
  Body body;  // in the link frame
  std::vector<Geometry> collisions;
  std::vector<std::string> meshes;  // collision meshes' file names (not simulated)
};

struct JointIn {
  std::string name, type, parent, child;
  Pose origin;
  Vec3 axis{1, 0, 0};
  bool has_limit = false;
  double lower = 0, upper = 0, effort = 0, velocity = 0, damping = 0;
};

struct Tree {
  std::string robot_name;
  std::string root;
  std::vector<Link> links;
  std::map<std::string, int> link_index;
  std::vector<JointIn> joints;
};

Tree read_urdf(const std::string& path);

// The bodies: body 0 is the floating base, body i + 1 is moved by joints[i].
struct Output {
  Body base;
  struct J {
    JointIn in;
    int parent_body;
    Pose origin;  // in the parent body frame
    Body body;
    Mat3 link_in_body = identity();  // the URDF link's axes in the body's (turn_axes_to_z)
  };
  std::vector<J> joints;
  struct F {
    std::string name;
    int body;
    Pose placement;
  };
  std::vector<F> frames;
  struct C {
    int body;
    Geometry geo;
  };
  std::vector<C> collisions;
  std::vector<std::string> skipped_meshes;  // "link: file" of each collision mesh
};

Output build(const Tree& t);

// Turns each moving body's frame so that its joint turns about +z of the joint frame, as the
// dynamics' kernels take it: the joint's origin is post-multiplied by a rotation R_a taking z to
// its axis, and everything expressed in the body's frame (its inertia, frames, collision
// shapes, and the origins of the joints it carries) pre-multiplied by R_a^T. The world pose of
// every named frame and the meaning of every q stay what the URDF says. A joint already about
// +z is left as it is.
void turn_axes_to_z(Output& o);

}  // namespace springbok::urdf2model
