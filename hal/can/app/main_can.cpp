// springbok: the deployed program on the robot. HAL = the SocketCAN joint
// drives (springbok::can), configured by the `can:` section of the same file.
// The firmware's gains are checked against what the drives can render
// before anything starts (also with --check-config).
#include <cstdio>
#include <memory>
#include <string>

#include "springbok/app/drive_gains.hpp"
#include "springbok/app/runtime.hpp"
#include "springbok/can/can_hardware.hpp"
#include "springbok/can/config_yaml.hpp"
#include "springbok/yaml/reader.hpp"

namespace {

springbok::app::DriveGainRanges gain_ranges(const springbok::can::CanConfig& can) {
  springbok::app::DriveGainRanges r;
  for (const springbok::can::BusConfig& bus : can.buses) {
    for (const springbok::can::DriveConfig& d : bus.drives) {
      if (d.protocol != springbok::can::Protocol::mit || d.joint < 0 || d.joint >= springbok::kNj) continue;
      const auto j = static_cast<std::size_t>(d.joint);
      r.in_drive[j] = true;
      r.kp_min[d.joint] = d.mit_ranges.kp_min;
      r.kp_max[d.joint] = d.mit_ranges.kp_max;
      r.kd_min[d.joint] = d.mit_ranges.kd_min;
      r.kd_max[d.joint] = d.mit_ranges.kd_max;
      r.drive[j] = "MIT drive (id " + std::to_string(d.drive_id) + " on bus " + bus.name + ")";
    }
  }
  r.backend_kd.emplace_back("can.timing.damping_kd_nms_per_rad", can.timing.damping_kd_nms_per_rad);
  return r;
}

}  // namespace

int main(int argc, char** argv) {
  using namespace springbok;
  return app::firmware_main(
      argc, argv, "springbok",
      [](app::AppConfig& config, const yaml::Field& root) -> std::unique_ptr<hal::Hardware> {
        // The `can:` section's problems are reported with the app's; the gains are checked
        // against the drives only when both parts are good.
        can::CanConfig can_config = can::read_can_config(root["can"]);
        const std::size_t errors_before = root.errors().size();
        if (errors_before != 0) return nullptr;
        for (std::string& e : app::check_drive_gains(config, gain_ranges(can_config))) root.errors().add_line(std::move(e));
        if (root.errors().size() != errors_before) return nullptr;
        config.control.tare_samples = can_config.sensors.wrist_ft.tare_samples;
        return std::make_unique<can::CanHardware>(std::move(can_config));
      });
}
