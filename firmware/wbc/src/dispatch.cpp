// WholeBodyController::tick at the level springbok::isa chose (dispatch.hpp).
#include "dispatch.hpp"

#include "springbok/isa/isa.hpp"

namespace springbok::wbc {
namespace {

constexpr Kernels kBaseline{&WholeBodyController::tick_kernel};

const Kernels& kernels() noexcept {
#ifdef SPRINGBOK_ISA_VARIANTS
  switch (isa::active()) {
    case isa::Level::x86_64_v3: return isa_x86_64_v3::kKernels;
    case isa::Level::x86_64_v4: return isa_x86_64_v4::kKernels;
    case isa::Level::baseline: break;
  }
#endif
  return kBaseline;
}

}  // namespace

const WbcOutput& WholeBodyController::tick(const WbcInput& in, const dyn::Data& data) noexcept {
  return (this->*kernels().tick)(in, data);
}

}  // namespace springbok::wbc
