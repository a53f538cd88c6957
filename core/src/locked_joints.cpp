#include "rbdgrad/locked_joints.hpp"

#include <cmath>
#include <cstdio>
#include <map>

#include "inertia_sum.hpp"

namespace rbdgrad {
namespace {

// x_to = R * x_from + t
struct Frame {
  Eigen::Matrix3d R = Eigen::Matrix3d::Identity();
  Eigen::Vector3d t = Eigen::Vector3d::Zero();
  Frame then(const Frame& inner) const { return {R * inner.R, R * inner.t + t}; }
};

// body i's frame in its parent body's frame with joint i at q (as the algorithms place it)
Frame body_in_parent(const Model& m, int i, double q) {
  const auto k = static_cast<std::size_t>(i);
  Frame f{m.joint_rotation[k], m.joint_translation[k]};
  if (m.type[k] == JointType::kRevolute) {
    const double s = std::sin(q), c = std::cos(q);
    Eigen::Matrix3d Rz;
    Rz << c, -s, 0, s, c, 0, 0, 0, 1;
    f.R = f.R * Rz;
  } else {
    f.t += q * f.R.col(2);
  }
  return f;
}

std::string number(double x) {
  char text[32];
  std::snprintf(text, sizeof text, "%g", x);
  return text;
}

}  // namespace

Status lock_joints(const Model& model, const std::vector<LockedJoint>& locked, Model& out, std::vector<int>* kept) {
  const int n = model.nv;
  std::map<std::string, int> index;
  for (int i = 0; i < n; ++i) index[model.joints[static_cast<std::size_t>(i)].name] = i;
  std::vector<bool> is_locked(static_cast<std::size_t>(n), false);
  std::vector<double> value(static_cast<std::size_t>(n), 0.0);
  for (const LockedJoint& l : locked) {
    const auto it = index.find(l.name);
    if (it == index.end()) return invalid_argument("locked joint '" + l.name + "': model '" + model.name + "' has no such joint");
    const auto k = static_cast<std::size_t>(it->second);
    if (is_locked[k]) return invalid_argument("locked joint '" + l.name + "' is named twice");
    const JointInfo& j = model.joints[k];
    if (!std::isfinite(l.value)) return invalid_argument("locked joint '" + l.name + "': value is not finite");
    if (j.lower_limit < j.upper_limit && (l.value < j.lower_limit || l.value > j.upper_limit))
      return invalid_argument("locked joint '" + l.name + "': value " + number(l.value) + " is outside its limits [" +
                              number(j.lower_limit) + ", " + number(j.upper_limit) + "]");
    is_locked[k] = true;
    value[k] = l.value;
  }
  if (static_cast<int>(locked.size()) == n)
    return invalid_argument("locking every joint of model '" + model.name + "' leaves nothing to move");

  Model r;
  r.name = model.name;
  r.source = model.source;
  r.gravity = model.gravity;
  std::vector<int> new_index(static_cast<std::size_t>(n), -1);
  // for a locked body: the kept body it is now part of (-1: the world) and its frame in that body
  std::vector<int> anchor(static_cast<std::size_t>(n), -1);
  std::vector<Frame> in_anchor(static_cast<std::size_t>(n));
  std::vector<detail::InertiaSum> bodies;
  std::vector<int> origin;
  for (int i = 0; i < n; ++i) {
    const auto k = static_cast<std::size_t>(i);
    const int p = model.parent[k];
    const bool parent_locked = p >= 0 && is_locked[static_cast<std::size_t>(p)];
    // the kept body (or the world) body i hangs from, and the frame of i's parent body in it
    const int hangs_from = p < 0 ? -1 : parent_locked ? anchor[static_cast<std::size_t>(p)] : new_index[static_cast<std::size_t>(p)];
    const Frame parent_frame = parent_locked ? in_anchor[static_cast<std::size_t>(p)] : Frame{};
    if (is_locked[k]) {
      anchor[k] = hangs_from;
      in_anchor[k] = parent_frame.then(body_in_parent(model, i, value[k]));
      // a body locked to the world moves nothing: it drops out of the dynamics
      if (hangs_from >= 0)
        bodies[static_cast<std::size_t>(hangs_from)].add(model.mass[k], in_anchor[k].R * model.com[k] + in_anchor[k].t,
                                                         in_anchor[k].R * model.inertia_com[k] * in_anchor[k].R.transpose());
      continue;
    }
    new_index[k] = r.nv++;
    origin.push_back(i);
    r.parent.push_back(hangs_from);
    r.type.push_back(model.type[k]);
    // the joint frame placed in the new parent body: the locked bodies' transforms composed in
    const Frame joint = parent_frame.then(Frame{model.joint_rotation[k], model.joint_translation[k]});
    r.joint_rotation.push_back(joint.R);
    r.joint_translation.push_back(joint.t);
    r.link_rotation.push_back(model.link_rotation[k]);
    r.joints.push_back(model.joints[k]);
    bodies.emplace_back();
    bodies.back().add(model.mass[k], model.com[k], model.inertia_com[k]);
  }
  for (const detail::InertiaSum& b : bodies) {
    r.mass.push_back(b.m);
    r.com.push_back(b.com());
    r.inertia_com.push_back(b.inertia_about_com());
  }
  finalize_topology(r);
  if (std::string why = validate_model(r); !why.empty())
    return invalid_argument("model '" + model.name + "' with its locked joints: " + why);
  out = std::move(r);
  if (kept != nullptr) *kept = std::move(origin);
  return Status::ok();
}

}  // namespace rbdgrad
