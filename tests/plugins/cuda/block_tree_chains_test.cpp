// Tests for plugins/cuda/device/block_tree_chains.hpp (M^-1 by the chains of a tree fixed at
// compile time), compiled as plain C++: the chains cover every joint once, each a range of joints
// with one child each but the bottom, in rounds after their children's; the table builds at
// compile time; and the chains' U = IA S, pivots and M^-1 are those of the generic level passes
// (block_mass_inverse.hpp) to rounding, also where a pivot fails.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <string>
#include <vector>

#include <Eigen/Dense>

#include "../../support/test_models.hpp"
#include "nested_junctions_tree.hpp"
#include "device/block_tree_chains.hpp"
#include "flat_model.hpp"

namespace rbdgrad::testing {

// A model view whose joint count and tree the chains take as fixed (the tree from the view's
// arrays, at run time, as host_tree_view.hpp's HostTreeView), its levels the view's
template <int NV>
struct ChainTestView : cuda::ModelView<double> {
  explicit ChainTestView(const cuda::ModelView<double>& view) : cuda::ModelView<double>(view) {}
};

}  // namespace rbdgrad::testing

namespace rbdgrad::cuda {
template <int NV>
struct FixedSizes<testing::ChainTestView<NV>> {
  static constexpr int nv = NV, levels = 0, matrix_scalars = 0;
};
template <int NV>
struct FixedTree<testing::ChainTestView<NV>> {
  static constexpr bool known = true;
  static int parent(const testing::ChainTestView<NV>& m, int i) { return m.parent[i]; }
  static int subtree_end(const testing::ChainTestView<NV>& m, int i) { return m.subtree_end[i]; }
};
}  // namespace rbdgrad::cuda

namespace rbdgrad::testing {
namespace {

const std::vector<int> kNestedJunctions = NestedJunctions::parents();

template <int NV>
cuda::TreeChains<NV> chains_of(const std::vector<int>& parent) {
  return cuda::tree_chains<NV>([&](int i) { return parent[static_cast<std::size_t>(i)]; });
}

// The table's chains against the tree: every joint once; a chain is [bottom - length + 1, bottom],
// each joint but its bottom with one child, the next; its bottom with none or several; its top a
// root or a child of a junction (then its slot, for that parent); a chain's round after its
// bottom's children's chains', 0 at a leaf; each round's longest.
template <int NV>
void check_chains(const std::string& name, const std::vector<int>& parent) {
  ASSERT_EQ(static_cast<int>(parent.size()), NV) << name;
  const cuda::TreeChains<NV> t = chains_of<NV>(parent);
  ASSERT_TRUE(t.fits) << name;
  std::vector<int> children(NV, 0), chain_round(NV, -1), seen(NV, 0);
  for (int i = 0; i < NV; ++i)
    if (parent[i] >= 0) ++children[parent[i]];
  std::vector<int> slots_seen(static_cast<std::size_t>(t.slots), 0);
  for (int r = 0; r < t.rounds; ++r) {
    ASSERT_GE(t.count[r], 1) << name << " round " << r;
    ASSERT_LE(t.count[r], cuda::kChainsPerWarp) << name << " round " << r;
    int longest = 0;
    for (int k = 0; k < t.count[r]; ++k) {
      const int b = t.bottom[r][k], top = b - t.length[r][k] + 1;
      const std::string where = name + " round " + std::to_string(r) + " chain " + std::to_string(k);
      ASSERT_GE(top, 0) << where;
      EXPECT_NE(children[b], 1) << where << ": its bottom has one child";
      for (int j = top; j < b; ++j) {
        EXPECT_EQ(children[j], 1) << where << " joint " << j;
        EXPECT_EQ(parent[j + 1], j) << where << " joint " << j;
      }
      for (int j = top; j <= b; ++j) {
        ++seen[j];
        chain_round[j] = r;
      }
      if (k > 0) {
        EXPECT_LT(t.bottom[r][k - 1], b) << where << ": the round's chains in their bottoms' order";
      }
      const int p = parent[top];
      if (p < 0) {
        EXPECT_EQ(t.top_slot[r][k], -1) << where;
      } else {
        EXPECT_GE(children[p], 2) << where << ": its top is not the only child of its parent";
        ASSERT_GE(t.top_slot[r][k], 0) << where;
        ASSERT_LT(t.top_slot[r][k], t.slots) << where;
        EXPECT_EQ(t.slot_parent[t.top_slot[r][k]], p) << where;
        ++slots_seen[static_cast<std::size_t>(t.top_slot[r][k])];
      }
      longest = std::max(longest, t.length[r][k]);
    }
    EXPECT_EQ(t.longest[r], longest) << name << " round " << r;
  }
  for (int i = 0; i < NV; ++i) EXPECT_EQ(seen[i], 1) << name << " joint " << i;
  for (int s = 0; s < t.slots; ++s) EXPECT_EQ(slots_seen[static_cast<std::size_t>(s)], 1) << name << " slot " << s;
  // a chain's round: one more than the largest of its bottom's children's chains', 0 at a leaf
  for (int r = 0; r < t.rounds; ++r)
    for (int k = 0; k < t.count[r]; ++k) {
      const int b = t.bottom[r][k];
      int expected = 0;
      for (int c = b + 1; c < NV; ++c)
        if (parent[c] == b) expected = std::max(expected, chain_round[c] + 1);
      EXPECT_EQ(r, expected) << name << ": the chain down to " << b;
    }
}

TEST(TreeChains, CoverEveryJointOnceInRoundOrder) {
  check_chains<14>("nested junctions", kNestedJunctions);
  const cuda::TreeChains<14> nested = chains_of<14>(kNestedJunctions);
  EXPECT_EQ(nested.rounds, 3);
  EXPECT_EQ(nested.slots, 6);  // 2 (at 1), 4 and 6 (at 3), 8 (at 1), 12 and 13 (at 11)
  check_chains<7>("iiwa14", load_embedded("iiwa14").parent);
  check_chains<12>("hyq", load_embedded("hyq").parent);
  check_chains<32>("talos_reduced", load_embedded("talos_reduced").parent);
  // talos_reduced: the legs, the arms and the head in the first round, the torso's two joints after
  const cuda::TreeChains<32> talos = chains_of<32>(load_embedded("talos_reduced").parent);
  EXPECT_EQ(talos.rounds, 2);
  EXPECT_EQ(talos.count[0], 5);
  EXPECT_EQ(talos.count[1], 1);
  EXPECT_EQ(talos.longest[0], 8);
  EXPECT_EQ(talos.longest[1], 2);
  EXPECT_EQ(talos.slots, 3);
  const cuda::TreeChains<7> iiwa = chains_of<7>(load_embedded("iiwa14").parent);
  EXPECT_EQ(iiwa.rounds, 1);
  EXPECT_EQ(iiwa.count[0], 1);
  EXPECT_EQ(iiwa.length[0][0], 7);
  // random trees of 12 joints that fit (most have more than five leaves)
  int random_trees = 0;
  for (unsigned seed = 1; seed < 2000 && random_trees < 20; ++seed) {
    const Model model = random_model(seed, 12, TreeShape::kBranching);
    if (!chains_of<12>(model.parent).fits) continue;
    check_chains<12>("random tree " + std::to_string(seed), model.parent);
    ++random_trees;
  }
  EXPECT_EQ(random_trees, 20);
}

TEST(TreeChains, MoreChainsInARoundThanAWarpHoldsDoNotFit) {
  // six leaves on one root: six chains in the first round
  EXPECT_FALSE(chains_of<7>({-1, 0, 0, 0, 0, 0, 0}).fits);
  EXPECT_TRUE(chains_of<6>({-1, 0, 0, 0, 0, 0}).fits);
}

TEST(TreeChains, BuildAtCompileTime) {
  constexpr cuda::TreeChains<14> t = cuda::tree_chains<14>([](int i) { return NestedJunctions::parent(i); });
  static_assert(t.fits && t.rounds == 3 && t.slots == 6, "the nested junctions' chains, at compile time");
  static_assert(t.count[0] == 5 && t.count[1] == 2 && t.count[2] == 1, "chains by round");
  EXPECT_EQ(t.bottom[2][0], 1);
}

// Random articulated quantities on a tree: axes S_i, Ic_i S_i for inertias Ic_i summed over each
// subtree of random positive definite I_k (or zero at `massless`, whose pivot then fails)
struct AxesInputs {
  std::vector<double> axis, Ic_S;
};
AxesInputs random_axes(const Model& model, unsigned seed, int massless) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  const int n = model.nv;
  std::vector<Eigen::Matrix<double, 6, 6>> I(static_cast<std::size_t>(n));
  for (int k = 0; k < n; ++k) {
    Eigen::Matrix<double, 6, 6> A;
    for (int e = 0; e < 36; ++e) A(e / 6, e % 6) = u(rng);
    const Eigen::Matrix<double, 6, 6> spd = A * A.transpose() + 0.5 * Eigen::Matrix<double, 6, 6>::Identity();
    I[k] = k == massless ? Eigen::Matrix<double, 6, 6>::Zero().eval() : spd;
  }
  AxesInputs in;
  in.axis.resize(6 * n);
  in.Ic_S.resize(6 * n);
  for (double& x : in.axis) x = u(rng);
  for (int i = 0; i < n; ++i) {
    Eigen::Matrix<double, 6, 6> Ic = Eigen::Matrix<double, 6, 6>::Zero();
    for (int k = i; k < model.subtree_end[i]; ++k) Ic += I[k];
    const Eigen::Map<const Eigen::Matrix<double, 6, 1>> S(in.axis.data() + 6 * i);
    Eigen::Map<Eigen::Matrix<double, 6, 1>>(in.Ic_S.data() + 6 * i) = Ic * S;
  }
  return in;
}

// The chains' U, pivots and M^-1 (as 1 thread and as 128, each pass in reverse) against the level
// passes' and the columns', dense rows; the failing pivot the same where `massless` >= 0 (the last
// joint: the largest failing one whatever the others do)
template <int NV>
void check_mass_inverse(const std::string& name, const Model& model, unsigned seed, int massless = -1) {
  ASSERT_EQ(model.nv, NV) << name;
  const cuda::FlatModel<double> flat(model);
  const ChainTestView<NV> m(flat.host_view());
  // M^-1's rows dense, and room for the chains' P (the kernel's packed matrix where it fits)
  const int needed = cuda::kChainScratch * (chains_of<NV>(model.parent).slots + cuda::kChainsPerWarp);
  ASSERT_TRUE(cuda::tree_chains_fit(m, needed)) << name;
  ASSERT_FALSE(cuda::tree_chains_fit(m, needed - 1)) << name;
  const int scalars = std::max(NV * NV, needed);
  const AxesInputs in = random_axes(model, seed, massless);
  const auto row_at = [](int i) { return NV * i; };
  const auto nothing = [](int) {};
  std::vector<double> U(6 * NV), pivots(NV), inverse(static_cast<std::size_t>(scalars), 0.0);
  std::uint32_t failed = 0;
  cuda::ThreadGroup one;
  cuda::articulated_axes<false>(static_cast<const cuda::ModelView<double>&>(m), in.axis.data(), in.Ic_S.data(), U.data(),
                                pivots.data(), &failed, one, 0, nothing);
  for (int j = 0; j < NV; ++j)
    cuda::inverse_column<false>(static_cast<const cuda::ModelView<double>&>(m), in.axis.data(), U.data(), pivots.data(),
                                inverse.data(), row_at, j);
  for (const int threads : {1, 128}) {
    const std::string where = name + ", " + std::to_string(threads) + " threads";
    std::vector<double> chain_U(6 * NV, -1.0), chain_pivots(NV, -1.0), chain_inverse(static_cast<std::size_t>(scalars), 0.0);
    std::uint32_t chain_failed = 0;
    cuda::ThreadGroup g;
    g.size = threads;
    g.reverse = threads > 1;
    int extra_runs = 0;
    cuda::tree_mass_inverse<false>(m, in.axis.data(), in.Ic_S.data(), chain_U.data(), chain_pivots.data(), &chain_failed,
                                   chain_inverse.data(), row_at, g, 5, [&](int) { ++extra_runs; });
    EXPECT_EQ(extra_runs, 5) << where;
    EXPECT_EQ(chain_failed, failed) << where;
    if (massless >= 0) {
      EXPECT_EQ(chain_failed, static_cast<std::uint32_t>(massless) + 1u) << where;
      continue;
    }
    ASSERT_EQ(failed, 0u) << where;
    const auto close = [](double a, double b) { return std::abs(a - b) <= 1e-11 * std::max(1.0, std::abs(b)); };
    for (int e = 0; e < 6 * NV; ++e) EXPECT_PRED2(close, chain_U[e], U[e]) << where << " U entry " << e;
    for (int i = 0; i < NV; ++i) EXPECT_PRED2(close, chain_pivots[i], pivots[i]) << where << " pivot " << i;
    for (int i = 0; i < NV; ++i)
      for (int j = m.root_of[i]; j < m.subtree_end[m.root_of[i]]; ++j)
        EXPECT_PRED2(close, chain_inverse[NV * i + j], inverse[NV * i + j]) << where << " M^-1 (" << i << ", " << j << ")";
  }
}

TEST(TreeChains, MassInverseMatchesTheLevelPasses) {
  check_mass_inverse<14>("nested junctions", model_with_tree(kNestedJunctions), 1);
  check_mass_inverse<32>("talos_reduced", load_embedded("talos_reduced"), 2);
  check_mass_inverse<12>("hyq", load_embedded("hyq"), 3);
  check_mass_inverse<7>("iiwa14", load_embedded("iiwa14"), 4);
  int random_trees = 0;
  for (unsigned seed = 1; seed < 2000 && random_trees < 4; ++seed) {
    const Model model = random_model(seed, 12, TreeShape::kBranching);
    const cuda::TreeChains<12> t = chains_of<12>(model.parent);
    if (!t.fits || t.rounds < 3) continue;
    check_mass_inverse<12>("random tree " + std::to_string(seed), model, seed);
    ++random_trees;
  }
  EXPECT_EQ(random_trees, 4) << "random trees of three rounds or more";
}

TEST(TreeChains, AFailingPivotIsTheLevelPassesOne) {
  check_mass_inverse<14>("nested junctions, the last joint massless", model_with_tree(kNestedJunctions), 1, 13);
  check_mass_inverse<32>("talos_reduced, the last joint massless", load_embedded("talos_reduced"), 2, 31);
}

}  // namespace
}  // namespace rbdgrad::testing
