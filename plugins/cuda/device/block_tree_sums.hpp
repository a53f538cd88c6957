// Sums over subtrees and over ancestors by the tree itself, for a model type that fixes the tree
// (model_view.hpp: TreeModelView, the lean block kernel compiled for one robot). One thread sums
// one component for every joint, each joint's sum from its children's or its parent's, which are
// still in registers. With the tree's indices constants the loops unroll into straight-line adds
// and loads at constant offsets; the generic pass (block_fused_state.hpp) sums each subtree anew,
// an item a joint and component, with a loop and index arithmetic per item (run 141: 3,534 warp
// instructions a talos_reduced state for 256 of arithmetic).
#pragma once

#include "model_view.hpp"

namespace rbdgrad::cuda {

// to[kStride * i] = the sum of from[kStride * k] over i's subtree k, for every joint i
template <int kStride, class S, class Model>
RBDGRAD_HD void tree_subtree_sums(const Model& m, const S* from, S* to) {
  constexpr int n = FixedSizes<Model>::nv;
  static_assert(n > 0 && FixedTree<Model>::known, "the tree's sums need the tree at compile time");
  S sum[n] = {};  // (each read after it is written: a joint's children come after it, summed first)
#if defined(__CUDA_ARCH__)
#pragma unroll
#endif
  for (int i = n - 1; i >= 0; --i) {
    S s = from[kStride * i];
    // i's children, in index order (a fixed trip count, so that the loop unrolls)
#if defined(__CUDA_ARCH__)
#pragma unroll
#endif
    for (int c = 0; c < n; ++c)
      if (c > i && FixedTree<Model>::parent(m, c) == i) s += sum[c];
    sum[i] = s;
    to[kStride * i] = s;
  }
}

// out[6 i] = init + the sum of x[6 j] y[j] over i's ancestors-or-self j, for every joint i (a
// component of the velocities or accelerations: x one of a 6-vector array, out another): the
// joints first to last, each joint's sum its parent's plus its own term. The adds are those of
// the generic pass's items (from the root down, a multiply-add a joint), in the same order.
template <class S, class Model>
RBDGRAD_HD void tree_ancestor_sums(const Model& m, const S* x, const S* y, S* out, S init) {
  constexpr int n = FixedSizes<Model>::nv;
  static_assert(n > 0 && FixedTree<Model>::known, "the tree's sums need the tree at compile time");
  S sum[n] = {};  // (every entry written before it is read: a parent comes before its children)
#if defined(__CUDA_ARCH__)
#pragma unroll
#endif
  for (int i = 0; i < n; ++i) {
    const int parent = FixedTree<Model>::parent(m, i);
    S s = parent < 0 ? init : sum[parent < 0 ? 0 : parent];
    s += x[6 * i] * y[i];
    sum[i] = s;
    out[6 * i] = s;
  }
}

}  // namespace rbdgrad::cuda
