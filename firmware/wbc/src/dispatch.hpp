// The kernel behind WholeBodyController::tick, compiled once per instruction-set level
// (springbok/isa/isa.hpp); dispatch.cpp calls active()'s.
#pragma once

#include "springbok/isa/isa.hpp"
#include "springbok/wbc/whole_body_controller.hpp"

namespace springbok::wbc {

// One level's kernels; each level's object defines its table (isa/entry.cpp).
struct Kernels {
  decltype(&WholeBodyController::tick_kernel) tick;
};

SPRINGBOK_ISA_LEVEL_TABLES(Kernels)

}  // namespace springbok::wbc
