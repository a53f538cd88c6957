// The tree the tree-fixed M^-1 tests share (block_tree_chains_test.cpp, block_tree_columns_test.cpp):
// junctions that nest under one root, then a root with two leaves, as a run-time list, as
// constant expressions (the kernel compiled for a robot has its parents so), and as a model.
#pragma once

#include <cstddef>
#include <vector>

#include "../../support/test_models.hpp"

namespace rbdgrad::testing {

// chains [4, 5] and [6, 7] meet at 3, the chain [2, 3] and [8, 10] at 1, the chain [0, 1] on top
// (three rounds of chains); then a root with two leaves (a chain of one joint whose bottom is a
// junction)
struct NestedJunctions {
  static constexpr int nv = 14;
  static constexpr int parent(int i) {
    constexpr int p[nv] = {-1, 0, 1, 2, 3, 4, 3, 6, 1, 8, 9, -1, 11, 11};
    return p[i];
  }
  static std::vector<int> parents() {
    std::vector<int> p(nv);
    for (int i = 0; i < nv; ++i) p[static_cast<std::size_t>(i)] = parent(i);
    return p;
  }
};

// a random model of `parent`'s tree
inline Model model_with_tree(const std::vector<int>& parent) {
  Model model = random_model(5, static_cast<int>(parent.size()), TreeShape::kChain);
  model.parent = parent;
  finalize_topology(model);
  return model;
}

}  // namespace rbdgrad::testing
