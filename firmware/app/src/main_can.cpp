// springbok: the deployed program on the robot. HAL = the SocketCAN joint
// drives (springbok::can), configured by the `can:` section of the same file.
#include <cstdio>
#include <memory>
#include <string>

#include "springbok/app/runtime.hpp"
#include "springbok/can/can_hardware.hpp"
#include "springbok/can/config_yaml.hpp"

int main(int argc, char** argv) {
  using namespace springbok;
  return app::firmware_main(
      argc, argv, "springbok",
      [](const app::AppConfig&, const std::string& config_path) -> std::unique_ptr<hal::Hardware> {
        can::ConfigResult can_config = can::load_can_config_file(config_path);
        if (!can_config.ok) {
          std::fprintf(stderr, "springbok: config error: %s\n", can_config.error.c_str());
          return nullptr;
        }
        return std::make_unique<can::CanHardware>(std::move(can_config.config));
      });
}
