// springbok-on-sim: the deployed program (real-time loop, safety, operator
// socket) with the simulated robot (sim_hal's Bullet world) as its HAL, in
// real time. The SocketCAN build is `springbok`.
#include <memory>
#include <string>

#include "../sim/stepped_bullet_robot.hpp"
#include "springbok/app/runtime.hpp"
#include "springbok/config/reader.hpp"

int main(int argc, char** argv) {
  using namespace springbok;
  return app::firmware_main(argc, argv, "springbok-on-sim", [](app::AppConfig& config, const config::Field&) -> std::unique_ptr<hal::Hardware> {
    return std::make_unique<app::SteppedBulletRobot>(app::crouched_sim_config(config.rate_hz));
  });
}
