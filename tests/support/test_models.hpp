// Models for tests: the embedded robots and seeded random kinematic trees.
#pragma once

#include <Eigen/Geometry>
#include <random>
#include <string>

#include "rbdgrad/embedded_robots.hpp"
#include "rbdgrad/locked_joints.hpp"
#include "rbdgrad/model.hpp"
#include "rbdgrad/urdf.hpp"

namespace rbdgrad::testing {

inline Model load_embedded(const std::string& name) {
  Model model;
  Status s = load_urdf_string(std::string(embedded_robot_urdf(name)), name + ".urdf", model);
  if (!s) throw std::runtime_error(s.to_string());
  return model;
}

// talos_reduced's hands (each gripper and the wrist: arm joints 5-7) and head, locked at the middle
// of their limits
inline std::vector<LockedJoint> talos_hands_and_head(const Model& talos) {
  std::vector<LockedJoint> locked;
  for (const JointInfo& j : talos.joints) {
    const std::string& n = j.name;
    const bool wrist =
        n.starts_with("arm") && (n.ends_with("_5_joint") || n.ends_with("_6_joint") || n.ends_with("_7_joint"));
    if (n.starts_with("head") || n.starts_with("gripper") || wrist)
      locked.push_back({n, 0.5 * (j.lower_limit + j.upper_limit)});
  }
  return locked;
}

inline Eigen::Matrix3d random_rotation(std::mt19937& rng) {
  std::normal_distribution<double> g;
  Eigen::Quaterniond q(g(rng), g(rng), g(rng), g(rng));
  return q.normalized().toRotationMatrix();
}

// kWide: a root with (n - 1) / 2 branches of two joints, so that two levels of the tree are wide.
enum class TreeShape { kChain, kBranching, kWide };

// A random tree of n moving joints in depth-first order: random joint placements and axes (the
// joint frame's z), revolute or prismatic, masses 0.2-5 kg and valid random inertias.
inline Model random_model(unsigned seed, int n, TreeShape shape, bool with_prismatic = true) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-1, 1), pos(0.1, 1);
  Model m;
  m.name = std::string("random_").append(std::to_string(seed));
  m.source = "<random>";
  m.nv = n;
  std::vector<int> path;  // ancestors-or-self of the last joint: choosing among them keeps DFS order
  for (int i = 0; i < n; ++i) {
    int parent = -1;
    if (shape == TreeShape::kChain) {
      parent = i - 1;
    } else if (shape == TreeShape::kWide) {
      parent = i == 0 ? -1 : (i % 2 == 1 ? 0 : i - 1);
    } else if (!path.empty()) {
      std::uniform_int_distribution<int> pick(-1, static_cast<int>(path.size()) - 1);
      const int k = pick(rng);
      parent = k < 0 ? -1 : path[static_cast<size_t>(k)];
    }
    while (!path.empty() && path.back() != parent) path.pop_back();
    path.push_back(i);
    m.parent.push_back(parent);
    m.type.push_back(with_prismatic && pos(rng) < 0.3 ? JointType::kPrismatic : JointType::kRevolute);
    m.joint_rotation.push_back(random_rotation(rng));
    m.joint_translation.emplace_back(0.3 * u(rng), 0.3 * u(rng), 0.3 * u(rng));
    m.mass.push_back(0.2 + 4.8 * (0.5 + 0.5 * u(rng)));
    m.com.emplace_back(0.2 * u(rng), 0.2 * u(rng), 0.2 * u(rng));
    // principal moments that satisfy the triangle inequality
    const Eigen::Vector3d pm(pos(rng), pos(rng), pos(rng));
    Eigen::Vector3d moments(pm.y() + pm.z(), pm.x() + pm.z(), pm.x() + pm.y());
    moments *= 0.05 * m.mass.back();
    const Eigen::Matrix3d R = random_rotation(rng);
    m.inertia_com.push_back(R * moments.asDiagonal() * R.transpose());
    m.link_rotation.push_back(Eigen::Matrix3d::Identity());
    JointInfo info;
    info.name = std::string("j").append(std::to_string(i));
    info.urdf_type = m.type.back() == JointType::kPrismatic ? "prismatic" : "revolute";
    info.child_link = std::string("l").append(std::to_string(i));
    info.parent_link = parent < 0 ? std::string("base") : std::string("l").append(std::to_string(parent));
    m.joints.push_back(info);
  }
  finalize_topology(m);
  return m;
}

inline Eigen::VectorXd random_vector(std::mt19937& rng, int n, double scale) {
  std::uniform_real_distribution<double> u(-scale, scale);
  Eigen::VectorXd x(n);
  for (int i = 0; i < n; ++i) x(i) = u(rng);
  return x;
}

inline double relative_error(const Eigen::MatrixXd& x, const Eigen::MatrixXd& ref) {
  const double denom = ref.norm();
  return denom > 0 ? (x - ref).norm() / denom : (x - ref).norm();
}

}  // namespace rbdgrad::testing
