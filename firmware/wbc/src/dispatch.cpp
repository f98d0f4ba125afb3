// WholeBodyController::tick at the level springbok::isa chose (dispatch.hpp).
#include "dispatch.hpp"

namespace springbok::wbc {
namespace {

constexpr Kernels kBaseline{&WholeBodyController::tick_kernel};

const Kernels& kernels() noexcept { return SPRINGBOK_ISA_ACTIVE_TABLE(kBaseline); }

}  // namespace

const WbcOutput& WholeBodyController::tick(const WbcInput& in, const dyn::Data& data) noexcept {
  return (this->*kernels().tick)(in, data);
}

}  // namespace springbok::wbc
