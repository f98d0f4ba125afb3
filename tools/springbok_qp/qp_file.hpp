// Reading QP instance files (tests/data/qp/FORMAT.md, version 1) and writing/reading
// the springbok-qp solution files. Tooling only (allocates, throws inside,
// reports errors as values); never on the tick path.
#pragma once

#include <array>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "springbok/qp/types.hpp"

namespace springbok::qpfile {

struct Instance {
  std::string name, family, expect;
  int n = 0, meq = 0, mi = 0;
  std::vector<double> H, g, Aeq, beq, Ain, lb, ub;  // matrices row-major as in the file
  // Reference solution (only when expect == "optimal").
  std::vector<double> xstar, lambda_eq, lambda_in;
  double obj = 0.0;
  std::vector<std::pair<int, char>> active;  // row, side L/U/E
  std::array<double, 4> kkt{};
};

// Parses one instance file. On failure returns nullopt and sets `error` to
// "<path>:<line>: <what> (token '<token>')".
std::optional<Instance> read_instance(const std::string& path, std::string& error);
// Same, from text already in memory (`origin` names it in errors).
std::optional<Instance> parse_instance(const std::string& text, const std::string& origin, std::string& error);

// Copies an instance into a fixed-size problem; false when it does not fit.
template <int N, int ME, int MI>
bool load_problem(const Instance& in, qp::Problem<N, ME, MI>& out) {
  if (in.n < 1 || in.n > N || in.meq > ME || in.mi > MI) return false;
  out.resize(in.n, in.meq, in.mi);
  const auto n = static_cast<std::size_t>(in.n);
  for (std::size_t i = 0; i < n; ++i) {
    for (std::size_t j = 0; j < n; ++j) out.hessian[j * N + i] = in.H[i * n + j];
    out.gradient[i] = in.g[i];
  }
  for (std::size_t r = 0; r < static_cast<std::size_t>(in.meq); ++r) {
    for (std::size_t j = 0; j < n; ++j) out.aeq[j * ME + r] = in.Aeq[r * n + j];
    out.beq_values[r] = in.beq[r];
  }
  for (std::size_t r = 0; r < static_cast<std::size_t>(in.mi); ++r) {
    for (std::size_t j = 0; j < n; ++j) out.ain[j * MI + r] = in.Ain[r * n + j];
    out.lower[r] = in.lb[r];
    out.upper[r] = in.ub[r];
  }
  return true;
}

// The status word of the command line: optimal infeasible error maxiter.
const char* status_word(qp::Status status);

struct Solution {
  std::string name, status;
  std::vector<double> x, lambda_eq, lambda_in;  // empty unless optimal
};

// Writes DIR/<name>.sol (numbers %.17g); false on an I/O error.
bool write_solution(const std::string& dir, const Solution& solution);
// Reads a solution file; nullopt (and error) when malformed.
std::optional<Solution> read_solution(const std::string& path, int n, int meq, int mi, std::string& error);

}  // namespace springbok::qpfile
