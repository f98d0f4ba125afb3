#include "springbok/qp/types.hpp"

namespace springbok::qp {

const char* to_string(Status status) noexcept {
  switch (status) {
    case Status::optimal: return "optimal";
    case Status::infeasible: return "infeasible";
    case Status::maxiter: return "maxiter";
    case Status::bad_input: return "bad_input";
    case Status::not_positive_definite: return "not_positive_definite";
    case Status::inaccurate: return "inaccurate";
  }
  return "unknown";
}

}  // namespace springbok::qp
