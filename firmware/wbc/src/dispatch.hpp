// The kernel behind WholeBodyController::tick, compiled once per instruction-set level
// (springbok/isa/isa.hpp); dispatch.cpp calls active()'s.
#pragma once

#include "springbok/wbc/whole_body_controller.hpp"

namespace springbok::wbc {

// One level's kernels; each level's object defines its table (isa/entry.cpp).
struct Kernels {
  decltype(&WholeBodyController::tick_kernel) tick;
};

#ifdef SPRINGBOK_ISA_VARIANTS
namespace isa_x86_64_v3 {
extern const Kernels kKernels;
}
namespace isa_x86_64_v4 {
extern const Kernels kKernels;
}
#endif

}  // namespace springbok::wbc
