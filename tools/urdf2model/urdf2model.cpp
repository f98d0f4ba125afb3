// urdf2model: reads a URDF (tinyxml2) and writes the C++ header holding the
// compile-time robot model (springbok::model types, see model_types.hpp).
//
//   urdf2model ROBOT.urdf OUT.hpp [--namespace NAME]
//
// The tree is rooted at the single link that is no joint's child (the
// floating base). Fixed joints are merged: their child links' inertias move
// into the movable parent body, and they become named frames. Movable joints
// are numbered depth-first in document order, so the URDF's joint order is
// the generalized-coordinate order. Any structural problem (missing
// <inertial>, unknown joint type, unknown link, a cycle, two roots, a bad
// number) is an error that names the element.
#include <array>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <map>
#include <set>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>
#include <tinyxml2.h>

namespace {

using Vec3 = std::array<double, 3>;
using Mat3 = std::array<double, 9>;  // row-major

struct Error : std::runtime_error {
  using std::runtime_error::runtime_error;
};

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
Mat3 transpose(const Mat3& a) {
  Mat3 t{};
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) t[3 * i + j] = a[3 * j + i];
  return t;
}
Vec3 add(const Vec3& a, const Vec3& b) { return {a[0] + b[0], a[1] + b[1], a[2] + b[2]}; }
Mat3 identity() { return {1, 0, 0, 0, 1, 0, 0, 0, 1}; }

// URDF: R = Rz(yaw) Ry(pitch) Rx(roll).
Mat3 rpy_to_matrix(const Vec3& rpy) {
  const double cr = std::cos(rpy[0]), sr = std::sin(rpy[0]);
  const double cp = std::cos(rpy[1]), sp = std::sin(rpy[1]);
  const double cy = std::cos(rpy[2]), sy = std::sin(rpy[2]);
  return {cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr,
          sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr,
          -sp,     cp * sr,                cp * cr};
}

struct Pose {
  Mat3 R = identity();
  Vec3 t{0, 0, 0};
};
Pose compose(const Pose& a, const Pose& b) { return {mul(a.R, b.R), add(mul(a.R, b.t), a.t)}; }

// Inertia about the COM in body axes, as a full symmetric matrix.
struct Body {
  double mass = 0;
  Vec3 com{0, 0, 0};
  Mat3 inertia{};  // about com
};

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

struct Geometry {
  std::string shape;
  Vec3 size{0, 0, 0};
  Pose origin;
};

struct Link {
  std::string name;
  Body body;  // in the link frame
  std::vector<Geometry> collisions;
};

struct JointIn {
  std::string name, type, parent, child;
  Pose origin;
  Vec3 axis{1, 0, 0};
  bool has_limit = false;
  double lower = 0, upper = 0, effort = 0, velocity = 0, damping = 0;
};

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

// ---- the tree ---------------------------------------------------------------
struct Tree {
  std::string robot_name;
  std::string root;
  std::vector<Link> links;
  std::map<std::string, int> link_index;
  std::vector<JointIn> joints;
};

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

struct Output {
  Body base;
  struct J {
    const JointIn* in;
    int parent_body;
    Pose origin;  // in the parent body frame
    Body body;
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
};

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
        out.joints.push_back({j, body, child_pose, Body{}});
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

// ---- emission ---------------------------------------------------------------
std::string num(double v) {
  if (v == 0.0) return "0.0";  // also folds -0
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.17g", v);
  std::string s = buf;
  if (s.find_first_of(".eEn") == std::string::npos) s += ".0";
  return s;
}
template <std::size_t N>
std::string arr(const std::array<double, N>& a) {
  std::string s = "{";
  for (std::size_t i = 0; i < N; ++i) s += (i ? ", " : "") + num(a[i]);
  return s + "}";
}
std::string transform(const Pose& p) { return "{" + arr(p.R) + ", " + arr(p.t) + "}"; }
std::string inertia(const Body& b) {
  const std::array<double, 6> I{b.inertia[0], b.inertia[4], b.inertia[8], b.inertia[1], b.inertia[2], b.inertia[5]};
  return "{" + num(b.mass) + ", " + arr(b.com) + ", " + arr(I) + "}";
}
std::string ident(std::string s) {
  for (char& c : s)
    if (!std::isalnum(static_cast<unsigned char>(c))) c = '_';
  return s;
}

std::string emit(const Tree& t, const Output& o, const std::string& ns, const std::string& source) {
  std::ostringstream h;
  h << "// GENERATED by tools/urdf2model from " << source << " -- do not edit by hand.\n"
    << "// Regenerate: build/<preset>/bin/urdf2model ../shared/robot/" << source
    << " firmware/model/include/springbok/model/" << ns << ".hpp\n"
    << "// A test regenerates this file and fails on any difference.\n"
    << "#pragma once\n\n#include <array>\n#include <string_view>\n\n"
    << "#include \"springbok/model/model_types.hpp\"\n\n"
    << "namespace springbok::model::" << ns << " {\n\n"
    << "inline constexpr std::string_view kRobotName = \"" << t.robot_name << "\";\n"
    << "inline constexpr std::string_view kBaseLink = \"" << t.root << "\";\n"
    << "inline constexpr int kNumJoints = " << o.joints.size() << ";\n"
    << "inline constexpr int kNumBodies = kNumJoints + 1;  // body 0 = the floating base\n\n"
    << "// The floating base with every fixed-attached link merged in.\n"
    << "inline constexpr Inertia kBaseInertia" << inertia(o.base) << ";\n\n"
    << "// Movable joints in generalized-coordinate order; joint i moves body i + 1.\n"
    << "inline constexpr std::array<Joint, kNumJoints> kJoints{{\n";
  for (const auto& j : o.joints) {
    const auto& in = *j.in;
    h << "    {\"" << in.name << "\", \"" << in.child << "\", " << j.parent_body << ",\n"
      << "     " << transform(j.origin) << ",\n"
      << "     " << arr(in.axis) << ", JointType::" << in.type << ",\n"
      << "     {" << (in.has_limit ? "true" : "false") << ", " << num(in.lower) << ", " << num(in.upper) << ", "
      << num(in.effort) << ", " << num(in.velocity) << "}, " << num(in.damping) << ",\n"
      << "     " << inertia(j.body) << "},\n";
  }
  h << "}};\n\n// Frames rigidly attached to a body (fixed-joint child links).\n"
    << "inline constexpr int kNumFrames = " << o.frames.size() << ";\n"
    << "inline constexpr std::array<Frame, kNumFrames> kFrames{{\n";
  for (const auto& f : o.frames)
    h << "    {\"" << f.name << "\", " << f.body << ", " << transform(f.placement) << "},\n";
  h << "}};\n";
  for (std::size_t i = 0; i < o.frames.size(); ++i)
    h << "inline constexpr int kFrame_" << ident(o.frames[i].name) << " = " << i << ";\n";
  h << "\n// Joint indices by name.\n";
  for (std::size_t i = 0; i < o.joints.size(); ++i)
    h << "inline constexpr int kJoint_" << ident(o.joints[i].in->name) << " = " << i << ";\n";
  h << "\n// Collision primitives (for the simulator), in body frames.\n"
    << "inline constexpr int kNumCollisions = " << o.collisions.size() << ";\n"
    << "inline constexpr std::array<Collision, kNumCollisions> kCollisions{{\n";
  for (const auto& c : o.collisions)
    h << "    {" << c.body << ", Shape::" << c.geo.shape << ", " << arr(c.geo.size) << ", " << transform(c.geo.origin)
      << "},\n";
  h << "}};\n\n}  // namespace springbok::model::" << ns << "\n";
  return h.str();
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"urdf2model: URDF -> springbok compile-time model header"};
  std::string urdf, out, ns;
  app.add_option("urdf", urdf, "the robot's URDF")->required();
  app.add_option("out", out, "header to write ('-' = stdout)")->required();
  app.add_option("--namespace", ns, "namespace under springbok::model (default: the robot name)");
  CLI11_PARSE(app, argc, argv);
  try {
    const Tree tree = read_urdf(urdf);
    if (ns.empty()) ns = ident(tree.robot_name);
    const Output o = build(tree);
    const std::string source = urdf.substr(urdf.find_last_of('/') + 1);
    const std::string text = emit(tree, o, ns, source);
    if (out == "-") {
      std::fwrite(text.data(), 1, text.size(), stdout);
    } else {
      const std::string tmp = out + ".tmp";
      {
        std::ofstream f(tmp, std::ios::binary);
        if (!(f << text)) throw Error(out + ": cannot write");
      }
      if (std::rename(tmp.c_str(), out.c_str()) != 0) throw Error(out + ": cannot write");
    }
  } catch (const std::exception& e) {
    std::fprintf(stderr, "urdf2model: %s: %s\n", urdf.c_str(), e.what());
    return 1;
  }
  return 0;
}
