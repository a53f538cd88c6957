#include "rbdgrad/model.hpp"

#include <Eigen/Eigenvalues>
#include <cmath>
#include <sstream>

namespace rbdgrad {

const char* joint_type_name(JointType t) noexcept {
  switch (t) {
    case JointType::kRevolute: return "revolute";
    case JointType::kPrismatic: return "prismatic";
  }
  return "unknown";
}

void finalize_topology(Model& model) {
  const int n = model.nv;
  model.subtree_end.assign(n, 0);
  model.depth.assign(n, 1);
  for (int i = 0; i < n; ++i) {
    model.subtree_end[i] = i + 1;
    if (model.parent[i] >= 0) model.depth[i] = model.depth[model.parent[i]] + 1;
  }
  // children come after their parent: extend every ancestor's range backwards
  for (int i = n - 1; i >= 0; --i) {
    const int p = model.parent[i];
    if (p >= 0 && model.subtree_end[i] > model.subtree_end[p]) model.subtree_end[p] = model.subtree_end[i];
  }
}

std::string validate_model(const Model& m) {
  const auto n = static_cast<size_t>(m.nv);
  if (m.nv < 1) return "model has no moving joint";
  if (m.parent.size() != n || m.type.size() != n || m.joint_rotation.size() != n ||
      m.joint_translation.size() != n || m.mass.size() != n || m.com.size() != n ||
      m.inertia_com.size() != n || m.link_rotation.size() != n || m.joints.size() != n ||
      m.subtree_end.size() != n || m.depth.size() != n)
    return "model arrays do not all have nv entries";
  if (!m.gravity.allFinite()) return "gravity is not finite";
  for (int i = 0; i < m.nv; ++i) {
    const std::string who = "joint " + std::to_string(i) + " '" + m.joints[i].name + "'";
    if (m.parent[i] < -1 || m.parent[i] >= i) return who + ": parent index must be in [-1, " + std::to_string(i) + ")";
    // depth-first numbering: a subtree is a contiguous range
    if (m.parent[i] >= 0 && i >= m.subtree_end[m.parent[i]]) return who + ": joints are not in depth-first order";
    const Eigen::Matrix3d& R = m.joint_rotation[i];
    if (!R.allFinite() || !m.joint_translation[i].allFinite() ||
        (R.transpose() * R - Eigen::Matrix3d::Identity()).norm() > 1e-9 || R.determinant() < 0)
      return who + ": joint placement is not a finite proper rotation and translation";
    const std::string body = "body of " + who + " (link '" + m.joints[i].child_link + "')";
    if (!std::isfinite(m.mass[i]) || m.mass[i] < 0) return body + ": mass must be finite and non-negative";
    if (!m.com[i].allFinite() || !m.inertia_com[i].allFinite()) return body + ": inertia is not finite";
    const Eigen::Matrix3d& I = m.inertia_com[i];
    if ((I - I.transpose()).norm() > 1e-12 * (1 + I.norm())) return body + ": inertia tensor is not symmetric";
    const Eigen::Vector3d ev = Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(I, Eigen::EigenvaluesOnly).eigenvalues();
    const double tol = 1e-12 * (1 + ev.cwiseAbs().maxCoeff());
    if (ev.minCoeff() < -tol) return body + ": inertia tensor is not positive semi-definite";
    // (the triangle inequality of principal moments is not required: published models such as
    // Talos and HyQ violate it slightly, and M stays positive definite without it)
  }
  return "";
}

std::string model_summary(const Model& m) {
  std::ostringstream s;
  double total_mass = 0;
  for (double x : m.mass) total_mass += x;
  s << "model '" << m.name << "' (" << m.source << "): " << m.nv << " moving joints, " << m.nv + 1
    << " bodies incl. the fixed root, max depth " << m.max_depth() << ", moving mass " << total_mass
    << " kg, gravity [" << m.gravity.transpose() << "]\n";
  s << "  parents: [";
  for (int i = 0; i < m.nv; ++i) s << (i ? ", " : "") << m.parent[i];
  s << "]\n";
  for (int i = 0; i < m.nv; ++i) {
    const JointInfo& j = m.joints[i];
    s << "  " << i << " " << j.name << " (" << j.urdf_type << ") " << j.parent_link << " -> " << j.child_link;
    if (j.lower_limit != 0 || j.upper_limit != 0) s << " [" << j.lower_limit << ", " << j.upper_limit << "]";
    s << "\n";
  }
  return s.str();
}

}  // namespace rbdgrad
