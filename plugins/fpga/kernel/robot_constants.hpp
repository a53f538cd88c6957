// The kernel's robot constants from a core Model (host side): joint transforms from the parent
// frames and each body's spatial inertia about its origin in its own axes, computed in double and
// rounded once into the kernel's scalar.
#pragma once

#include <Eigen/Core>

#include "gradient_kernel.hpp"
#include "rbdgrad/model.hpp"

namespace rbdgrad::fpga {

/// \return false when the model has more joints than MaxNv.
template <class T, int MaxNv>
bool robot_constants(const Model& model, RobotConstants<T, MaxNv>& out) {
  if (model.nv > MaxNv) return false;
  out.nv = model.nv;
  for (int i = 0; i < model.nv; ++i) {
    const auto k = static_cast<std::size_t>(i);
    out.parent[i] = model.parent[k];
    out.prismatic[i] = model.type[k] == JointType::kPrismatic;
    for (int r = 0; r < 3; ++r) {
      for (int c = 0; c < 3; ++c) out.joint_rotation[i][3 * r + c] = T(model.joint_rotation[k](r, c));
      out.joint_translation[i][r] = T(model.joint_translation[k](r));
    }
    // [[Ic - m cx cx, m cx], [-m cx, m 1]] about the body origin
    const double m = model.mass[k];
    const Eigen::Vector3d c = model.com[k];
    Eigen::Matrix3d cx;
    cx << 0, -c.z(), c.y(), c.z(), 0, -c.x(), -c.y(), c.x(), 0;
    const Eigen::Matrix3d top_left = model.inertia_com[k] - m * cx * cx;
    for (int r = 0; r < 3; ++r)
      for (int col = 0; col < 3; ++col) {
        out.inertia[i][6 * r + col] = T(top_left(r, col));
        out.inertia[i][6 * r + col + 3] = T(m * cx(r, col));
        out.inertia[i][6 * (r + 3) + col] = T(-m * cx(r, col));
        out.inertia[i][6 * (r + 3) + col + 3] = T(r == col ? m : 0.0);
      }
  }
  for (int r = 0; r < 3; ++r) out.gravity[r] = T(model.gravity(r));
  return true;
}

}  // namespace rbdgrad::fpga
