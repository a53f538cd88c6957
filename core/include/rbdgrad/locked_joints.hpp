// Joints held at fixed positions (a scene's locked hands, head or fingers, issue 8): the model is
// reduced so that every algorithm and backend works on the smaller tree. Each locked joint's body
// is folded into the body it hangs from (its mass, centre of mass and inertia re-expressed there
// at the locked position), its children hang from that body with the locked joint's transform
// composed into their placement, and a body locked to the world moves nothing and drops out.
// The reduced model's M, bias forces and their derivatives are the full model's rows and columns
// of the kept joints with the locked joints at their values and at rest (q̇ = q̈ = 0 there).
#pragma once

#include <string>
#include <vector>

#include "rbdgrad/model.hpp"
#include "rbdgrad/status.hpp"

namespace rbdgrad {

struct LockedJoint {
  std::string name;  // a joint of the model (JointInfo::name)
  double value = 0;  // rad, or m for a prismatic joint
};

/// `model` with the joints of `locked` held at their values, into `out` (its name and source
/// are the model's). `kept` (may be null) receives, for each joint of `out`, its index in `model`.
/// Errors (invalid_argument, naming the joint): a name the model does not have, a joint named
/// twice, a value that is not finite or is outside the joint's limits (where it has limits), and
/// locking every joint.
Status lock_joints(const Model& model, const std::vector<LockedJoint>& locked, Model& out,
                   std::vector<int>* kept = nullptr);

}  // namespace rbdgrad
