#include "model_desc.hpp"

#include <Eigen/LU>  // determinant
#include <cmath>
#include <cstddef>
#include <cstdio>
#include <tuple>
#include <utility>

namespace rbdgrad::plugin {

namespace {

// the core indexes nv x nv matrices with int arithmetic in places: keep nv^2 well inside int
constexpr std::uint32_t kMaxNv = 32768;

void append_row_major(std::vector<double>& out, const Eigen::Matrix3d& m) {
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) out.push_back(m(r, c));
}

void append(std::vector<double>& out, const Eigen::Vector3d& v) {
  for (int r = 0; r < 3; ++r) out.push_back(v(r));
}

Eigen::Matrix3d read_row_major(const double* p) {
  Eigen::Matrix3d m;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) m(r, c) = p[r * 3 + c];
  return m;
}

std::string number(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.17g", v);
  return buf;
}

// "model_desc.com[7] (joint 2) is not finite (nan)" for the first bad value of joint i's `per` entries
Status check_finite(const char* field, const double* values, std::uint32_t i, int per) {
  for (int k = 0; k < per; ++k) {
    const double v = values[static_cast<std::size_t>(i) * per + k];
    if (!std::isfinite(v))
      return invalid_argument(std::string("model_desc.") + field + "[" + std::to_string(i * per + k) + "] (joint " +
                              std::to_string(i) + ") is not finite (" + number(v) + ")");
  }
  return Status::ok();
}

}  // namespace

ModelDesc::ModelDesc(const Model& model) : name_(model.name) {
  const auto n = static_cast<std::size_t>(model.nv);
  parent_.reserve(n);
  joint_type_.reserve(n);
  for (std::vector<double>* v : {&joint_rotation_, &inertia_com_, &link_rotation_}) v->reserve(9 * n);
  for (std::vector<double>* v : {&joint_translation_, &com_}) v->reserve(3 * n);
  mass_.reserve(n);
  for (std::size_t i = 0; i < n; ++i) {
    parent_.push_back(model.parent[i]);
    joint_type_.push_back(model.type[i] == JointType::kPrismatic ? 1 : 0);
    append_row_major(joint_rotation_, model.joint_rotation[i]);
    append(joint_translation_, model.joint_translation[i]);
    mass_.push_back(model.mass[i]);
    append(com_, model.com[i]);
    append_row_major(inertia_com_, model.inertia_com[i]);
    append_row_major(link_rotation_, model.link_rotation[i]);
  }
  desc_.nv = static_cast<std::uint32_t>(model.nv);
  for (int r = 0; r < 3; ++r) desc_.gravity[r] = model.gravity(r);
  point_desc();
}

ModelDesc::ModelDesc(const ModelDesc& other)
    : name_(other.name_), parent_(other.parent_), joint_type_(other.joint_type_),
      joint_rotation_(other.joint_rotation_), joint_translation_(other.joint_translation_), mass_(other.mass_),
      com_(other.com_), inertia_com_(other.inertia_com_), link_rotation_(other.link_rotation_), has_plan_(other.has_plan_), plan_(other.plan_),
      fext_bodies_(other.fext_bodies_), desc_(other.desc_) {
  point_desc();
}

// a moved std::string may live in the object itself (small-string buffer): always re-point
ModelDesc::ModelDesc(ModelDesc&& other) noexcept
    : name_(std::move(other.name_)), parent_(std::move(other.parent_)), joint_type_(std::move(other.joint_type_)),
      joint_rotation_(std::move(other.joint_rotation_)), joint_translation_(std::move(other.joint_translation_)),
      mass_(std::move(other.mass_)), com_(std::move(other.com_)), inertia_com_(std::move(other.inertia_com_)),
      link_rotation_(std::move(other.link_rotation_)), has_plan_(other.has_plan_), plan_(other.plan_),
      fext_bodies_(std::move(other.fext_bodies_)), desc_(other.desc_) {
  point_desc();
  other.point_desc();
}

ModelDesc& ModelDesc::operator=(const ModelDesc& other) {
  if (this != &other) *this = ModelDesc(other);
  return *this;
}

ModelDesc& ModelDesc::operator=(ModelDesc&& other) noexcept {
  if (this == &other) return *this;
  name_ = std::move(other.name_);
  parent_ = std::move(other.parent_);
  joint_type_ = std::move(other.joint_type_);
  joint_rotation_ = std::move(other.joint_rotation_);
  joint_translation_ = std::move(other.joint_translation_);
  mass_ = std::move(other.mass_);
  com_ = std::move(other.com_);
  inertia_com_ = std::move(other.inertia_com_);
  link_rotation_ = std::move(other.link_rotation_);
  has_plan_ = other.has_plan_;
  plan_ = other.plan_;
  fext_bodies_ = std::move(other.fext_bodies_);
  desc_ = other.desc_;
  point_desc();
  other.point_desc();
  return *this;
}

void ModelDesc::point_desc() {
  desc_.struct_size = sizeof(rbdgrad_model_desc);
  desc_.name = name_.c_str();
  desc_.nv = static_cast<std::uint32_t>(parent_.size());
  desc_.parent = parent_.data();
  desc_.joint_type = joint_type_.data();
  desc_.joint_rotation = joint_rotation_.data();
  desc_.joint_translation = joint_translation_.data();
  desc_.mass = mass_.data();
  desc_.com = com_.data();
  desc_.inertia_com = inertia_com_.data();
  desc_.link_rotation = link_rotation_.data();
  plan_.struct_size = sizeof(rbdgrad_plan);
  plan_.fext_body_count = static_cast<std::uint32_t>(fext_bodies_.size());
  plan_.fext_bodies = fext_bodies_.empty() ? nullptr : fext_bodies_.data();
  desc_.plan = has_plan_ ? &plan_ : nullptr;
}

void ModelDesc::set_plan(std::uint32_t outputs, bool minv_supplied, std::vector<std::uint32_t> fext_bodies) {
  has_plan_ = true;
  plan_.outputs = outputs;
  plan_.minv_supplied = minv_supplied ? 1 : 0;
  fext_bodies_ = std::move(fext_bodies);
  point_desc();
}

Status model_from_desc(const rbdgrad_model_desc& d, Model& out) {
  // the header fields first: nothing else can be read safely without them
  // a 1.2 host's description ends before the plan (plan_from_desc reads it)
  if (d.struct_size < offsetof(rbdgrad_model_desc, plan))
    return invalid_argument("model_desc.struct_size is " + std::to_string(d.struct_size) + ", expected at least " +
                            std::to_string(offsetof(rbdgrad_model_desc, plan)) + " (API " +
                            std::to_string(RBDGRAD_PLUGIN_API_MAJOR) + ".2)");
  if (d.name == nullptr) return invalid_argument("model_desc.name is NULL");
  if (d.nv < 1) return invalid_argument("model_desc.nv is 0: a model needs at least one moving joint");
  if (d.nv > kMaxNv)
    return invalid_argument("model_desc.nv is " + std::to_string(d.nv) + ", more than the " +
                            std::to_string(kMaxNv) + " joints supported");
  const std::pair<const void*, const char*> arrays[] = {
      {d.parent, "parent"}, {d.joint_type, "joint_type"}, {d.joint_rotation, "joint_rotation"},
      {d.joint_translation, "joint_translation"}, {d.mass, "mass"}, {d.com, "com"},
      {d.inertia_com, "inertia_com"}, {d.link_rotation, "link_rotation"}};
  for (const auto& [pointer, field] : arrays)
    if (pointer == nullptr) return invalid_argument(std::string("model_desc.") + field + " is NULL");
  for (int r = 0; r < 3; ++r)
    if (!std::isfinite(d.gravity[r]))
      return invalid_argument("model_desc.gravity[" + std::to_string(r) + "] is not finite (" + number(d.gravity[r]) + ")");

  Model m;
  m.name = d.name;
  m.source = "<plugin model description>";
  m.nv = static_cast<int>(d.nv);
  m.gravity = Eigen::Vector3d(d.gravity[0], d.gravity[1], d.gravity[2]);
  for (std::uint32_t i = 0; i < d.nv; ++i) {
    const std::string joint = "joint " + std::to_string(i);
    // topology: parent[i] < i, and i continues the depth-first walk: its parent is an
    // ancestor-or-self of joint i - 1, so every subtree stays a contiguous index range
    const std::int32_t p = d.parent[i];
    if (p < -1 || p >= static_cast<std::int64_t>(i))
      return invalid_argument("model_desc.parent[" + std::to_string(i) + "] is " + std::to_string(p) +
                              ": must be -1 (the world) or an earlier joint in [0, " + std::to_string(i) + ")");
    if (p >= 0) {
      std::int32_t a = static_cast<std::int32_t>(i) - 1;
      while (a > p) a = d.parent[a];
      if (a != p)
        return invalid_argument("model_desc.parent[" + std::to_string(i) + "] is " + std::to_string(p) + " but joint " +
                                std::to_string(i - 1) + " is outside joint " + std::to_string(p) +
                                "'s subtree: joints must be in depth-first order");
    }
    if (d.joint_type[i] > 1)
      return invalid_argument("model_desc.joint_type[" + std::to_string(i) + "] is " + std::to_string(d.joint_type[i]) +
                              ": must be 0 (revolute) or 1 (prismatic)");
    for (const auto& [field, values, per] : {std::tuple{"joint_rotation", d.joint_rotation, 9},
                                             std::tuple{"joint_translation", d.joint_translation, 3},
                                             std::tuple{"mass", d.mass, 1}, std::tuple{"com", d.com, 3},
                                             std::tuple{"inertia_com", d.inertia_com, 9},
                                             std::tuple{"link_rotation", d.link_rotation, 9}})
      if (Status s = check_finite(field, values, i, per); !s) return s;

    const std::size_t at3 = 3 * static_cast<std::size_t>(i), at9 = 9 * static_cast<std::size_t>(i);
    m.parent.push_back(p);
    m.type.push_back(d.joint_type[i] == 1 ? JointType::kPrismatic : JointType::kRevolute);
    m.joint_rotation.push_back(read_row_major(d.joint_rotation + at9));
    m.joint_translation.emplace_back(d.joint_translation[at3], d.joint_translation[at3 + 1], d.joint_translation[at3 + 2]);
    m.mass.push_back(d.mass[i]);
    m.com.emplace_back(d.com[at3], d.com[at3 + 1], d.com[at3 + 2]);
    m.inertia_com.push_back(read_row_major(d.inertia_com + at9));
    const Eigen::Matrix3d link = read_row_major(d.link_rotation + at9);
    // validate_model does not look at link_rotation: external forces go through it
    if ((link.transpose() * link - Eigen::Matrix3d::Identity()).norm() > 1e-9 || link.determinant() < 0)
      return invalid_argument("model_desc.link_rotation (" + joint + ") is not a proper rotation");
    m.link_rotation.push_back(link);
    JointInfo info;
    info.name = "joint_" + std::to_string(i);
    info.urdf_type = m.type.back() == JointType::kPrismatic ? "prismatic" : "revolute";
    info.child_link = "link_" + std::to_string(i);
    info.parent_link = p < 0 ? "world" : "link_" + std::to_string(p);
    m.joints.push_back(std::move(info));
  }
  finalize_topology(m);
  // rotations are orthonormal, masses non-negative, inertias symmetric positive semi-definite
  if (std::string problem = validate_model(m); !problem.empty()) return invalid_argument("model_desc: " + problem);
  out = std::move(m);
  return Status::ok();
}

}  // namespace rbdgrad::plugin
