// Reading the robot file against the URDF's bodies: see robot_file.hpp.
#include "robot_file.hpp"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <map>
#include <numbers>

namespace springbok::urdf2model {

namespace {

using yaml::Field;

constexpr double kPi = std::numbers::pi;

[[noreturn]] void refuse(const yaml::Errors& errors) {
  std::string text = "bad robot file:";
  for (const std::string& l : errors.lines()) text += "\n  " + l;
  throw Error(text);
}

std::string show_range(const JointIn& j) {
  return "[" + yaml::show(j.lower) + ", " + yaml::show(j.upper) + "]";
}

// A name the file gives: text, else an error.
std::string name_at(const Field& f) {
  std::string s;
  if (f.require()) f.text(s);
  return s;
}

// The movable joints by name, in the bodies' order.
std::map<std::string, int> joint_indices(const Output& o) {
  std::map<std::string, int> m;
  for (std::size_t i = 0; i < o.joints.size(); ++i) m[o.joints[i].in.name] = static_cast<int>(i);
  return m;
}

// Puts the joints in `order` (every joint once), renumbering the bodies they move.
void reorder(Output& o, const std::vector<int>& order) {
  std::vector<int> body_of(o.joints.size() + 1, 0);  // old body -> new body
  for (std::size_t k = 0; k < order.size(); ++k) body_of[static_cast<std::size_t>(order[k]) + 1] = static_cast<int>(k) + 1;
  std::vector<Output::J> joints;
  for (int old : order) {
    Output::J j = o.joints[static_cast<std::size_t>(old)];
    j.parent_body = body_of[static_cast<std::size_t>(j.parent_body)];
    joints.push_back(std::move(j));
  }
  o.joints = std::move(joints);
  for (auto& f : o.frames) f.body = body_of[static_cast<std::size_t>(f.body)];
  for (auto& c : o.collisions) c.body = body_of[static_cast<std::size_t>(c.body)];
}

// The index of frame `name`; a link that is a body's own (the base link, or a movable joint's
// child) becomes a frame at that body's origin. -1 (an error at `f`) when neither.
int frame_index(Output& o, const Tree& t, const Field& f, const std::string& name) {
  for (std::size_t i = 0; i < o.frames.size(); ++i) {
    if (o.frames[i].name == name) return static_cast<int>(i);
  }
  int body = -1;
  if (name == t.root) body = 0;
  for (std::size_t i = 0; i < o.joints.size(); ++i) {
    if (o.joints[i].in.child == name) body = static_cast<int>(i) + 1;
  }
  if (body < 0) {
    f.fail("'" + name + "' is no link of the URDF");
    return -1;
  }
  o.frames.push_back({name, body, Pose{}});
  return static_cast<int>(o.frames.size()) - 1;
}

std::string body_name(const Tree& t, const Output& o, int body) {
  return body == 0 ? t.root : o.joints[static_cast<std::size_t>(body) - 1].in.child;
}

// A frame that must sit on `body`.
int frame_on(Output& o, const Tree& t, const Field& f, int body, const std::string& what) {
  const std::string name = name_at(f);
  if (name.empty()) return -1;
  const int i = frame_index(o, t, f, name);
  if (i >= 0 && o.frames[static_cast<std::size_t>(i)].body != body) {
    f.fail("'" + name + "' must be fixed to " + what + " ('" + body_name(t, o, body) + "'), not to '" +
           body_name(t, o, o.frames[static_cast<std::size_t>(i)].body) + "'");
  }
  return i;
}

// A pose (stance_rad, lying_rad): three angles per leg and one per arm joint, within the ranges.
std::vector<double> read_pose(const Field& f, const Output& o, int arm_joints) {
  std::vector<double> q(o.joints.size(), 0.0);
  if (!f.require()) return q;
  f.allow_only({"lf", "rf", "lh", "rh", "arm"});
  for (int leg = 0; leg <= kFeet; ++leg) {
    const Field part = f[leg < kFeet ? kLegNames[static_cast<std::size_t>(leg)] : "arm"];
    const int first = leg * kLegJoints;
    const int n = leg < kFeet ? kLegJoints : arm_joints;
    if (!part.require() || !part.expect_list(static_cast<std::size_t>(n))) continue;
    for (int i = 0; i < n; ++i) {
      const Field e = part[static_cast<std::size_t>(i)];
      const JointIn& j = o.joints[static_cast<std::size_t>(first + i)].in;
      double v = 0;
      if (!e.number(v, -2 * kPi, 2 * kPi)) continue;
      if (j.has_limit && (v < j.lower || v > j.upper)) {
        e.fail(yaml::show(v) + " is outside " + j.name + "'s range " + show_range(j));
        continue;
      }
      q[static_cast<std::size_t>(first + i)] = v;
    }
  }
  return q;
}

GainsIn read_gains(const Field& f, bool with_mass, const char* mass_key) {
  GainsIn g;
  if (!f.require()) return g;
  if (with_mass) {
    f.allow_only({mass_key, "damping", "stiffness"});
    if (f[mass_key].require()) f[mass_key].number(g.mass, 1e-6, 1e6);
  } else {
    f.allow_only({"damping", "stiffness"});
  }
  if (f["damping"].require()) f["damping"].number(g.damping, 0.0, 1e6);
  if (f["stiffness"].require()) f["stiffness"].number(g.stiffness, 1e-6, 1e7);
  return g;
}

}  // namespace

RobotFile::RobotFile(std::string path) : path_(std::move(path)), doc_(yaml::parse_file(path_)) {
  if (!doc_.ok) throw Error(doc_.error);
  if (!doc_.root.IsMap()) throw Error(path_ + ": must be a map of the robot's fields");
}

std::string RobotFile::urdf_path() const {
  yaml::Errors errors;
  const Field urdf = Field(doc_.root, "", errors)["urdf"];
  const std::string name = name_at(urdf);
  if (!errors.empty()) refuse(errors);
  if (name.front() == '/') return name;
  const std::size_t slash = path_.find_last_of('/');
  return slash == std::string::npos ? name : path_.substr(0, slash + 1) + name;
}

void RobotFile::lock_joints(Tree& tree) const {
  yaml::Errors errors;
  const Field locked = Field(doc_.root, "", errors)["locked_joints"];
  if (!locked.present() || locked.node().IsNull()) return;
  if (!locked.is_map()) {
    locked.fail("must be a map of joint: angle [rad]");
    refuse(errors);
  }
  for (const std::string& name : locked.keys()) {
    const Field f = locked[name];
    const auto it = std::find_if(tree.joints.begin(), tree.joints.end(), [&](const JointIn& j) { return j.name == name; });
    if (it == tree.joints.end() || it->type == "fixed") {
      f.fail("'" + name + "' is no movable joint of the URDF");
      continue;
    }
    double angle = 0;
    if (!f.number(angle, -2 * kPi, 2 * kPi)) continue;
    if (it->has_limit && (angle < it->lower || angle > it->upper)) {
      f.fail(yaml::show(angle) + " is outside the joint's range " + show_range(*it));
      continue;
    }
    it->type = "fixed";
    it->origin = compose(it->origin, Pose{axis_angle(it->axis, angle), {0, 0, 0}});
  }
  if (!errors.empty()) refuse(errors);
}

RobotSpec RobotFile::apply(const Tree& tree, Output& o) const {
  yaml::Errors errors;
  const Field root(doc_.root, "", errors);
  root.allow_only({"name", "urdf", "base_link", "legs", "feet", "arm", "imu_frame", "wrist_ft_frame", "locked_joints",
                   "rotor_inertia_kgm2", "torque_limits", "stance_rad", "lying_rad", "template", "rotational_template"});
  RobotSpec s;
  s.name = name_at(root["name"]);
  if (!s.name.empty() &&
      (!std::all_of(s.name.begin(), s.name.end(), [](char c) { return std::islower(static_cast<unsigned char>(c)) || std::isdigit(static_cast<unsigned char>(c)) || c == '_'; }) ||
       !std::islower(static_cast<unsigned char>(s.name.front())))) {
    root["name"].fail("'" + s.name + "' must be lower case letters, digits and _, starting with a letter");
  }
  const std::string base = name_at(root["base_link"]);
  if (!base.empty() && base != tree.root) {
    root["base_link"].fail("'" + base + "' is not the URDF's root link '" + tree.root + "' (the floating base is the root)");
  }

  // ---- the joint order: legs LF RF LH RH, then the arm ----
  const std::map<std::string, int> index = joint_indices(o);
  std::vector<int> order;
  std::vector<Field> order_fields;
  auto take = [&](const Field& f) {
    const std::string name = name_at(f);
    if (name.empty()) return;
    const auto it = index.find(name);
    if (it == index.end()) {
      f.fail("'" + name + "' is no movable joint of the URDF (locked joints are not)");
    } else if (std::find(order.begin(), order.end(), it->second) != order.end()) {
      f.fail("'" + name + "' is named twice");
    } else {
      order.push_back(it->second);
      order_fields.push_back(f);
    }
  };
  const Field legs = root["legs"];
  if (legs.require() && legs.allow_only({"lf", "rf", "lh", "rh"})) {
    for (const char* leg : kLegNames) {
      const Field l = legs[leg];
      if (!l.require() || !l.expect_list(kLegJoints)) continue;
      for (std::size_t i = 0; i < kLegJoints; ++i) take(l[i]);
    }
  }
  const Field arm = root["arm"];
  const Field arm_joints = arm["joints"];
  if (arm.require() && arm.allow_only({"joints", "end_effector"}) && arm_joints.require() && arm_joints.expect_list()) {
    for (std::size_t i = 0; i < arm_joints.size(); ++i) take(arm_joints[i]);
  }
  if (!errors.empty()) refuse(errors);  // the rest reads the ordered joints
  for (const auto& [name, i] : index) {
    if (std::find(order.begin(), order.end(), i) == order.end()) {
      arm_joints.fail("the URDF's movable joint '" + name + "' is in no leg and not in the arm (a joint that must not move: locked_joints)");
    }
  }
  if (!errors.empty()) refuse(errors);
  reorder(o, order);
  s.first_arm_joint = kFeet * kLegJoints;
  s.arm_joints = static_cast<int>(o.joints.size()) - s.first_arm_joint;

  // Each leg and the arm a chain from the base: a joint hangs on the body of the one before it.
  auto check_chain = [&](int first, int count) {
    for (int k = first; k < first + count; ++k) {
      const int parent = o.joints[static_cast<std::size_t>(k)].parent_body;
      const int expected = k == first ? 0 : k;  // body k is moved by joint k - 1
      if (parent != expected) {
        order_fields[static_cast<std::size_t>(k)].fail(
            "'" + o.joints[static_cast<std::size_t>(k)].in.name + "' hangs on '" + body_name(tree, o, parent) +
            "', not on '" + body_name(tree, o, expected) + "': a leg or the arm is a chain of joints from the base link");
      }
    }
  };
  for (int leg = 0; leg < kFeet; ++leg) check_chain(leg * kLegJoints, kLegJoints);
  check_chain(s.first_arm_joint, s.arm_joints);
  if (!errors.empty()) refuse(errors);

  // ---- frames ----
  const Field feet = root["feet"];
  if (feet.require() && feet.allow_only({"frames", "radius_m", "offset_m"})) {
    const Field frames = feet["frames"];
    if (frames.require() && frames.expect_list(kFeet)) {
      for (int leg = 0; leg < kFeet; ++leg) {
        s.foot_frames[static_cast<std::size_t>(leg)] =
            frame_on(o, tree, frames[static_cast<std::size_t>(leg)], (leg + 1) * kLegJoints,
                     std::string("leg ") + kLegNames[static_cast<std::size_t>(leg)] + "'s last body");
      }
    }
    if (feet["radius_m"].require()) feet["radius_m"].number(s.foot_radius_m, 0.0, 0.5);
    Eigen::Vector3d offset = Eigen::Vector3d::Zero();
    if (feet["offset_m"].require() && feet["offset_m"].vector<3>(offset, -1.0, 1.0) && !offset.isZero() &&
        errors.empty()) {
      // The sphere's centre off the foot frame: a frame of its own, which the controller uses.
      for (int& f : s.foot_frames) {
        const Output::F foot = o.frames[static_cast<std::size_t>(f)];
        o.frames.push_back({foot.name + "_sphere", foot.body, compose(foot.placement, Pose{identity(), {offset[0], offset[1], offset[2]}})});
        f = static_cast<int>(o.frames.size()) - 1;
      }
    }
  }
  const int hand_body = static_cast<int>(o.joints.size());
  s.ee_frame = frame_on(o, tree, arm["end_effector"], hand_body, "the arm's last body");
  s.imu_frame = frame_on(o, tree, root["imu_frame"], 0, "the base link");
  s.wrist_ft_frame = frame_on(o, tree, root["wrist_ft_frame"], hand_body, "the arm's last body");

  // ---- actuators ----
  const std::size_t nj = o.joints.size();
  s.rotor_inertia_kgm2.assign(nj, 0.0);
  const Field rotors = root["rotor_inertia_kgm2"];
  if (rotors.require() && rotors.is_map()) {
    if (rotors["source"].require()) rotors["source"].text(s.rotor_source);
    for (const std::string& key : rotors.keys()) {
      if (key == "source") continue;
      const auto it = std::find_if(o.joints.begin(), o.joints.end(), [&](const Output::J& j) { return j.in.name == key; });
      if (it == o.joints.end()) {
        rotors[key].fail("'" + key + "' is no joint of the robot");
        continue;
      }
      rotors[key].number(s.rotor_inertia_kgm2[static_cast<std::size_t>(it - o.joints.begin())], 0.0, 100.0);
    }
  } else if (rotors.present()) {
    rotors.fail("must be a map: source, and joint: inertia [kg m^2] (joints not named: 0)");
  }
  s.lever.assign(nj, false);
  s.levers.assign(nj, LeverIn{});
  const Field limits = root["torque_limits"];
  if (limits.present() && !limits.node().IsNull() && !limits.is_map()) limits.fail("must be a map of joint: {flat: N m} or {lever: {...}}");
  for (const std::string& key : limits.keys()) {
    const Field f = limits[key];
    const auto it = std::find_if(o.joints.begin(), o.joints.end(), [&](const Output::J& j) { return j.in.name == key; });
    if (it == o.joints.end()) {
      f.fail("'" + key + "' is no joint of the robot");
      continue;
    }
    const std::size_t j = static_cast<std::size_t>(it - o.joints.begin());
    if (!f.allow_only({"flat", "lever"})) continue;
    if (f["flat"].present() == f["lever"].present()) {
      f.fail("give one of flat (N m) or lever");
      continue;
    }
    if (f["flat"].present()) {
      f["flat"].number(it->in.effort, 1e-3, 1e5);
      continue;
    }
    const Field l = f["lever"];
    LeverIn& in = s.levers[j];
    if (!l.allow_only({"force_max_n", "a_m", "b_m", "angle_sign", "angle_offset_rad"})) continue;
    bool ok = true;
    for (const char* k : {"force_max_n", "a_m", "b_m", "angle_sign", "angle_offset_rad"}) ok = l[k].require() && ok;
    ok = l["force_max_n"].number(in.force_max_n, 1e-3, 1e7) && ok;
    ok = l["a_m"].number(in.a_m, 1e-6, 10.0) && ok;
    ok = l["b_m"].number(in.b_m, 1e-6, 10.0) && ok;
    ok = l["angle_sign"].number(in.angle_sign, -1.0, 1.0) && ok;
    ok = l["angle_offset_rad"].number(in.angle_offset_rad, -2 * kPi, 2 * kPi) && ok;
    if (ok && in.angle_sign != 1.0 && in.angle_sign != -1.0) l["angle_sign"].fail("must be 1 or -1");
    if (ok && in.a_m <= in.b_m) l["b_m"].fail("must be shorter than a_m (the cylinder never reaches zero length)");
    if (ok && !it->in.has_limit) f.fail("a lever actuator needs a joint with a range ('" + key + "' is continuous)");
    s.lever[j] = true;
  }
  for (const auto& j : o.joints) {
    if (!(j.in.effort > 0.0)) {
      limits.fail("'" + j.in.name + "' has no torque limit (the URDF's effort is " + yaml::show(j.in.effort) + "): give one");
    }
  }

  // ---- poses and the template ----
  if (errors.empty()) {
    s.stance_rad = read_pose(root["stance_rad"], o, s.arm_joints);
    s.lying_rad = read_pose(root["lying_rad"], o, s.arm_joints);
  }
  const Field tmpl = root["template"];
  if (tmpl.require() && tmpl.allow_only({"base", "ee"})) {
    s.base = read_gains(tmpl["base"], true, "mass");
    s.ee = read_gains(tmpl["ee"], true, "mass");
  }
  const Field rot = root["rotational_template"];
  if (rot.require() && rot.allow_only({"base", "ee"})) {
    s.base_rotation = read_gains(rot["base"], false, "inertia");
    s.ee_rotation = read_gains(rot["ee"], true, "inertia");
  }
  if (!errors.empty()) refuse(errors);
  return s;
}

}  // namespace springbok::urdf2model
