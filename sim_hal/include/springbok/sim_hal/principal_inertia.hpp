// A URDF-style inertia (tensor about the COM, in the body frame) seen from
// its principal frame: Bullet's multibody links live in a frame at the COM
// whose axes are the principal axes, with a diagonal inertia.
#pragma once

#include "springbok/model/model.hpp"

namespace springbok::sim {

struct PrincipalInertia {
  Vec3 moments_kgm2 = Vec3::Zero();        // diagonal inertia in the principal frame
  Mat3 rotation = Mat3::Identity();        // principal frame -> body frame (det +1)
  Vec3 com_m = Vec3::Zero();               // principal frame origin in the body frame
};

// The symmetric inertia tensor [ixx ixy ixz; ...] of a model inertia.
Mat3 inertia_tensor(const model::Inertia& inertia) noexcept;

// I = R diag(moments) R^T with R a proper rotation (columns = principal axes).
PrincipalInertia principal_inertia(const model::Inertia& inertia) noexcept;

}  // namespace springbok::sim
