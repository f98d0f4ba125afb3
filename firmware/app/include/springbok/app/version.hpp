// The firmware's identity, for --version and the start-up log line: the
// project version (CMakeLists.txt) and the source revision it was built from
// (`git describe --always --dirty`, "unknown" outside a git checkout). The
// definitions are generated at build time (firmware/app/cmake/write_version.cmake).
#pragma once

namespace springbok::app {

const char* version() noexcept;
const char* revision() noexcept;

}  // namespace springbok::app
