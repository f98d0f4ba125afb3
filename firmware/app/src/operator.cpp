#include "springbok/app/operator.hpp"

#include <algorithm>
#include <cstdio>
#include <vector>

#include <yaml-cpp/yaml.h>

#include "springbok/yaml/reader.hpp"
#include "springbok/params/controller_params.hpp"
#include "springbok/gait/trot.hpp"

namespace springbok::app {
namespace {

std::vector<std::string_view> split_words(std::string_view line) {
  std::vector<std::string_view> words;
  std::size_t i = 0;
  while (i < line.size()) {
    while (i < line.size() && (line[i] == ' ' || line[i] == '\t')) ++i;
    const std::size_t start = i;
    while (i < line.size() && line[i] != ' ' && line[i] != '\t') ++i;
    if (i > start) words.push_back(line.substr(start, i - start));
  }
  return words;
}

ParsedLine error(std::string text) {
  ParsedLine p;
  p.kind = ParsedLine::Kind::error;
  p.error = "error: " + std::move(text);
  return p;
}

ParsedLine command(safety::OperatorCommand c) {
  ParsedLine p;
  p.kind = ParsedLine::Kind::command;
  p.command = c;
  p.name = safety::to_string(c);
  return p;
}

ParsedLine controller_request(ControllerRequest r, std::string name) {
  ParsedLine p;
  p.kind = ParsedLine::Kind::controller_request;
  p.request = r;
  p.name = std::move(name);
  return p;
}

constexpr const char* kVerbs = "(start, stop, mode, reset, status, gait, walk, tune, hand, tare, controller, dump)";

// `walk <v_x> <v_y> <yaw_rate>`: the running trot's velocity (m/s, m/s, rad/s), checked by
// the config's reader against the trot's velocity ranges.
ParsedLine parse_walk(const std::vector<std::string_view>& words) {
  if (words.size() != 4) return error("walk needs three numbers: v_x v_y yaw_rate (m/s, m/s, rad/s)");
  YAML::Node params(YAML::NodeType::Map);
  params["velocity_x"] = std::string(words[1]);
  params["velocity_y"] = std::string(words[2]);
  params["yaw_rate"] = std::string(words[3]);
  yaml::Errors errors;
  const gait::TrotParams p = params::read_trot_params(yaml::Field(params, "walk", errors));
  if (!errors.empty()) return error(errors.lines().front());
  ControllerRequest r;
  r.kind = ControllerRequest::Kind::walk;
  r.velocity = {p.velocity_x_m_s, p.velocity_y_m_s, p.yaw_rate_rad_s};
  return controller_request(r, "walk");
}

// `key=value` words from words[first] on, as a YAML map for the config's reader (nodes
// without a position in a file: the messages carry no line); `lists`: a value [x,y,z] is a
// list of three words. An empty string, or the error (`name: ...`) in `why`.
YAML::Node key_values(const std::vector<std::string_view>& words, std::size_t first, const std::string& name,
                      bool lists, std::string& why) {
  YAML::Node params(YAML::NodeType::Map);
  for (std::size_t i = first; i < words.size(); ++i) {
    const std::string_view word = words[i];
    const std::size_t eq = word.find('=');
    if (eq == std::string_view::npos || eq == 0 || eq + 1 == word.size()) {
      why = name + ": expected key=value, got '" + std::string(word) + "'";
      return params;
    }
    const std::string key(word.substr(0, eq));
    if (params[key].IsDefined()) {
      why = name + "." + key + ": given twice";
      return params;
    }
    const std::string value(word.substr(eq + 1));
    if (lists && value.front() == '[' && value.back() == ']') {
      YAML::Node list(YAML::NodeType::Sequence);
      std::size_t at = 1;
      while (at < value.size()) {
        const std::size_t end = std::min(value.find(',', at), value.size() - 1);
        list.push_back(value.substr(at, end - at));
        at = end + 1;
      }
      params[key] = list;
    } else {
      params[key] = value;
    }
  }
  return params;
}

// `hand X Y Z [RX RY RZ] SECONDS`: the hand's rest point's target offset, optionally its
// rotation vector, and the move's duration.
ParsedLine parse_hand(const std::vector<std::string_view>& words) {
  if (words.size() != 5 && words.size() != 8) {
    return error("hand needs x y z (m, from the engaged rest point), optionally rx ry rz (rad, a rotation vector "
                 "from the engaged orientation), and a duration (s)");
  }
  const bool turns = words.size() == 8;
  YAML::Node params(YAML::NodeType::Map);
  for (std::size_t i = 1; i <= 3; ++i) params["offset"].push_back(std::string(words[i]));
  if (turns) {
    for (std::size_t i = 4; i <= 6; ++i) params["rotation"].push_back(std::string(words[i]));
  }
  params["duration"] = std::string(words.back());
  yaml::Errors errors;
  const yaml::Field f(params, "hand", errors);
  Vec3 offset = Vec3::Zero(), rotation = Vec3::Zero();
  ControllerRequest r;
  r.kind = ControllerRequest::Kind::hand;
  f["offset"].vector<3>(offset, -control::kHandMaxOffset_m, control::kHandMaxOffset_m);
  if (turns) f["rotation"].vector<3>(rotation, -control::kHandMaxRotation_rad, control::kHandMaxRotation_rad);
  f["duration"].number(r.hand_duration_s, control::kHandMinMove_s, 60.0);
  if (!errors.empty()) return error(errors.lines().front());
  r.hand_target = {offset.x(), offset.y(), offset.z()};
  r.hand_rotation = {rotation.x(), rotation.y(), rotation.z()};
  return controller_request(r, "hand");
}

// `tune key=value ...`: the template's M, D, K per body (base.mass .. ee.stiffness: a
// number for every axis or [x,y,z]), posture_kp, posture_kd and ramp (s), read with the
// config's reader and ranges (the message names the key).
ParsedLine parse_tune(const std::vector<std::string_view>& words) {
  static constexpr std::array<const char*, control::TuningRequest::kParts> kKeys{
      "base.mass",       "base.damping",       "base.stiffness", "ee.mass",           "ee.damping",
      "ee.stiffness",    "rot.base.damping",   "rot.base.stiffness", "rot.ee.inertia", "rot.ee.damping",
      "rot.ee.stiffness"};
  if (words.size() < 2) {
    return error("tune needs key=value: base.mass, base.damping, base.stiffness, ee.mass, ee.damping, "
                 "ee.stiffness, rot.base.damping, rot.base.stiffness, rot.ee.inertia, rot.ee.damping, "
                 "rot.ee.stiffness (a number or [x,y,z]), posture_kp, posture_kd, ramp (s)");
  }
  std::string why;
  const YAML::Node params = key_values(words, 1, "tune", true, why);
  if (!why.empty()) return error(why);
  yaml::Errors errors;
  const yaml::Field f(params, "tune", errors);
  ControllerRequest r;
  r.kind = ControllerRequest::Kind::tune;
  control::TuningRequest& t = r.tune;
  std::array<std::string_view, kKeys.size() + 3> allowed{};  // the template's keys, then the rest
  std::copy(kKeys.begin(), kKeys.end(), allowed.begin());
  allowed[kKeys.size()] = "posture_kp";
  allowed[kKeys.size() + 1] = "posture_kd";
  allowed[kKeys.size() + 2] = "ramp";
  if (f.allow_only(allowed)) {
    for (std::size_t p = 0; p < kKeys.size(); ++p) {
      const yaml::Field v = f[kKeys[p]];
      if (!v.present()) continue;
      Vec3 value = Vec3::Zero();
      t.set[p] = v.vector<3>(value, control::kTemplateRanges[p].lo, control::kTemplateRanges[p].hi, true);
      t.value[p] = {value.x(), value.y(), value.z()};
    }
    if (f["posture_kp"].present()) {
      t.set_posture_kp = f["posture_kp"].number(t.posture_kp_per_s2, control::kPostureKpRange.lo, control::kPostureKpRange.hi);
    }
    if (f["posture_kd"].present()) {
      t.set_posture_kd = f["posture_kd"].number(t.posture_kd_per_s, control::kPostureKdRange.lo, control::kPostureKdRange.hi);
    }
    f["ramp"].number(t.ramp_s, control::kTuningRampRange.lo, control::kTuningRampRange.hi);
  }
  if (!errors.empty()) return error(errors.lines().front());
  return controller_request(r, "tune");
}

// `gait stand` or `gait trot key=value ...`: the trot's keys read by the config's
// reader (the same ranges, the same messages).
ParsedLine parse_gait(const std::vector<std::string_view>& words) {
  if (words.size() < 2) return error("gait needs an argument: stand or trot [key=value ...]");
  ControllerRequest r;
  r.kind = ControllerRequest::Kind::gait;
  if (words[1] == "stand") {
    if (words.size() != 2) return error("gait stand takes no parameter");
    r.gait.kind = control::GaitKind::stand;
    return controller_request(r, "gait stand");
  }
  if (words[1] != "trot") return error("unknown gait '" + std::string(words[1]) + "' (stand or trot)");
  std::string why;
  const YAML::Node params = key_values(words, 2, "gait trot", false, why);
  if (!why.empty()) return error(why);
  yaml::Errors errors;
  r.gait.kind = control::GaitKind::trot;
  r.gait.trot = params::read_trot_params(yaml::Field(params, "gait trot", errors));
  if (!errors.empty()) return error(errors.lines().front());
  return controller_request(r, "gait trot");
}

}  // namespace

ParsedLine parse_operator_line(std::string_view line) {
  if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
  if (line.size() > kMaxOperatorLine) return error("line too long (at most 255 bytes)");
  for (const char c : line) {
    const auto u = static_cast<unsigned char>(c);
    if ((u < 0x20 && c != '\t') || u >= 0x7f) return error("non-printable byte in the command");
  }
  const std::vector<std::string_view> words = split_words(line);
  if (words.empty()) return error(std::string("empty command ") + kVerbs);
  const std::string_view verb = words[0];
  const std::size_t args = words.size() - 1;
  if (verb == "start" || verb == "stop" || verb == "reset" || verb == "status") {
    if (args != 0) return error(std::string(verb) + " takes no argument");
    if (verb == "status") {
      ParsedLine p;
      p.kind = ParsedLine::Kind::status;
      p.name = "status";
      return p;
    }
    if (verb == "start") return command(safety::OperatorCommand::start);
    if (verb == "stop") return command(safety::OperatorCommand::stop);
    return command(safety::OperatorCommand::reset);
  }
  if (verb == "mode") {
    if (args != 1) return error("mode needs one argument: stand or control");
    if (words[1] == "stand") return command(safety::OperatorCommand::mode_stand);
    if (words[1] == "control") return command(safety::OperatorCommand::mode_control);
    return error("unknown mode '" + std::string(words[1]) + "' (stand or control)");
  }
  if (verb == "gait") return parse_gait(words);
  if (verb == "walk") return parse_walk(words);
  if (verb == "tune") return parse_tune(words);
  if (verb == "hand") return parse_hand(words);
  if (verb == "tare" || verb == "controller" || verb == "dump") {
    if (args != 0) return error(std::string(verb) + " takes no argument");
    if (verb == "tare") return controller_request(ControllerRequest{}, "tare");
    ParsedLine p;
    p.kind = verb == "dump" ? ParsedLine::Kind::dump : ParsedLine::Kind::controller_status;
    p.name = std::string(verb);
    return p;
  }
  return error("unknown command '" + std::string(verb) + "' " + kVerbs);
}

std::string fault_list(safety::FaultMask faults) {
  if (faults == 0) return "none";
  std::string out;
  for (int bit = 0; bit < safety::fault::kCount; ++bit) {
    if ((faults & (1u << bit)) == 0) continue;
    if (!out.empty()) out += ',';
    out += safety::fault_name(bit);
  }
  return out;
}

std::string describe_log_record(const rt::LogRecord& r) {
  const auto mode = [](std::int64_t m) {
    return m >= 0 && m <= static_cast<std::int64_t>(safety::Mode::damping) ? safety::to_string(static_cast<safety::Mode>(m))
                                                                          : "?";
  };
  const auto faults = [](std::int64_t bits) { return fault_list(static_cast<safety::FaultMask>(bits)); };
  const auto buses = [](std::int64_t bits) {
    std::string out;
    for (int b = 0; b < 32; ++b) {
      if ((bits & (std::int64_t{1} << b)) != 0) out += (out.empty() ? "bus" : ",bus") + std::to_string(b);
    }
    return out.empty() ? std::string("none") : out;
  };
  switch (r.event) {
    case rt::LogEvent::mode_change: return std::string(mode(r.a)) + " -> " + mode(r.b);
    case rt::LogEvent::fault_latched: return "new=" + faults(r.a) + " latched=" + faults(r.b);
    case rt::LogEvent::sensors_lost: return "lost=" + faults(r.a) + " mode=" + mode(r.b);
    case rt::LogEvent::buses_degraded: return "degraded=" + buses(r.a) + " was=" + buses(r.b);
    case rt::LogEvent::bus_voltage_low: {
      const auto joints = [](std::int64_t bits) {
        std::string out;
        for (int j = 0; j < kNj; ++j) {
          if ((bits & (std::int64_t{1} << j)) != 0) out += (out.empty() ? "" : ",") + std::string(robot::kJoints[static_cast<std::size_t>(j)].name);
        }
        return out.empty() ? std::string("none") : out;
      };
      char lowest[32];
      std::snprintf(lowest, sizeof lowest, " lowest=%.2fV", r.x);
      return "low=" + joints(r.a) + " was=" + joints(r.b) + lowest;
    }
    case rt::LogEvent::command_accepted:
    case rt::LogEvent::command_rejected: {
      std::string words = r.a >= 0 && r.a <= static_cast<std::int64_t>(safety::OperatorCommand::reset)
                              ? safety::to_string(static_cast<safety::OperatorCommand>(r.a))
                              : "?";
      if (r.event == rt::LogEvent::command_rejected && r.b >= 0 && r.b <= static_cast<std::int64_t>(safety::Verdict::controller_not_ready)) {
        words += std::string(": ") + safety::to_string(static_cast<safety::Verdict>(r.b));
      }
      return words;
    }
    case rt::LogEvent::controller_request:
    case rt::LogEvent::controller_request_refused:
      if (r.a == static_cast<std::int64_t>(ControllerRequest::Kind::tare)) return "tare";
      if (r.a == static_cast<std::int64_t>(ControllerRequest::Kind::walk)) return "walk";
      if (r.a == static_cast<std::int64_t>(ControllerRequest::Kind::hand)) return "hand";
      if (r.a == static_cast<std::int64_t>(ControllerRequest::Kind::tune)) {
        char words[48];
        std::snprintf(words, sizeof words, "tune (ramp %.3g s)", r.x);
        return words;
      }
      return r.b == static_cast<std::int64_t>(control::GaitKind::trot) ? "gait trot" : "gait stand";
    default: return {};
  }
}

}  // namespace springbok::app
