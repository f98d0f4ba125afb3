// One level's kernel table (dispatch.hpp), compiled only into that level's object
// (toolchain/springbok_isa.cmake), where update_kernel names that level's own function.
#include "../dispatch.hpp"

namespace springbok::est::SPRINGBOK_ISA_NAMESPACE {

extern const Kernels kKernels;
const Kernels kKernels{&BaseEstimator::update_kernel};

}  // namespace springbok::est::SPRINGBOK_ISA_NAMESPACE
