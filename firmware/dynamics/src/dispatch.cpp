// The public kernels run at the level springbok::isa chose (dispatch.hpp).
#include "dispatch.hpp"

namespace springbok::dyn {
namespace {

constexpr Kernels kBaseline{&kernel::crba, &kernel::rnea, &kernel::aba, &kernel::compute_tick};

const Kernels& kernels() noexcept { return SPRINGBOK_ISA_ACTIVE_TABLE(kBaseline); }

}  // namespace

const MatNv& crba(const Model& model, Data& data, const VecNq& q) noexcept { return kernels().crba(model, data, q); }

const VecNv& rnea(const Model& model, Data& data, const VecNq& q, const VecNv& v, const VecNv& vdot) noexcept {
  return kernels().rnea(model, data, q, v, vdot);
}

const VecNv& aba(const Model& model, Data& data, const VecNq& q, const VecNv& v, const VecNv& tau) noexcept {
  return kernels().aba(model, data, q, v, tau);
}

void compute_tick(const Model& model, Data& data, const VecNq& q, const VecNv& v) noexcept {
  kernels().compute_tick(model, data, q, v);
}

}  // namespace springbok::dyn
