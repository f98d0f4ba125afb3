#include <limits>
#include <string>

#include "springbok/yaml/reader.hpp"
#include "springbok/drive_emulator/drives.hpp"

namespace springbok::emu {

namespace {

FaultResult read_faults(const yaml::Document& doc) {
  FaultResult r;
  if (!doc.ok) {
    r.error = doc.error;
    return r;
  }
  yaml::Errors errors;
  const yaml::Field root(doc.root, "", errors);
  root.allow_only({"faults"});
  const yaml::Field list = root["faults"];
  if (list.require() && list.expect_list()) {
    for (std::size_t i = 0; i < list.size(); ++i) {
      const yaml::Field n = list[i];
      if (!n.is_map()) {
        n.fail("must be a map {kind, drive | sensor, at, count, param}, got " + n.describe());
        continue;
      }
      n.allow_only({"kind", "drive", "sensor", "at", "at_sdo", "at_frame", "count", "param"});
      Fault f;
      int kind = -1;
      std::string name;
      if (n["kind"].require() && n["kind"].text(name)) {
        std::string known;
        for (int k = 0; k <= static_cast<int>(FaultKind::not_ready); ++k) {
          if (name == to_string(static_cast<FaultKind>(k))) kind = k;
          known += std::string(known.empty() ? "" : ", ") + to_string(static_cast<FaultKind>(k));
        }
        if (kind < 0) n["kind"].fail("'" + name + "' is not a fault kind (known: " + known + ")");
      }
      if (kind >= 0) {
        f.kind = static_cast<FaultKind>(kind);
        const bool sensor_kind = f.kind >= FaultKind::stale_counter;
        const bool shared = f.kind == FaultKind::silent || f.kind == FaultKind::drop || f.kind == FaultKind::wrong_dlc;
        int sensor = -1;
        if (n["sensor"].choice(sensor, {"imu", "wrist_ft"})) {
          f.sensor = sensor == 0 ? SensorId::imu : SensorId::wrist_ft;
          if (n["drive"].present()) n.fail("give either `drive` or `sensor`");
          if (!sensor_kind && !shared) n["kind"].fail(std::string("'") + to_string(f.kind) + "' is not a sensor fault");
          if (f.kind == FaultKind::corrupt_quaternion && f.sensor != SensorId::imu) {
            n["kind"].fail("corrupt_quaternion is an IMU fault");
          }
        } else if (!n["sensor"].present()) {
          if (sensor_kind) {
            n["sensor"].fail(std::string("'") + to_string(f.kind) + "' needs `sensor: imu` or `sensor: wrist_ft`");
          } else if (n["drive"].require()) {
            (void)n["drive"].integer(f.drive_id, 1, 127);
          }
        }
      }
      constexpr long long kMax = std::numeric_limits<long long>::max();
      if (kind >= 0 && is_property(f.kind)) {
        // A property of the drive from power-on: no time, the value in `param`.
        for (const char* key : {"at", "at_sdo", "at_frame", "count"}) {
          if (n[key].present()) n[key].fail(std::string("does not apply to '") + to_string(f.kind) + "' (a drive property from power-on)");
        }
        if (f.kind == FaultKind::enable_blocked) {
          if (n["param"].present()) n["param"].fail("does not apply to 'enable_blocked' (it has no value)");
        } else if (n["param"].require()) {
          if (f.kind == FaultKind::rated_torque) {
            (void)n["param"].integer(f.param, 0, 0xFFFFFFFFLL);  // mNm; 0 is a drive fault worth injecting
          } else if (f.kind == FaultKind::vendor_error) {
            (void)n["param"].integer(f.param, 1, 0xFF);  // the reply's error byte; 0 is no error
          } else {
            (void)n["param"].integer(f.param, 1, 60000);  // ms
          }
        }
      } else {
        if (n["at_sdo"].present()) {
          if (kind >= 0 && f.kind != FaultKind::emcy) {
            n["at_sdo"].fail("only for kind emcy (CiA 402: the EMCY after the k-th SDO answer)");
          } else if (n["at"].present()) {
            n.fail("give either `at` or `at_sdo`");
          } else {
            (void)n["at_sdo"].integer(f.at_sdo, 1, kMax);
          }
        } else if (n["at_frame"].present()) {
          if (kind >= 0 && (f.kind != FaultKind::silent || f.sensor != SensorId::none)) {
            n["at_frame"].fail("only for a drive's kind silent (unplugged from its k-th frame on)");
          } else if (n["at"].present()) {
            n.fail("give either `at` or `at_frame`");
          } else {
            (void)n["at_frame"].integer(f.at_frame, 1, kMax);
          }
        } else if (n["at"].require()) {
          (void)n["at"].integer(f.at_tick, 1, kMax);
        }
        (void)n["count"].integer(f.count, 1, kMax);
        (void)n["param"].integer(f.param, 0, 0xFFFFFFFFLL);
      }
      r.faults.push_back(f);
    }
  }
  r.error = errors.joined();
  r.ok = errors.empty();
  if (!r.ok) r.faults.clear();
  return r;
}

}  // namespace

FaultResult load_faults_text(const std::string& text) { return read_faults(yaml::parse_text(text)); }

FaultResult load_faults_file(const std::string& path) {
  FaultResult r = read_faults(yaml::parse_file(path));
  if (!r.ok && r.error.rfind(path, 0) != 0) r.error = path + ": " + r.error;
  return r;
}

}  // namespace springbok::emu
