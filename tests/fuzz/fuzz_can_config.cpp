// libFuzzer: arbitrary text into the CAN config loader and the emulator's fault-script
// loader. Either loads (and then validates and passes the bus-load check cleanly) or
// returns an error; never crashes, never throws.
#include <cstddef>
#include <cstdint>
#include <string>

#include "springbok/can/bus_load.hpp"
#include "springbok/can/config_yaml.hpp"
#include "springbok/drive_emulator/drives.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  const springbok::can::ConfigResult r = springbok::can::load_can_config_text(text);
  if (r.ok) {
    if (!springbok::can::validate(r.config).empty()) __builtin_trap();  // loaded means valid
    (void)springbok::can::check_bus_loads(r.config);
  } else if (r.error.empty()) {
    __builtin_trap();  // a failure always says why
  }
  (void)springbok::emu::load_faults_text(text);
  return 0;
}
