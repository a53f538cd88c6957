// A model type that fixes the tree as TreeModelView does (the lean block kernel compiled for a
// robot, kernel_source.cpp), here from the view's arrays at run time: the passes that unroll over
// a fixed tree (block_tree_sums.hpp, the chains, the tree's products and columns) run on the host
// as loops. For host code only: the block state tests and the host tools that run the device code
// (bench/plugins/cuda_shared_wavefronts.cpp).
#pragma once

#include "device/model_view.hpp"

namespace rbdgrad::cuda {

template <class S, int NV, int LEVELS>
struct HostTreeView : FixedSizeModelView<S, NV, LEVELS> {
  explicit HostTreeView(const ModelView<S>& view) : FixedSizeModelView<S, NV, LEVELS>(view) {}
};

template <class S, int NV, int LEVELS>
struct FixedSizes<HostTreeView<S, NV, LEVELS>> : FixedSizes<FixedSizeModelView<S, NV, LEVELS>> {};
template <class S, int NV, int LEVELS>
struct FixedTree<HostTreeView<S, NV, LEVELS>> {
  static constexpr bool known = true;
  static int parent(const HostTreeView<S, NV, LEVELS>& m, int i) { return m.parent[i]; }
  static int subtree_end(const HostTreeView<S, NV, LEVELS>& m, int i) { return m.subtree_end[i]; }
};

}  // namespace rbdgrad::cuda
