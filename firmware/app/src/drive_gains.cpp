#include "springbok/app/drive_gains.hpp"

#include <sstream>

namespace springbok::app {
namespace {

enum class Gain { kp, kd };

enum class Joints { legs, arm, all };

struct Field {
  std::string name;  // e.g. "gains.stand.kp_legs"
  Gain gain;
  Joints joints;
  double value;
};

std::string describe(const Field& f, int joint, double lo, double hi, const std::string& drive) {
  std::ostringstream s;
  s << f.name << ": " << f.value << " is outside the " << (f.gain == Gain::kp ? "kp" : "kd") << " range [" << lo
    << ", " << hi << "] of " << robot::kJoints[static_cast<std::size_t>(joint)].name << "'s " << drive
    << " (the drive would clamp it); lower the gain or give the drive a wider range (can.mit_ranges)";
  return s.str();
}

}  // namespace

std::vector<std::string> check_drive_gains(const AppConfig& c, const DriveGainRanges& r) {
  const auto legs_arm = [](const std::string& prefix, Gain gain, const VecNj& values) {
    const char* key = gain == Gain::kp ? "kp" : "kd";
    return std::array<Field, 2>{Field{prefix + key + "_legs", gain, Joints::legs, values[0]},
                                Field{prefix + key + "_arm", gain, Joints::arm, values[kFirstArmJoint]}};
  };
  std::vector<Field> fields;
  for (const auto& [prefix, gains] :
       {std::pair{"gains.stand.", &c.stand_gains}, std::pair{"gains.control.", &c.control_gains}}) {
    for (const Field& f : legs_arm(prefix, Gain::kp, gains->kp_nm_per_rad)) fields.push_back(f);
    for (const Field& f : legs_arm(prefix, Gain::kd, gains->kd_nms_per_rad)) fields.push_back(f);
  }
  const VecNj& damping = c.safety.damping_nms_per_rad;
  fields.push_back(Field{"safety.damping_nms_per_rad.legs", Gain::kd, Joints::legs, damping[0]});
  fields.push_back(Field{"safety.damping_nms_per_rad.arm", Gain::kd, Joints::arm, damping[kFirstArmJoint]});
  const VecNj& idle = c.safety.idle_damping_nms_per_rad;
  fields.push_back(Field{"safety.idle_damping_nms_per_rad.legs", Gain::kd, Joints::legs, idle[0]});
  fields.push_back(Field{"safety.idle_damping_nms_per_rad.arm", Gain::kd, Joints::arm, idle[kFirstArmJoint]});
  for (const auto& [name, kd] : r.backend_kd) fields.push_back(Field{name, Gain::kd, Joints::all, kd});

  std::vector<std::string> errors;
  for (const Field& f : fields) {
    const int first = f.joints == Joints::arm ? kFirstArmJoint : 0;
    const int last = f.joints == Joints::legs ? kFirstArmJoint : kNj;
    for (int j = first; j < last; ++j) {
      if (!r.in_drive[static_cast<std::size_t>(j)]) continue;
      const double lo = f.gain == Gain::kp ? r.kp_min[j] : r.kd_min[j];
      const double hi = f.gain == Gain::kp ? r.kp_max[j] : r.kd_max[j];
      if (f.value < lo || f.value > hi) {
        errors.push_back(describe(f, j, lo, hi, r.drive[static_cast<std::size_t>(j)]));
        break;
      }
    }
  }
  return errors;
}

}  // namespace springbok::app
