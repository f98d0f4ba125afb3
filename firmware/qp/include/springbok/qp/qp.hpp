// springbok::qp: the dense Goldfarb-Idnani QP solver (see solver.hpp).
#pragma once

#include "springbok/qp/solver.hpp"
#include "springbok/qp/types.hpp"
