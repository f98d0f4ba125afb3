// URDF parsing (tinyxml2) and the tree's bodies: see urdf_tree.hpp.
#include "urdf_tree.hpp"

#include <cmath>
#include <cstdlib>
#include <set>
#include <sstream>

#include <tinyxml2.h>

namespace springbok::urdf2model {

// ---- small 3D algebra (start-up code; clarity over speed) -----------------
Mat3 mul(const Mat3& a, const Mat3& b) {
  Mat3 c{};
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j)
      for (int k = 0; k < 3; ++k) c[3 * i + j] += a[3 * i + k] * b[3 * k + j];
  return c;
}
Vec3 mul(const Mat3& a, const Vec3& v) {
  Vec3 r{};
  for (int i = 0; i < 3; ++i)
    for (int k = 0; k < 3; ++k) r[i] += a[3 * i + k] * v[k];
  return r;
}
namespace {
Mat3 transpose(const Mat3& a) {
  Mat3 t{};
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) t[3 * i + j] = a[3 * j + i];
  return t;
}
}  // namespace
Vec3 add(const Vec3& a, const Vec3& b) { return {a[0] + b[0], a[1] + b[1], a[2] + b[2]}; }
Mat3 identity() { return {1, 0, 0, 0, 1, 0, 0, 0, 1}; }

namespace {
// URDF: R = Rz(yaw) Ry(pitch) Rx(roll).
Mat3 rpy_to_matrix(const Vec3& rpy) {
  const double cr = std::cos(rpy[0]), sr = std::sin(rpy[0]);
  const double cp = std::cos(rpy[1]), sp = std::sin(rpy[1]);
  const double cy = std::cos(rpy[2]), sy = std::sin(rpy[2]);
  return {cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr,
          sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr,
          -sp,     cp * sr,                cp * cr};
}

}  // namespace

Mat3 axis_angle(const Vec3& a, double angle_rad) {
  const double c = std::cos(angle_rad), s = std::sin(angle_rad), t = 1.0 - c;
  return {t * a[0] * a[0] + c,        t * a[0] * a[1] - s * a[2], t * a[0] * a[2] + s * a[1],
          t * a[0] * a[1] + s * a[2], t * a[1] * a[1] + c,        t * a[1] * a[2] - s * a[0],
          t * a[0] * a[2] - s * a[1], t * a[1] * a[2] + s * a[0], t * a[2] * a[2] + c};
}

Pose compose(const Pose& a, const Pose& b) { return {mul(a.R, b.R), add(mul(a.R, b.t), a.t)}; }

namespace {

// Adds `part` (already expressed in the body frame) to `body` (parallel axis theorem).
void merge_into(Body& body, const Body& part) {
  const double m = body.mass + part.mass;
  if (part.mass == 0.0 && part.inertia == Mat3{}) return;
  Vec3 c{0, 0, 0};
  if (m > 0)
    for (int i = 0; i < 3; ++i) c[i] = (body.mass * body.com[i] + part.mass * part.com[i]) / m;
  auto shifted = [&c](const Body& b) {
    const Vec3 d{b.com[0] - c[0], b.com[1] - c[1], b.com[2] - c[2]};
    const double dd = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
    Mat3 r = b.inertia;
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) r[3 * i + j] += b.mass * ((i == j ? dd : 0.0) - d[i] * d[j]);
    return r;
  };
  const Mat3 a = shifted(body), b = shifted(part);
  for (int i = 0; i < 9; ++i) body.inertia[i] = a[i] + b[i];
  body.mass = m;
  body.com = c;
}

Body transformed(const Body& b, const Pose& p) {
  return {b.mass, add(mul(p.R, b.com), p.t), mul(mul(p.R, b.inertia), transpose(p.R))};
}

// ---- URDF parsing ---------------------------------------------------------
double parse_number(const std::string& s, const std::string& where) {
  const char* begin = s.c_str();
  char* end = nullptr;
  const double v = std::strtod(begin, &end);
  while (end && *end == ' ') ++end;
  if (end == begin || (end && *end != '\0') || !std::isfinite(v))
    throw Error(where + ": bad number '" + s + "'");
  return v;
}

Vec3 parse_vec3(const char* text, const std::string& where, Vec3 fallback) {
  if (!text) return fallback;
  std::istringstream in(text);
  std::vector<std::string> tok;
  for (std::string t; in >> t;) tok.push_back(t);
  if (tok.size() != 3) throw Error(where + ": expected 3 numbers, got '" + std::string(text) + "'");
  return {parse_number(tok[0], where), parse_number(tok[1], where), parse_number(tok[2], where)};
}

double required_attr(const tinyxml2::XMLElement* e, const char* name, const std::string& where) {
  const char* text = e ? e->Attribute(name) : nullptr;
  if (!text) throw Error(where + ": missing attribute '" + name + "'");
  return parse_number(text, where + " " + name);
}

Pose parse_origin(const tinyxml2::XMLElement* parent, const std::string& where) {
  const auto* o = parent->FirstChildElement("origin");
  if (!o) return {};
  return {rpy_to_matrix(parse_vec3(o->Attribute("rpy"), where + " <origin rpy>", {0, 0, 0})),
          parse_vec3(o->Attribute("xyz"), where + " <origin xyz>", {0, 0, 0})};
}

Link parse_link(const tinyxml2::XMLElement* e) {
  Link l;
  const char* name = e->Attribute("name");
  if (!name) throw Error("<link> without a name attribute (line " + std::to_string(e->GetLineNum()) + ")");
  l.name = name;
  const std::string where = "link '" + l.name + "'";
  const auto* in = e->FirstChildElement("inertial");
  if (!in) throw Error(where + ": missing <inertial>");
  const auto* mass = in->FirstChildElement("mass");
  if (!mass) throw Error(where + ": <inertial> without <mass>");
  l.body.mass = required_attr(mass, "value", where + " <mass>");
  if (l.body.mass < 0) throw Error(where + ": negative mass");
  const auto* I = in->FirstChildElement("inertia");
  if (!I) throw Error(where + ": <inertial> without <inertia>");
  const std::string iw = where + " <inertia>";
  const double ixx = required_attr(I, "ixx", iw), iyy = required_attr(I, "iyy", iw),
               izz = required_attr(I, "izz", iw), ixy = required_attr(I, "ixy", iw),
               ixz = required_attr(I, "ixz", iw), iyz = required_attr(I, "iyz", iw);
  const Pose inertial_origin = parse_origin(in, where + " <inertial>");
  const Body local{l.body.mass, {0, 0, 0}, {ixx, ixy, ixz, ixy, iyy, iyz, ixz, iyz, izz}};
  l.body = transformed(local, inertial_origin);
  for (const auto* c = e->FirstChildElement("collision"); c; c = c->NextSiblingElement("collision")) {
    const auto* g = c->FirstChildElement("geometry");
    const auto* shape = g ? g->FirstChildElement() : nullptr;
    if (!shape) throw Error(where + ": <collision> without <geometry>");
    Geometry geo;
    geo.origin = parse_origin(c, where + " <collision>");
    geo.shape = shape->Name();
    const std::string gw = where + " <" + geo.shape + ">";
    if (geo.shape == "box") {
      geo.size = parse_vec3(shape->Attribute("size"), gw + " size", {0, 0, 0});
    } else if (geo.shape == "cylinder") {
      geo.size = {required_attr(shape, "radius", gw), required_attr(shape, "length", gw), 0};
    } else if (geo.shape == "sphere") {
      geo.size = {required_attr(shape, "radius", gw), 0, 0};
    } else if (geo.shape == "mesh") {
      l.meshes.push_back(shape->Attribute("filename") ? shape->Attribute("filename") : "");
      continue;  // not simulated: the generated model lists it
    } else {
      throw Error(where + ": unsupported collision geometry <" + geo.shape + ">");
    }
    l.collisions.push_back(geo);
  }
  return l;
}

JointIn parse_joint(const tinyxml2::XMLElement* e) {
  JointIn j;
  const char* name = e->Attribute("name");
  if (!name) throw Error("<joint> without a name attribute (line " + std::to_string(e->GetLineNum()) + ")");
  j.name = name;
  const std::string where = "joint '" + j.name + "'";
  const char* type = e->Attribute("type");
  if (!type) throw Error(where + ": missing type");
  j.type = type;
  if (j.type != "revolute" && j.type != "continuous" && j.type != "fixed")
    throw Error(where + ": unsupported joint type '" + j.type +
                "' (springbok models revolute, continuous and fixed joints)");
  const auto* p = e->FirstChildElement("parent");
  const auto* c = e->FirstChildElement("child");
  if (!p || !p->Attribute("link")) throw Error(where + ": missing <parent link=...>");
  if (!c || !c->Attribute("link")) throw Error(where + ": missing <child link=...>");
  j.parent = p->Attribute("link");
  j.child = c->Attribute("link");
  j.origin = parse_origin(e, where);
  if (const auto* a = e->FirstChildElement("axis")) j.axis = parse_vec3(a->Attribute("xyz"), where + " <axis>", {1, 0, 0});
  const double n = std::sqrt(j.axis[0] * j.axis[0] + j.axis[1] * j.axis[1] + j.axis[2] * j.axis[2]);
  if (j.type != "fixed" && n < 1e-12) throw Error(where + ": zero axis");
  if (n > 0)
    for (double& x : j.axis) x /= n;
  if (const auto* lim = e->FirstChildElement("limit")) {
    const std::string lw = where + " <limit>";
    j.effort = required_attr(lim, "effort", lw);
    j.velocity = required_attr(lim, "velocity", lw);
    if (j.type == "revolute") {
      j.has_limit = true;
      j.lower = required_attr(lim, "lower", lw);
      j.upper = required_attr(lim, "upper", lw);
      if (j.lower > j.upper) throw Error(lw + ": lower > upper");
    }
  } else if (j.type == "revolute") {
    throw Error(where + ": revolute joint without <limit>");
  }
  if (const auto* d = e->FirstChildElement("dynamics"); d && d->Attribute("damping"))
    j.damping = parse_number(d->Attribute("damping"), where + " <dynamics damping>");
  return j;
}


}  // namespace

// ---- the tree ---------------------------------------------------------------
Tree read_urdf(const std::string& path) {
  tinyxml2::XMLDocument doc;
  if (doc.LoadFile(path.c_str()) != tinyxml2::XML_SUCCESS)
    throw Error("cannot parse XML: " + std::string(doc.ErrorStr()));
  const auto* robot = doc.FirstChildElement("robot");
  if (!robot) throw Error("no <robot> element");
  Tree t;
  t.robot_name = robot->Attribute("name") ? robot->Attribute("name") : "robot";
  for (const auto* e = robot->FirstChildElement("link"); e; e = e->NextSiblingElement("link")) {
    Link l = parse_link(e);
    if (t.link_index.count(l.name)) throw Error("link '" + l.name + "' defined twice");
    t.link_index[l.name] = static_cast<int>(t.links.size());
    t.links.push_back(std::move(l));
  }
  if (t.links.empty()) throw Error("no <link>");
  std::set<std::string> children;
  for (const auto* e = robot->FirstChildElement("joint"); e; e = e->NextSiblingElement("joint")) {
    JointIn j = parse_joint(e);
    if (!t.link_index.count(j.parent)) throw Error("joint '" + j.name + "': unknown parent link '" + j.parent + "'");
    if (!t.link_index.count(j.child)) throw Error("joint '" + j.name + "': unknown child link '" + j.child + "'");
    if (!children.insert(j.child).second)
      throw Error("joint '" + j.name + "': link '" + j.child + "' has two parent joints");
    t.joints.push_back(std::move(j));
  }
  std::vector<std::string> roots;
  for (const auto& l : t.links)
    if (!children.count(l.name)) roots.push_back(l.name);
  if (roots.empty()) throw Error("no root link: the joints form a cycle");
  if (roots.size() > 1) {
    std::string names;
    for (const auto& r : roots) names += (names.empty() ? "'" : ", '") + r + "'";
    throw Error("more than one root link (" + names + "): the URDF must be one tree");
  }
  t.root = roots.front();
  return t;
}

Output build(const Tree& t) {
  Output out;
  std::map<std::string, std::vector<const JointIn*>> by_parent;
  for (const auto& j : t.joints) by_parent[j.parent].push_back(&j);

  std::set<std::string> visited;
  // Depth-first from the root; `body` = index of the movable body the link belongs to,
  // `pose` = the link frame in that body's frame.
  auto visit = [&](auto&& self, const std::string& link, int body, const Pose& pose) -> void {
    if (!visited.insert(link).second) throw Error("link '" + link + "' reached twice: the joints form a cycle");
    const Link& l = t.links[t.link_index.at(link)];
    Body& target = body == 0 ? out.base : out.joints[body - 1].body;
    merge_into(target, transformed(l.body, pose));
    for (const auto& m : l.meshes) out.skipped_meshes.push_back(l.name + ": " + m);
    for (const auto& g : l.collisions) {
      Geometry geo = g;
      geo.origin = compose(pose, g.origin);
      out.collisions.push_back({body, geo});
    }
    auto it = by_parent.find(link);
    if (it == by_parent.end()) return;
    for (const JointIn* j : it->second) {
      const Pose child_pose = compose(pose, j->origin);
      if (j->type == "fixed") {
        out.frames.push_back({j->child, body, child_pose});
        self(self, j->child, body, child_pose);
      } else {
        out.joints.push_back({*j, body, child_pose, Body{}});
        self(self, j->child, static_cast<int>(out.joints.size()), Pose{});
      }
    }
  };
  visit(visit, t.root, 0, Pose{});
  if (visited.size() != t.links.size()) {
    for (const auto& l : t.links)
      if (!visited.count(l.name)) throw Error("link '" + l.name + "' is not connected to the root (a cycle?)");
  }
  return out;
}


namespace {

// A rotation taking +z to the unit axis `a`: exact for the principal axes, else about z x a.
Mat3 z_to(const Vec3& a) {
  if (a == Vec3{1, 0, 0}) return {0, 0, 1, 0, 1, 0, -1, 0, 0};    // Ry(pi/2)
  if (a == Vec3{-1, 0, 0}) return {0, 0, -1, 0, 1, 0, 1, 0, 0};   // Ry(-pi/2)
  if (a == Vec3{0, 1, 0}) return {1, 0, 0, 0, 0, 1, 0, -1, 0};    // Rx(-pi/2)
  if (a == Vec3{0, -1, 0}) return {1, 0, 0, 0, 0, -1, 0, 1, 0};   // Rx(pi/2)
  if (a == Vec3{0, 0, -1}) return {1, 0, 0, 0, -1, 0, 0, 0, -1};  // Rx(pi)
  const double s = std::sqrt(a[0] * a[0] + a[1] * a[1]);  // |z x a|
  if (s < 1e-12) return identity();                        // +z (or numerically so)
  return axis_angle({-a[1] / s, a[0] / s, 0.0}, std::atan2(s, a[2]));
}

}  // namespace

void turn_axes_to_z(Output& o) {
  for (std::size_t i = 0; i < o.joints.size(); ++i) {
    Output::J& j = o.joints[i];
    if (j.in.axis == Vec3{0, 0, 1}) continue;
    const Mat3 ra = z_to(j.in.axis);
    const Pose into{transpose(ra), {0, 0, 0}};  // body frame coordinates -> the turned body's
    const int body = static_cast<int>(i) + 1;
    j.origin = compose(j.origin, Pose{ra, {0, 0, 0}});
    j.link_in_body = transpose(ra);
    j.in.axis = {0, 0, 1};
    j.body = transformed(j.body, into);
    for (auto& f : o.frames)
      if (f.body == body) f.placement = compose(into, f.placement);
    for (auto& c : o.collisions)
      if (c.body == body) c.geo.origin = compose(into, c.geo.origin);
    for (auto& child : o.joints)
      if (child.parent_body == body) child.origin = compose(into, child.origin);
  }
}

}  // namespace springbok::urdf2model
