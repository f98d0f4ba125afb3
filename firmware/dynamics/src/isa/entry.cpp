// One level's kernel table (dispatch.hpp), compiled only into that level's object
// (toolchain/springbok_isa.cmake), where kernel:: names that level's own functions.
#include "../dispatch.hpp"

namespace springbok::dyn::SPRINGBOK_ISA_NAMESPACE {

extern const Kernels kKernels;
const Kernels kKernels{&kernel::crba, &kernel::rnea, &kernel::aba, &kernel::compute_tick};

}  // namespace springbok::dyn::SPRINGBOK_ISA_NAMESPACE
