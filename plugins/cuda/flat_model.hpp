// A core Model flattened into the two blocks that device/model_view.hpp reads (ModelLayout): built
// on the host once per instance and precision, then uploaded as is. Host tests point a ModelView
// at these blocks directly.
#pragma once

#include <vector>

#include "device/model_view.hpp"
#include "rbdgrad/model.hpp"

namespace rbdgrad::cuda {

template <class S>
struct FlatModel {
  explicit FlatModel(const Model& model) : nv(model.nv) {
    const auto n = static_cast<std::size_t>(nv);
    ints.resize(static_cast<std::size_t>(ModelLayout::ints(nv)));
    scalars.reserve(static_cast<std::size_t>(ModelLayout::scalars(nv)));
    for (std::size_t i = 0; i < n; ++i) {
      ints[i] = model.parent[i];
      ints[n + i] = model.subtree_end[i];
      ints[2 * n + i] = model.type[i] == JointType::kPrismatic ? 1 : 0;
      // parents come first: a root's own entry is set before its descendants read it
      ints[3 * n + i] = model.parent[i] < 0 ? static_cast<int>(i) : ints[3 * n + static_cast<std::size_t>(model.parent[i])];
    }
    // level_joints and level_start (ModelView): a counting sort of the joints by depth
    levels = model.max_depth();
    int* level_joints = ints.data() + 4 * n;
    int* level_start = ints.data() + 5 * n;
    int at = 0;
    for (int level = 0; level < levels; ++level) {
      level_start[level] = at;
      for (std::size_t i = 0; i < n; ++i)
        if (model.depth[i] == level + 1) level_joints[at++] = static_cast<int>(i);
    }
    level_start[levels] = at;
    // matrix_row: the roots' blocks (contiguous index ranges) one after the other, each square
    int* matrix_row = ints.data() + ModelLayout::matrix_row(nv);
    matrix_scalars = 0;
    for (std::size_t i = 0; i < n; ++i) {
      const int root = ints[3 * n + i], size = model.subtree_end[static_cast<std::size_t>(root)] - root;
      if (static_cast<int>(i) == root) matrix_scalars += size * size;
      // the block starts at matrix_scalars - size * size; row i is row i - root of it
      matrix_row[i] = matrix_scalars - size * size + (static_cast<int>(i) - root) * size - root;
    }
    // the order of model_view(): row-major 3x3 matrices, 3-vectors, scalars
    auto matrices = [&](const std::vector<Eigen::Matrix3d>& m) {
      for (const Eigen::Matrix3d& x : m)
        for (int r = 0; r < 3; ++r)
          for (int c = 0; c < 3; ++c) scalars.push_back(static_cast<S>(x(r, c)));
    };
    auto vectors = [&](const std::vector<Eigen::Vector3d>& v) {
      for (const Eigen::Vector3d& x : v)
        for (int r = 0; r < 3; ++r) scalars.push_back(static_cast<S>(x(r)));
    };
    matrices(model.joint_rotation);
    vectors(model.joint_translation);
    for (double m : model.mass) scalars.push_back(static_cast<S>(m));
    vectors(model.com);
    matrices(model.inertia_com);
    matrices(model.link_rotation);
    for (int r = 0; r < 3; ++r) gravity[r] = static_cast<S>(model.gravity(r));
  }

  /// A view onto blocks laid out like these, e.g. their device copies.
  ModelView<S> view(const S* scalar_block, const int* int_block) const {
    return model_view(nv, levels, matrix_scalars, scalar_block, int_block, gravity);
  }
  ModelView<S> host_view() const { return view(scalars.data(), ints.data()); }

  int nv;
  int levels;              // the tree's depth
  int matrix_scalars;      // ModelView::matrix_scalars
  std::vector<S> scalars;  // (ModelLayout::scalars(nv))
  std::vector<int> ints;   // (ModelLayout::ints(nv))
  S gravity[3];
};

}  // namespace rbdgrad::cuda
