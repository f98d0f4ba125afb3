// The reference states (test_data.hpp: reference_state_files(), globbed at run time) and
// helpers to compare springbok's results with their blocks.
#pragma once

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "state_file.hpp"
#include "test_data.hpp"

namespace springbok::test {

inline Eigen::MatrixXd to_matrix(const state_file::Block& b) {
  Eigen::MatrixXd m(b.rows, b.cols);
  for (int r = 0; r < b.rows; ++r)
    for (int c = 0; c < b.cols; ++c) m(r, c) = b.values[static_cast<std::size_t>(r * b.cols + c)];
  return m;
}

// FORMAT.md's tolerance rule: absolute for kinematic blocks and M, relative to
// max(1, |reference|) for the generalized forces and accelerations.
inline bool relative_block(const std::string& name) {
  return name == "tau" || name == "h" || name == "g" || name == "vdot_aba";
}

// Largest error of `mine` against `ref` under the block's rule.
inline double block_error(const std::string& name, const Eigen::MatrixXd& mine,
                          const Eigen::MatrixXd& ref) {
  const Eigen::MatrixXd diff = (mine - ref).cwiseAbs();
  if (!relative_block(name)) return diff.maxCoeff();
  return diff.cwiseQuotient(ref.cwiseAbs().cwiseMax(1.0)).maxCoeff();
}

inline constexpr double kReferenceTolerance = 1e-9;

}  // namespace springbok::test
