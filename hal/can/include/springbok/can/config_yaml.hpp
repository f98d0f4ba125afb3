// The `can:` section of the robot configuration, read with yaml-cpp and
// validated; every error names the field (e.g. "can.buses[2].drives[0].id: ...").
#pragma once

#include <string>
#include <string_view>

#include "springbok/can/config.hpp"

namespace YAML {
class Node;
}

namespace springbok::can {

struct ConfigResult {
  bool ok = false;
  CanConfig config;
  std::string error;  // set when !ok
};

// `can` is the node of the `can:` section. Never throws.
ConfigResult load_can_config(const YAML::Node& can);
// A YAML document (text) whose top level has a `can:` key. Never throws.
ConfigResult load_can_config_text(std::string_view yaml_text);
// A file holding such a document. Never throws.
ConfigResult load_can_config_file(const std::string& path);

}  // namespace springbok::can
