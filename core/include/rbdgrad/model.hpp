// The robot model: constants only, immutable after loading, shared by every worker.
//
// Internal conventions (what the algorithms see):
// - moving joints are numbered 0..nv-1 in depth-first order (Pinocchio's order: the children of a link
//   in the order urdfdom lists them); parent[i] < i, -1 for the fixed root (the world);
// - every joint moves along the z axis of its own joint frame: at load time each body frame is turned so
//   that the URDF axis becomes +z ("motion subspace as an axis index"); link_rotation[i] maps back;
// - links joined by fixed joints are merged into the moving body they hang from, inertias combined;
// - the subtree of joint i is the index range [i, subtree_end[i]) (a property of depth-first order).
#pragma once

#include <Eigen/Core>
#include <string>
#include <vector>

namespace rbdgrad {

enum class JointType : unsigned char {
  kRevolute,   // rotation about joint z (URDF revolute and continuous)
  kPrismatic,  // translation along joint z
};

const char* joint_type_name(JointType t) noexcept;

// Description of a joint for people and clients; never read by the algorithms.
struct JointInfo {
  std::string name;
  std::string urdf_type;        // "revolute", "continuous" or "prismatic"
  std::string child_link;       // URDF link moved by this joint (fixed children merged into it)
  std::string parent_link;
  double lower_limit = 0, upper_limit = 0;   // rad or m; both 0 when the URDF gives none (continuous)
  double effort_limit = 0, velocity_limit = 0;
};

template <class S>
struct ModelTpl {
  using Scalar = S;
  using Vec3 = Eigen::Matrix<S, 3, 1>;
  using Mat3 = Eigen::Matrix<S, 3, 3>;

  std::string name;                     // robot name from the URDF
  std::string source;                   // file path or "<embedded>"
  int nv = 0;                           // number of moving joints = bodies without the world
  std::vector<int> parent;              // (nv) parent joint, -1 for the world
  std::vector<int> subtree_end;         // (nv) one past the last joint of joint i's subtree
  std::vector<int> depth;               // (nv) number of joints from the root to i, root joints have 1
  std::vector<JointType> type;          // (nv)

  // joint frame i in its parent body frame (before the joint moves): x_parent = rotation * x + translation
  std::vector<Mat3> joint_rotation;     // (nv)
  std::vector<Vec3> joint_translation;  // (nv)

  // body i inertia in body frame i (fixed-joint children merged in)
  std::vector<S> mass;                  // (nv) kg
  std::vector<Vec3> com;                // (nv) centre of mass, m
  std::vector<Mat3> inertia_com;        // (nv) rotational inertia about the centre of mass, kg m^2

  // URDF child link frame in internal body frame i: x_body = link_rotation * x_link (pure rotation)
  std::vector<Mat3> link_rotation;      // (nv)

  Vec3 gravity = Vec3(S(0), S(0), S(-9.81));  // world frame, m/s^2
  std::vector<JointInfo> joints;        // (nv) names and limits

  int max_depth() const;
  // Same model in another scalar type (double -> float or fixed point); constants are rounded once.
  template <class T>
  ModelTpl<T> cast() const;
};

using Model = ModelTpl<double>;

// Human-readable summary for logs and the CLI: name, joints, bodies, parent array, joint names and types.
std::string model_summary(const Model& model);

// Checks the internal consistency of a model built by hand or by a loader: sizes, parent order,
// subtree ranges, finite constants, physically valid inertias. Returns "" when valid, else the problem.
std::string validate_model(const Model& model);

// Recomputes subtree_end and depth from parent (for models built by hand, e.g. random test trees).
void finalize_topology(Model& model);

template <class S>
int ModelTpl<S>::max_depth() const {
  int d = 0;
  for (int x : depth) d = x > d ? x : d;
  return d;
}

template <class S>
template <class T>
ModelTpl<T> ModelTpl<S>::cast() const {
  ModelTpl<T> out;
  out.name = name;
  out.source = source;
  out.nv = nv;
  out.parent = parent;
  out.subtree_end = subtree_end;
  out.depth = depth;
  out.type = type;
  out.joints = joints;
  out.gravity = gravity.template cast<T>();
  for (int i = 0; i < nv; ++i) {
    out.joint_rotation.push_back(joint_rotation[i].template cast<T>());
    out.joint_translation.push_back(joint_translation[i].template cast<T>());
    out.mass.push_back(static_cast<T>(mass[i]));
    out.com.push_back(com[i].template cast<T>());
    out.inertia_com.push_back(inertia_com[i].template cast<T>());
    out.link_rotation.push_back(link_rotation[i].template cast<T>());
  }
  return out;
}

}  // namespace rbdgrad
