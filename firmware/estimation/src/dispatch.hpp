// The kernel behind BaseEstimator::update, compiled once per instruction-set level
// (springbok/isa/isa.hpp); dispatch.cpp calls active()'s.
#pragma once

#include "springbok/estimation/base_estimator.hpp"
#include "springbok/isa/isa.hpp"

namespace springbok::est {

// One level's kernels; each level's object defines its table (isa/entry.cpp).
struct Kernels {
  decltype(&BaseEstimator::update_kernel) update;
};

SPRINGBOK_ISA_LEVEL_TABLES(Kernels)

}  // namespace springbok::est
