// One level's kernel table (dispatch.hpp), compiled only into that level's object
// (toolchain/springbok_isa.cmake), where tick_kernel names that level's own function.
#include "../dispatch.hpp"

namespace springbok::wbc::SPRINGBOK_ISA_NAMESPACE {

extern const Kernels kKernels;
const Kernels kKernels{&WholeBodyController::tick_kernel};

}  // namespace springbok::wbc::SPRINGBOK_ISA_NAMESPACE
