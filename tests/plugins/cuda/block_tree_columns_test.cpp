// Tests for plugins/cuda/device/block_tree_columns.hpp (M^-1's columns by a tree fixed at compile
// time), compiled as plain C++: the table's blocks, shapes and segments against the tree, built at
// compile time; and every column the same bits as the generic inverse_column's
// (block_mass_inverse.hpp), in the dense layout and in the packed one the kernel uses.
#include <gtest/gtest.h>

#include <cstring>
#include <random>
#include <string>
#include <vector>

#include "../../support/test_models.hpp"
#include "nested_junctions_tree.hpp"
#include "device/block_tree_columns.hpp"
#include "flat_model.hpp"

namespace rbdgrad::testing {
namespace {

template <int NV>
cuda::TreeColumns<NV> columns_of(const std::vector<int>& parent) {
  return cuda::tree_columns<NV>([&](int i) { return parent[static_cast<std::size_t>(i)]; });
}

// The table against the tree: the blocks are the roots' subtrees in order, each of the shape of
// the first block of its size and relative parents; each joint's parent and subtree end relative
// to its block's root; the segments cover every joint once in order, each joint of one but its
// bottom with one child, the next, and its subtree ending where the bottom's does.
template <int NV>
void check_columns(const std::string& name, const Model& model) {
  ASSERT_EQ(model.nv, NV) << name;
  const cuda::TreeColumns<NV> t = columns_of<NV>(model.parent);
  std::vector<int> children(NV, 0);
  for (int i = 0; i < NV; ++i)
    if (model.parent[i] >= 0) ++children[model.parent[i]];
  int joint = 0;
  for (int k = 0; k < t.blocks; ++k) {
    const std::string where = name + " block " + std::to_string(k);
    const int root = t.first[k];
    ASSERT_EQ(root, joint) << where;
    EXPECT_EQ(model.parent[root], -1) << where;
    EXPECT_EQ(t.size[k], model.subtree_end[root] - root) << where;
    for (int i = root; i < root + t.size[k]; ++i) {
      EXPECT_EQ(t.parent[i], model.parent[i] < 0 ? -1 : model.parent[i] - root) << where << " joint " << i;
      EXPECT_EQ(t.end[i], model.subtree_end[i] - root) << where << " joint " << i;
    }
    // its shape: the first block of its size and relative parents
    int shape = k;
    for (int q = k - 1; q >= 0; --q) {
      bool same = t.size[q] == t.size[k];
      for (int r = 0; same && r < t.size[k]; ++r) same = t.parent[t.first[q] + r] == t.parent[root + r];
      if (same) shape = q;
    }
    EXPECT_EQ(t.shape[k], shape) << where;
    joint += t.size[k];
  }
  EXPECT_EQ(joint, NV) << name;
  int next = 0;
  for (int q = 0; q < t.segments; ++q) {
    const std::string where = name + " segment " + std::to_string(q);
    const int top = t.segment_top[q], bottom = t.segment_bottom[q];
    ASSERT_EQ(top, next) << where;
    ASSERT_LE(top, bottom) << where;
    for (int i = top; i < bottom; ++i) {
      EXPECT_EQ(children[i], 1) << where << " joint " << i;
      EXPECT_EQ(model.parent[i + 1], i) << where << " joint " << i;
      EXPECT_EQ(model.subtree_end[i], model.subtree_end[bottom]) << where << " joint " << i;
    }
    // maximal: the next joint starts a segment of its own
    if (bottom + 1 < NV) {
      EXPECT_FALSE(children[bottom] == 1 && model.parent[bottom + 1] == bottom) << where;
    }
    EXPECT_EQ(t.segment_end[q], t.end[bottom]) << where;
    EXPECT_EQ(t.segment_parent[q], t.parent[top]) << where;
    next = bottom + 1;
  }
  EXPECT_EQ(next, NV) << name;
}

const std::vector<int> kNestedJunctions = NestedJunctions::parents();

TEST(TreeColumns, BlocksShapesAndSegmentsFollowTheTree) {
  check_columns<14>("nested junctions", model_with_tree(kNestedJunctions));
  check_columns<7>("iiwa14", load_embedded("iiwa14"));
  check_columns<12>("hyq", load_embedded("hyq"));
  check_columns<32>("talos_reduced", load_embedded("talos_reduced"));
  // talos_reduced: the two legs one shape, the torso another
  const cuda::TreeColumns<32> talos = columns_of<32>(load_embedded("talos_reduced").parent);
  ASSERT_EQ(talos.blocks, 3);
  EXPECT_EQ(talos.shape[0], 0);
  EXPECT_EQ(talos.shape[1], 0);
  EXPECT_EQ(talos.shape[2], 2);
  // hyq's four legs: one shape
  const cuda::TreeColumns<12> hyq = columns_of<12>(load_embedded("hyq").parent);
  ASSERT_EQ(hyq.blocks, 4);
  for (int k = 0; k < 4; ++k) EXPECT_EQ(hyq.shape[k], 0) << "hyq leg " << k;
  for (unsigned seed = 1; seed <= 20; ++seed)
    check_columns<12>("random tree " + std::to_string(seed), random_model(seed, 12, TreeShape::kBranching));
}

TEST(TreeColumns, BuildAtCompileTime) {
  constexpr cuda::TreeColumns<14> t = cuda::tree_columns<14>([](int i) { return NestedJunctions::parent(i); });
  static_assert(t.blocks == 2 && t.size[0] == 11 && t.size[1] == 3, "the nested junctions' blocks, at compile time");
  // [0, 1], [2, 3], [4, 5], [6, 7], [8, 10], [11], [12], [13]
  static_assert(t.segments == 8 && t.segment_top[4] == 8 && t.segment_bottom[4] == 10, "its segments");
  EXPECT_EQ(t.segment_parent[2], 3);
}

// Every column by the tree against inverse_column, bit for bit, on random S, U and pivots (the
// columns' arithmetic takes any values), in the dense layout and the packed one (flat_model.hpp).
template <int NV>
void check_inverse_columns(const std::string& name, const Model& model, unsigned seed) {
  ASSERT_EQ(model.nv, NV) << name;
  const cuda::FlatModel<double> flat(model);
  const cuda::ModelView<double> m = flat.host_view();
  const cuda::TreeColumns<NV> t = columns_of<NV>(model.parent);
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  std::vector<double> axis(6 * NV), U(6 * NV), pivots(NV);
  for (double& x : axis) x = u(rng);
  for (double& x : U) x = u(rng);
  for (double& x : pivots) x = 0.5 + u(rng) * u(rng);
  const auto dense = [](int i) { return NV * i; };
  const auto packed = [&](int i) { return m.matrix_row[i]; };
  for (const bool by_blocks : {false, true}) {
    const std::string where = name + (by_blocks ? ", packed" : ", dense");
    const int scalars = by_blocks ? m.matrix_scalars : NV * NV;
    // poisoned before: an entry of a column's block left unwritten shows
    std::vector<double> expected(static_cast<std::size_t>(scalars), -7.0), got(expected);
    for (int j = 0; j < NV; ++j) {
      if (by_blocks) {
        cuda::inverse_column<false>(m, axis.data(), U.data(), pivots.data(), expected.data(), packed, j);
        cuda::tree_inverse_column<false, NV, NV>(t, axis.data(), U.data(), pivots.data(), got.data(), packed, j);
      } else {
        cuda::inverse_column<false>(m, axis.data(), U.data(), pivots.data(), expected.data(), dense, j);
        cuda::tree_inverse_column<false, NV, NV>(t, axis.data(), U.data(), pivots.data(), got.data(), dense, j);
      }
    }
    int different = 0;
    for (std::size_t e = 0; e < expected.size(); ++e)
      if (std::memcmp(&expected[e], &got[e], sizeof(double)) != 0 && ++different <= 5)
        ADD_FAILURE() << where << ": entry " << e << " " << got[e] << ", inverse_column " << expected[e];
    EXPECT_EQ(different, 0) << where;
    // and every entry of each column's block written
    for (int i = 0; i < NV; ++i)
      for (int j = m.root_of[i]; j < m.subtree_end[m.root_of[i]]; ++j)
        EXPECT_NE(got[static_cast<std::size_t>((by_blocks ? packed(i) : dense(i)) + j)], -7.0)
            << where << " (" << i << ", " << j << ")";
  }
}

TEST(TreeColumns, EveryColumnIsInverseColumnsBits) {
  check_inverse_columns<14>("nested junctions", model_with_tree(kNestedJunctions), 1);
  check_inverse_columns<7>("iiwa14", load_embedded("iiwa14"), 2);
  check_inverse_columns<12>("hyq", load_embedded("hyq"), 3);
  check_inverse_columns<32>("talos_reduced", load_embedded("talos_reduced"), 4);
  for (unsigned seed = 1; seed <= 20; ++seed)
    check_inverse_columns<12>("random tree " + std::to_string(seed), random_model(seed, 12, TreeShape::kBranching),
                              seed);
}

}  // namespace
}  // namespace rbdgrad::testing
