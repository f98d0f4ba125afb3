// The `can:` section of the robot configuration, read with springbok::yaml's reader and
// validated; every error names the field and its line (e.g. "can.buses[2].drives[0].id: ... (line 9)").
#pragma once

#include <string>
#include <string_view>

#include "springbok/can/config.hpp"

namespace springbok::yaml {
class Field;
}

namespace springbok::can {

struct ConfigResult {
  bool ok = false;
  CanConfig config;
  std::string error;  // set when !ok
};

// The `can:` section of a document read with yaml::Field (springbok.yaml is read once, by the
// app's config reader): every problem goes to can.errors(), then validate() and the bus loads.
CanConfig read_can_config(const yaml::Field& can);
// A YAML document (text) whose top level has a `can:` key. Never throws.
ConfigResult load_can_config_text(std::string_view yaml_text);
// A file holding such a document. Never throws.
ConfigResult load_can_config_file(const std::string& path);

}  // namespace springbok::can
