// The kernels behind crba, rnea, aba and compute_tick (dynamics.hpp), compiled once per
// instruction-set level (springbok/isa/isa.hpp); dispatch.cpp calls active()'s.
#pragma once

#include "springbok/dynamics/dynamics.hpp"
#include "springbok/isa/isa.hpp"

namespace springbok::dyn {

namespace kernel {
const MatNv& crba(const Model& model, Data& data, const VecNq& q) noexcept;
const VecNv& rnea(const Model& model, Data& data, const VecNq& q, const VecNv& v, const VecNv& vdot) noexcept;
const VecNv& aba(const Model& model, Data& data, const VecNq& q, const VecNv& v, const VecNv& tau) noexcept;
void compute_tick(const Model& model, Data& data, const VecNq& q, const VecNv& v) noexcept;
}  // namespace kernel

// One level's kernels; each level's object defines its table (isa/entry.cpp).
struct Kernels {
  decltype(&kernel::crba) crba;
  decltype(&kernel::rnea) rnea;
  decltype(&kernel::aba) aba;
  decltype(&kernel::compute_tick) compute_tick;
};

SPRINGBOK_ISA_LEVEL_TABLES(Kernels)

}  // namespace springbok::dyn
