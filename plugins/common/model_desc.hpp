// The model description of the plugin ABI (rbdgrad_model_desc): built from a core Model on the host
// side, turned back into a validated Model on the plugin side.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "rbdgrad/model.hpp"
#include "rbdgrad/plugin_api.h"
#include "rbdgrad/status.hpp"

namespace rbdgrad::plugin {

// Owns the flat arrays that an rbdgrad_model_desc points into. The ABI's 3x3 matrices are
// row-major while Eigen stores column-major: the constructor transposes the layout element by element.
class ModelDesc {
 public:
  explicit ModelDesc(const Model& model);
  // copies and moves re-point the description at the new object's arrays
  ModelDesc(const ModelDesc& other);
  ModelDesc(ModelDesc&& other) noexcept;
  ModelDesc& operator=(const ModelDesc& other);
  ModelDesc& operator=(ModelDesc&& other) noexcept;
  ~ModelDesc() = default;

  /// Valid while this object lives and is not modified.
  const rbdgrad_model_desc& desc() const { return desc_; }

  /// Adds a plan (ABI 1.3) that every batch of the instances made from this description follows:
  /// the outputs they may ask for, whether they bring M^-1, the bodies that receive forces
  /// (ascending; empty = none).
  void set_plan(std::uint32_t outputs, bool minv_supplied, std::vector<std::uint32_t> fext_bodies);

 private:
  void point_desc();

  std::string name_;
  std::vector<std::int32_t> parent_;        // (nv)
  std::vector<std::uint8_t> joint_type_;    // (nv) 0 revolute, 1 prismatic
  std::vector<double> joint_rotation_;      // (9 nv) row-major 3x3 per joint
  std::vector<double> joint_translation_;   // (3 nv)
  std::vector<double> mass_;                // (nv)
  std::vector<double> com_;                 // (3 nv)
  std::vector<double> inertia_com_;         // (9 nv) row-major
  std::vector<double> link_rotation_;       // (9 nv) row-major
  bool has_plan_ = false;
  rbdgrad_plan plan_{};
  std::vector<std::uint32_t> fext_bodies_;  // the plan's
  rbdgrad_model_desc desc_{};
};

/// Builds a Model from a description received through the ABI, checking everything the host could
/// get wrong: struct_size, NULL arrays, nv >= 1, joint types, parent order (depth-first, parent[i] <
/// i), finite values, proper rotations, valid inertias (rbdgrad::validate_model). Messages name the
/// field and the joint: "model_desc.mass[3] (joint 3) is not finite (nan)".
/// Joint names are not part of the ABI: joints become "joint_<i>", links "link_<i>".
/// \param[out] out filled only on success.
Status model_from_desc(const rbdgrad_model_desc& d, Model& out);

}  // namespace rbdgrad::plugin
