// Tests for plugins/cuda/device/block_tree_products.hpp (the products with M^-1 by the blocks of a
// tree fixed at compile time), compiled as plain C++: the items cover every entry of the blocks
// once and every entry between them once, each warp's items keep to one block size, the blocks
// sit where the flat model packs them, and the sums are the plain products' to the bit.
#include <gtest/gtest.h>

#include <map>
#include <random>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

#include "../../support/test_models.hpp"
#include "device/block_tree_products.hpp"
#include "flat_model.hpp"

namespace rbdgrad::testing {

// A tree as a model type that fixes it, from arrays (the kernel's TreeModelView has constexpr
// functions; the code under test calls the same two)
template <int NV>
struct ArrayTree {
  std::vector<int> parent, subtree_end;
  explicit ArrayTree(std::vector<int> parents) : parent(std::move(parents)), subtree_end(NV) {
    for (int i = NV - 1; i >= 0; --i) {
      int end = i + 1;
      for (int c = i + 1; c < NV; ++c)
        if (parent[c] == i && subtree_end[c] > end) end = subtree_end[c];
      subtree_end[i] = end;
    }
  }
};

}  // namespace rbdgrad::testing

namespace rbdgrad::cuda {
template <int NV>
struct FixedSizes<testing::ArrayTree<NV>> {
  static constexpr int nv = NV, levels = 0, matrix_scalars = 0;
};
template <int NV>
struct FixedTree<testing::ArrayTree<NV>> {
  static constexpr bool known = true;
  static int parent(const testing::ArrayTree<NV>& m, int i) { return m.parent[i]; }
  static int subtree_end(const testing::ArrayTree<NV>& m, int i) { return m.subtree_end[i]; }
};
}  // namespace rbdgrad::cuda

namespace rbdgrad::testing {
namespace {

// chains of the given lengths, one after the other, each from the world
std::vector<int> chains(const std::vector<int>& lengths) {
  std::vector<int> parent;
  for (const int length : lengths)
    for (int k = 0; k < length; ++k) parent.push_back(k == 0 ? -1 : static_cast<int>(parent.size()) - 1);
  return parent;
}

// Tile `tile`, column `col` of a block of b joints (a and d packed at `packed`, its first joint
// `first`) in tiles of at most R rows: each entry it writes the plain sum in r's order, counted in
// `written` by its joints
template <int R>
void check_tile(const std::string& name, const std::vector<double>& a, const std::vector<double>& d, int packed,
                int first, int b, int tile, int col, bool pairs, std::map<std::pair<int, int>, int>& written) {
  cuda::tree_tile_product<R>(a.data() + packed, d.data() + packed, b, tile, col, pairs, [&](int i, int j, double s) {
    double expected = 0.0;
    for (int r = 0; r < b; ++r) expected += a[packed + i * b + r] * d[packed + r * b + j];
    EXPECT_EQ(s, expected) << name << " entry (" << first + i << ", " << first + j << ")";
    ++written[{first + i, first + j}];
  });
}

template <int NV>
void check_tree(const std::string& name, const std::vector<int>& parents) {
  ASSERT_EQ(static_cast<int>(parents.size()), NV) << name;
  const ArrayTree<NV> m(parents);
  using Blocks = cuda::TreeBlocks<ArrayTree<NV>>;
  // each joint's block: [root, subtree_end(root)); the packed matrices as flat_model.hpp lays them
  std::vector<int> root_of(NV), packed_at(NV, -1);
  int packed_scalars = 0;
  for (int i = 0; i < NV; ++i) {
    root_of[i] = parents[i] < 0 ? i : root_of[parents[i]];
    if (parents[i] < 0) {
      packed_at[i] = packed_scalars;
      packed_scalars += Blocks::size(m, i) * Blocks::size(m, i);
    }
  }
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> value(-1.0, 1.0);
  std::vector<double> a(packed_scalars), d(packed_scalars), x(NV);
  for (double& v : a) v = value(rng);
  for (double& v : d) v = value(rng);
  for (double& v : x) v = value(rng);

  // the tiles: each entry of each block once, the product's sum in r's order; a warp's items one
  // block size
  std::map<std::pair<int, int>, int> written;
  const int items = cuda::tree_block_items(m, false);
  ASSERT_EQ(items % 32, 0) << name;
  for (int t = 0; t < items; ++t) {
    cuda::tree_block_item(m, t, false, [&](int first, int b, int packed, int tile, int col) {
      ASSERT_EQ(packed, packed_at[first]) << name << " item " << t;
      ASSERT_EQ(b, Blocks::size(m, first)) << name << " item " << t;
      // the other items of this warp with work: blocks of the same size
      for (int u = t / 32 * 32; u < t / 32 * 32 + 32; ++u)
        cuda::tree_block_item(m, u, false, [&](int, int other, int, int, int) {
          EXPECT_EQ(other, b) << name << ": items " << t << " and " << u << " share a warp";
        });
      check_tile<cuda::kTreeTileRowsOf<ArrayTree<NV>>>(name, a, d, packed, first, b, tile, col,
                                                      packed % 2 == 0 && b % 2 == 0, written);
    });
  }
  // qdd's rows: each row once
  std::vector<int> rows_written(NV, 0);
  const int row_items = cuda::tree_block_items(m, true);
  ASSERT_EQ(row_items % 32, 0) << name;
  for (int t = 0; t < row_items; ++t) {
    cuda::tree_block_item(m, t, true, [&](int first, int b, int packed, int row, int col) {
      EXPECT_EQ(col, 0);
      const double s = cuda::tree_row_product(a.data() + packed + row * b, x.data() + first, b, packed % 2 == 0 && b % 2 == 0);
      double expected = 0.0;
      for (int r = 0; r < b; ++r) expected += a[packed + row * b + r] * x[first + r];
      EXPECT_EQ(s, expected) << name << " row " << first + row;
      ++rows_written[first + row];
    });
  }
  for (int i = 0; i < NV; ++i) EXPECT_EQ(rows_written[i], 1) << name << " row " << i;
  // the entries between blocks: one warp, each once
  const int zero_items = cuda::tree_zero_items(m);
  EXPECT_EQ(zero_items, Blocks::roots(m) > 1 ? 32 : 0) << name;
  for (int lane = 0; lane < zero_items; ++lane)
    cuda::tree_zero_entries(m, lane, [&](int i, int j) {
      EXPECT_NE(root_of[i], root_of[j]) << name << ": (" << i << ", " << j << ") zeroed inside a block";
      ++written[{i, j}];
    });
  for (int i = 0; i < NV; ++i)
    for (int j = 0; j < NV; ++j)
      EXPECT_EQ((written[{i, j}]), 1) << name << ": entry (" << i << ", " << j << ")";
}

TEST(TreeProducts, CoverEveryEntryOnceWithThePlainSums) {
  check_tree<7>("a chain of 7", chains({7}));
  check_tree<12>("four chains of 3", chains({3, 3, 3, 3}));
  check_tree<20>("chains of 3, 7, 3, 7", chains({3, 7, 3, 7}));
  check_tree<40>("two chains of 20 (more joints than a warp's lanes)", chains({20, 20}));
  check_tree<11>("a chain of 11 (tiles of 4, 4 and 3 rows)", chains({11}));
}

// Tiles of at most 4 rows (the build without the chains' tiles, kTreeTileRowsWithoutChains) and of
// 5 (with them): talos_reduced's torso block of 20 rows as five tiles and four, every entry of a
// block once, the sums in r's order, with and without pairs.
TEST(TreeProducts, TilesOfFourAndFiveRowsCoverEveryEntryOnce) {
  static_assert(cuda::tree_tiles<4>(20) == 5 && cuda::tree_tiles<5>(20) == 4);
  static_assert(cuda::tree_tile_rows<4>(6) == 3 && cuda::tree_tile_rows<5>(6) == 3);
  static_assert(cuda::tree_tile_rows<4>(11) == 4 && cuda::tree_tile_rows<5>(11) == 4);
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> value(-1.0, 1.0);
  for (const int b : {2, 3, 6, 8, 11, 20}) {
    std::vector<double> a(static_cast<std::size_t>(b * b)), d(a.size());
    for (double& v : a) v = value(rng);
    for (double& v : d) v = value(rng);
    const auto check = [&](auto rows, bool pairs) {
      constexpr int R = decltype(rows)::value;
      const std::string name = "b " + std::to_string(b) + ", tiles of " + std::to_string(R);
      std::map<std::pair<int, int>, int> written;
      for (int tile = 0; tile < cuda::tree_tiles<R>(b); ++tile)
        for (int col = 0; col < b; ++col) check_tile<R>(name, a, d, 0, 0, b, tile, col, pairs, written);
      for (int i = 0; i < b; ++i)
        for (int j = 0; j < b; ++j) EXPECT_EQ((written[{i, j}]), 1) << name << ": (" << i << ", " << j << ")";
    };
    for (const bool pairs : {false, true}) {
      if (pairs && b % 2 != 0) continue;  // pairs need an even block
      check(std::integral_constant<int, cuda::kTreeTileRowsWithoutChains>{}, pairs);
      check(std::integral_constant<int, cuda::kTreeTileRows>{}, pairs);
    }
  }
}

// The embedded robots' trees, and where flat_model.hpp packs their blocks
template <int NV>
void check_robot(const std::string& robot) {
  const Model model = load_embedded(robot);
  ASSERT_EQ(model.nv, NV) << robot;
  check_tree<NV>(robot, model.parent);
  const cuda::FlatModel<double> flat(model);
  const cuda::ModelView<double> view = flat.host_view();
  const ArrayTree<NV> m(model.parent);
  for (int i = 0; i < NV; ++i) {
    if (model.parent[i] >= 0) continue;
    int first = -1, packed = -1;
    for (int k = 0; k < cuda::TreeBlocks<ArrayTree<NV>>::count(m, view.subtree_end[i] - i); ++k) {
      int f, p;
      cuda::TreeBlocks<ArrayTree<NV>>::block(m, view.subtree_end[i] - i, k, f, p);
      if (f == i) first = f, packed = p;
    }
    ASSERT_EQ(first, i) << robot << ": root " << i << " not among its size's blocks";
    EXPECT_EQ(packed, view.matrix_row[i] + i) << robot << ": root " << i << "'s block packed elsewhere";
  }
}

TEST(TreeProducts, EmbeddedRobotsBlocksWhereTheFlatModelPacksThem) {
  check_robot<32>("talos_reduced");
  check_robot<12>("hyq");
  check_robot<7>("iiwa14");
}

}  // namespace
}  // namespace rbdgrad::testing
