// springbok-on-sim: the deployed program (real-time loop, safety, operator
// socket) with the simulated robot (sim_hal's Bullet world) as its HAL, in
// real time. The SocketCAN build is `springbok`.
#include <memory>
#include <string>

#include "springbok/app/runtime.hpp"
#include "springbok/yaml/reader.hpp"
#include "springbok/sim_hal/stepped_bullet_robot.hpp"

int main(int argc, char** argv) {
  using namespace springbok;
  return app::firmware_main(argc, argv, "springbok-on-sim", [](app::AppConfig& config, const yaml::Field&) -> std::unique_ptr<hal::Hardware> {
    return std::make_unique<sim::SteppedBulletRobot>(sim::crouched_sim_config(config.rate_hz));
  });
}
