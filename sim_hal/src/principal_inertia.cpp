#include "springbok/sim_hal/principal_inertia.hpp"

#include <Eigen/Eigenvalues>

namespace springbok::sim {

Mat3 inertia_tensor(const model::Inertia& inertia) noexcept {
  const auto& i = inertia.inertia_com_kgm2;  // ixx iyy izz ixy ixz iyz
  Mat3 tensor;
  tensor << i[0], i[3], i[4],  //
      i[3], i[1], i[5],        //
      i[4], i[5], i[2];
  return tensor;
}

PrincipalInertia principal_inertia(const model::Inertia& inertia) noexcept {
  const Eigen::SelfAdjointEigenSolver<Mat3> eigen(inertia_tensor(inertia));
  PrincipalInertia out;
  out.moments_kgm2 = eigen.eigenvalues();
  out.rotation = eigen.eigenvectors();
  if (out.rotation.determinant() < 0.0) out.rotation.col(2) = -out.rotation.col(2);
  out.com_m = Vec3(inertia.com_m[0], inertia.com_m[1], inertia.com_m[2]);
  return out;
}

}  // namespace springbok::sim
