// URDF -> Model. Walks the link tree depth-first from the root in urdfdom's child order (the order
// Pinocchio uses), merges links held by fixed joints into the moving body above them and turns each
// body frame so that its joint axis is +z.
#include "rbdgrad/urdf.hpp"

#include <console_bridge/console.h>
#include <urdf_parser/urdf_parser.h>

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>
#include <cmath>
#include <fstream>
#include <map>
#include <mutex>
#include <sstream>

#include "inertia_sum.hpp"

namespace rbdgrad {
namespace {

// urdfdom reports parse errors through console_bridge: collect them for our message.
class CaptureConsole : public console_bridge::OutputHandler {
 public:
  void log(const std::string& text, console_bridge::LogLevel level, const char*, int) override {
    if (level >= console_bridge::CONSOLE_BRIDGE_LOG_WARN) messages += (messages.empty() ? "" : "; ") + text;
  }
  std::string messages;
};

struct Placement {
  Eigen::Matrix3d R = Eigen::Matrix3d::Identity();
  Eigen::Vector3d p = Eigen::Vector3d::Zero();
  Placement operator*(const Placement& o) const { return {R * o.R, R * o.p + p}; }
};

Placement to_placement(const urdf::Pose& pose) {
  Placement out;
  const urdf::Rotation& q = pose.rotation;
  out.R = Eigen::Quaterniond(q.w, q.x, q.y, q.z).normalized().toRotationMatrix();
  out.p = Eigen::Vector3d(pose.position.x, pose.position.y, pose.position.z);
  return out;
}

// A proper rotation whose third column is the unit axis a. Built from the coordinate axis least
// aligned with a, so an axis along a coordinate axis gives an exact signed permutation matrix.
Eigen::Matrix3d frame_with_z_along(const Eigen::Vector3d& a) {
  int m = 0;
  a.cwiseAbs().minCoeff(&m);
  Eigen::Vector3d b1 = Eigen::Vector3d::Unit(m) - a(m) * a;
  b1.normalize();
  Eigen::Matrix3d A;
  A.col(0) = b1;
  A.col(1) = a.cross(b1);
  A.col(2) = a;
  return A;
}

using detail::InertiaSum;

class TreeBuilder {
 public:
  TreeBuilder(const std::string& file, Model& model) : file_(file), model_(model) {}

  Status build(const urdf::ModelInterface& urdf) {
    urdf::LinkConstSharedPtr root = urdf.getRoot();
    if (!root) return invalid_argument(file_ + ": URDF has no root link");
    if (Status s = check_tree(urdf, root->name); !s) return s;
    Status s = visit_link(root, /*body=*/-1, Placement{});
    if (!s) return s;
    if (model_.nv == 0) return invalid_argument(file_ + ": URDF has no moving joint");
    // moving bodies: turn accumulated inertias into (mass, com, inertia about com)
    for (int i = 0; i < model_.nv; ++i) {
      const InertiaSum& b = bodies_[i];
      const std::string& link = model_.joints[i].child_link;
      if (!has_inertial_[i] && b.m == 0)
        return invalid_argument(file_ + ": link '" + link + "' (moved by joint '" + model_.joints[i].name +
                                "') has no <inertial> and nothing with mass is fixed to it");
      model_.mass[i] = b.m;
      model_.com[i] = b.com();
      model_.inertia_com[i] = b.inertia_about_com();
    }
    finalize_topology(model_);
    if (std::string why = validate_model(model_); !why.empty()) return invalid_argument(file_ + ": " + why);
    return check_axis_inertia();
  }

 private:
  // Every link must have one parent and be reachable from the root: anything else is a closed loop
  // or a second tree, which urdfdom itself accepts silently.
  Status check_tree(const urdf::ModelInterface& urdf, const std::string& root) {
    std::map<std::string, std::string> parent_joint;
    for (const auto& [name, joint] : urdf.joints_) {
      auto [it, inserted] = parent_joint.emplace(joint->child_link_name, name);
      if (!inserted)
        return invalid_argument(file_ + ": closed kinematic loop: link '" + joint->child_link_name +
                                "' is the child of joints '" + it->second + "' and '" + name + "'");
    }
    for (const auto& [name, link] : urdf.links_) {
      std::string at = name;
      for (size_t steps = 0; at != root; ++steps) {
        auto pj = parent_joint.find(at);
        if (pj == parent_joint.end() || steps > urdf.links_.size())
          return invalid_argument(file_ + ": link '" + name + "' is not connected to the root link '" + root +
                                  "' (closed loop or separate tree)");
        at = urdf.joints_.at(pj->second)->parent_link_name;
      }
    }
    return Status::ok();
  }

  // link_in_body: placement of `link`'s frame in the internal frame of `body` (-1: the world)
  Status visit_link(const urdf::LinkConstSharedPtr& link, int body, const Placement& link_in_body) {
    if (link->inertial && body >= 0) {
      const urdf::Inertial& in = *link->inertial;
      const Placement com_frame = link_in_body * to_placement(in.origin);
      Eigen::Matrix3d Ic;
      Ic << in.ixx, in.ixy, in.ixz, in.ixy, in.iyy, in.iyz, in.ixz, in.iyz, in.izz;
      if (!std::isfinite(in.mass) || in.mass < 0 || !Ic.allFinite())
        return invalid_argument(file_ + ": link '" + link->name + "': mass and inertia must be finite, mass >= 0");
      if (Status s = check_link_inertia(link->name, Ic); !s) return s;
      bodies_[body].add(in.mass, com_frame.p, com_frame.R * Ic * com_frame.R.transpose());
      has_inertial_[body] = true;
    }
    for (const urdf::JointSharedPtr& joint : link->child_joints) {
      urdf::LinkConstSharedPtr child;
      for (const auto& c : link->child_links)
        if (c->name == joint->child_link_name) child = c;
      if (!child) return invalid_argument(file_ + ": joint '" + joint->name + "' has no child link");
      const Placement origin = link_in_body * to_placement(joint->parent_to_joint_origin_transform);
      Status s;
      switch (joint->type) {
        case urdf::Joint::FIXED:
          s = visit_link(child, body, origin);
          break;
        case urdf::Joint::REVOLUTE:
        case urdf::Joint::CONTINUOUS:
        case urdf::Joint::PRISMATIC:
          s = add_moving_joint(*joint, *link, child, body, origin);
          break;
        case urdf::Joint::FLOATING:
          return unimplemented(file_ + ": joint '" + joint->name + "': floating joints are not supported yet");
        case urdf::Joint::PLANAR:
          return unimplemented(file_ + ": joint '" + joint->name + "': planar joints are not supported yet");
        default:
          return unimplemented(file_ + ": joint '" + joint->name + "': unknown joint type");
      }
      if (!s) return s;
    }
    return Status::ok();
  }

  Status add_moving_joint(const urdf::Joint& joint, const urdf::Link& parent_link,
                          const urdf::LinkConstSharedPtr& child, int parent_body, const Placement& origin) {
    Eigen::Vector3d axis(joint.axis.x, joint.axis.y, joint.axis.z);
    if (!axis.allFinite() || axis.norm() < 1e-12)
      return invalid_argument(file_ + ": joint '" + joint.name + "': axis must be a finite non-zero vector");
    axis.normalize();
    const Eigen::Matrix3d A = frame_with_z_along(axis);  // x_link = A x_body

    const int i = model_.nv++;
    model_.parent.push_back(parent_body);
    model_.type.push_back(joint.type == urdf::Joint::PRISMATIC ? JointType::kPrismatic : JointType::kRevolute);
    model_.joint_rotation.push_back(origin.R * A);
    model_.joint_translation.push_back(origin.p);
    model_.link_rotation.push_back(A.transpose());
    model_.mass.push_back(0);
    model_.com.emplace_back(Eigen::Vector3d::Zero());
    model_.inertia_com.emplace_back(Eigen::Matrix3d::Zero());
    bodies_.emplace_back();
    has_inertial_.push_back(false);

    JointInfo info;
    info.name = joint.name;
    info.urdf_type = joint.type == urdf::Joint::PRISMATIC ? "prismatic"
                     : joint.type == urdf::Joint::CONTINUOUS ? "continuous" : "revolute";
    info.child_link = child->name;
    info.parent_link = parent_link.name;
    if (joint.limits) {
      if (joint.type != urdf::Joint::CONTINUOUS) {
        info.lower_limit = joint.limits->lower;
        info.upper_limit = joint.limits->upper;
      }
      info.effort_limit = joint.limits->effort;
      info.velocity_limit = joint.limits->velocity;
    }
    model_.joints.push_back(info);

    Placement link_in_body;
    link_in_body.R = A.transpose();
    return visit_link(child, i, link_in_body);
  }

  Status check_link_inertia(const std::string& link, const Eigen::Matrix3d& I) {
    const Eigen::Vector3d ev = Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(I, Eigen::EigenvaluesOnly).eigenvalues();
    const double tol = 1e-12 * (1 + ev.cwiseAbs().maxCoeff());
    if (ev.minCoeff() < -tol)
      return invalid_argument(file_ + ": link '" + link + "': inertia tensor is not positive semi-definite");
    return Status::ok();
  }

  // M is singular when a joint moves nothing with inertia along its axis. Checked at q = 0 on the
  // composite inertia of the joint's subtree, expressed in the joint frame.
  Status check_axis_inertia() {
    const int n = model_.nv;
    std::vector<InertiaSum> composite(n);
    for (int i = 0; i < n; ++i) composite[i].add(model_.mass[i], model_.com[i], model_.inertia_com[i]);
    for (int i = n - 1; i >= 0; --i) {
      const double inertia_about_axis = model_.type[i] == JointType::kRevolute ? composite[i].I_origin(2, 2)
                                                                               : composite[i].m;
      const double scale = 1e-12 * (1 + composite[i].m);
      if (!(inertia_about_axis > scale))
        return invalid_argument(file_ + ": joint '" + model_.joints[i].name + "' moves no " +
                                (model_.type[i] == JointType::kRevolute ? "rotational inertia about its axis"
                                                                         : "mass along its axis") +
                                " (link '" + model_.joints[i].child_link + "' and its children): M would be singular");
      const int p = model_.parent[i];
      if (p < 0) continue;
      // express the subtree's inertia in the parent body frame at q = 0
      const Eigen::Matrix3d& R = model_.joint_rotation[i];
      const Eigen::Vector3d& t = model_.joint_translation[i];
      const InertiaSum& c = composite[i];
      if (c.m > 0) composite[p].add(c.m, R * c.com() + t, R * c.inertia_about_com() * R.transpose());
    }
    return Status::ok();
  }

  const std::string& file_;
  Model& model_;
  std::vector<InertiaSum> bodies_;
  std::vector<bool> has_inertial_;
};

Status build_model(const urdf::ModelInterfaceSharedPtr& urdf, const std::string& file, Model& model,
                   const UrdfOptions& options) {
  Model m;
  m.name = urdf->getName();
  m.source = file;
  if (options.gravity) {
    if (!options.gravity->allFinite()) return invalid_argument("gravity must be finite");
    m.gravity = *options.gravity;
  }
  TreeBuilder builder(file, m);
  if (Status s = builder.build(*urdf); !s) return s;
  model = std::move(m);
  return Status::ok();
}

// console_bridge's output handler is global: one parse at a time.
std::mutex g_parse_mutex;

}  // namespace

Status load_urdf_string(const std::string& xml, const std::string& name_for_messages, Model& model,
                        const UrdfOptions& options) {
  urdf::ModelInterfaceSharedPtr urdf;
  std::string messages;
  {
    std::lock_guard<std::mutex> lock(g_parse_mutex);
    CaptureConsole capture;
    console_bridge::useOutputHandler(&capture);
    try {
      urdf = urdf::parseURDF(xml);
    } catch (const std::exception& e) {
      capture.messages += e.what();
    }
    console_bridge::restorePreviousOutputHandler();
    messages = capture.messages;
  }
  if (!urdf)
    return invalid_argument(name_for_messages + ": malformed URDF" + (messages.empty() ? "" : ": " + messages));
  Status built = build_model(urdf, name_for_messages, model, options);
  // urdfdom's links own their child links (shared_ptr): a joint that makes a link its own
  // descendant (a closed loop, which build_model refuses) leaves a cycle of owners that would
  // never be freed (found by fuzz/urdf_fuzzer)
  for (auto& [name, link] : urdf->links_) link->child_links.clear();
  return built;
}

Status load_urdf_file(const std::string& path, Model& model, const UrdfOptions& options) {
  std::ifstream in(path);
  if (!in) return not_found(path + ": cannot open URDF file");
  std::stringstream text;
  text << in.rdbuf();
  return load_urdf_string(text.str(), path, model, options);
}

}  // namespace rbdgrad
