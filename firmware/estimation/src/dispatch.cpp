// BaseEstimator::update at the level springbok::isa chose (dispatch.hpp).
#include "dispatch.hpp"

namespace springbok::est {
namespace {

constexpr Kernels kBaseline{&BaseEstimator::update_kernel};

const Kernels& kernels() noexcept { return SPRINGBOK_ISA_ACTIVE_TABLE(kBaseline); }

}  // namespace

const BaseEstimate& BaseEstimator::update(const hal::Measurements& m, const Stance& stance, double dt_s) noexcept {
  return (this->*kernels().update)(m, stance, dt_s);
}

}  // namespace springbok::est
