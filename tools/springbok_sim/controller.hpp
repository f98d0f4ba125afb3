// The controllers a scenario can select (controller.type). Each validates its
// params at construction; a controller may add columns to log.csv and fields
// to summary.json.
#pragma once

#include <cstdint>
#include <string>

#include "springbok/hal/types.hpp"
#include "springbok/sim_hal/bullet_robot.hpp"

namespace springbok::simtool {

class Controller {
 public:
  virtual ~Controller() = default;
  // Tick k in lockstep: reads the robot's measurements and writes its command (the caller
  // steps the physics after). False: the robot's HAL refused the command.
  virtual bool tick(sim::BulletRobot& robot, std::int64_t k) noexcept = 0;
  // Extra log.csv columns, each with its leading comma ("" for none).
  virtual std::string csv_columns() const { return ""; }
  // Called once per tick after the physics step: appends this tick's extra columns.
  virtual void after_step(const sim::GroundTruth& /*truth*/, std::string& /*row*/) {}
  // Extra summary.json members, each line "  \"key\": value,\n".
  virtual std::string summary_fields() const { return ""; }
};

}  // namespace springbok::simtool
