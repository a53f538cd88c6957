// The products with M^-1 (qdd = M^-1 u and -M^-1 d tau/d u) by the roots' blocks, for a model type
// that fixes the tree (model_view.hpp: TreeModelView, the lean block kernel compiled for one
// robot). The generic items (block_fused_state.hpp) take rows 8p .. 8p + 7 of any column and find
// the block, its rows and their addresses at run time: run 146 counted 3,100 warp instructions a
// talos_reduced state for each product, 550 of them f64 and over 1,000 integer address
// arithmetic. Here a pass's items are grouped by block size, each group rounded up to whole warps,
// so that the lanes of a warp run one block size's code: every loop's trip count and every offset
// within a block is a constant, and an item's addresses are a base and immediate offsets. The sums
// are the generic items' (the same products in the same order), so the results are the same bits.
#pragma once

#include "model_view.hpp"
#include "scalar_pairs.hpp"

#if defined(__CUDA_ARCH__)
#define RBDGRAD_TREE_UNROLL _Pragma("unroll")
#else
#define RBDGRAD_TREE_UNROLL
#endif

namespace rbdgrad::cuda {

// A tile is at most this many rows of a block: a thread's sums, and the rows that share each load
// of d tau/d u's column (talos_reduced: the torso's 20 rows as four tiles, a leg's 6 as two of 3).
// 5 where M^-1 goes by the tree's chains: 6.0% faster than 4 there (run 154, H100;
// docs/benchmarks/cuda.md), the chains having freed the registers that 5 needs. 4 in the build
// without the chains, which spills 4 bytes with 5 at talos_reduced's 64 registers (NVRTC,
// KernelSource tests).
inline constexpr int kTreeTileRows = 5;
inline constexpr int kTreeTileRowsWithoutChains = 4;
template <class Model>
inline constexpr int kTreeTileRowsOf = TreeConstants<Model>::chains ? kTreeTileRows : kTreeTileRowsWithoutChains;

RBDGRAD_HD constexpr int whole_warps(int items) { return (items + 31) / 32 * 32; }
// a block of b joints as ceil(b / R) tiles of equal rows (the last may have fewer), R the most
// rows a tile (no default: the items' tiling and the product must take the same R,
// kTreeTileRowsOf<Model>)
template <int R>
RBDGRAD_HD constexpr int tree_tile_rows(int b) {
  const int tiles = (b + R - 1) / R;
  return (b + tiles - 1) / tiles;
}
template <int R>
RBDGRAD_HD constexpr int tree_tiles(int b) {
  return (b + tree_tile_rows<R>(b) - 1) / tree_tile_rows<R>(b);
}

// The roots' blocks of the fixed tree: root r's block is [r, subtree_end(r)), packed in the
// matrices after the blocks of the roots before it (flat_model.hpp). On the device every call
// below folds to a constant where its arguments are (the loops unroll over the joints).
template <class Model>
struct TreeBlocks {
  using Tree = FixedTree<Model>;
  static constexpr int n = FixedSizes<Model>::nv;
  static_assert(n > 0 && Tree::known, "the tree's blocks need the tree at compile time");

  static RBDGRAD_HD bool is_root(const Model& m, int i) { return Tree::parent(m, i) < 0; }
  static RBDGRAD_HD int size(const Model& m, int root) { return Tree::subtree_end(m, root) - root; }
  // whether root leads its group: no root before it has a block of its size
  static RBDGRAD_HD bool leads(const Model& m, int root) {
    bool first = true;
    RBDGRAD_TREE_UNROLL
    for (int r = 0; r < n; ++r)
      if (r < root && is_root(m, r) && size(m, r) == size(m, root)) first = false;
    return first;
  }
  // the blocks of b joints
  static RBDGRAD_HD int count(const Model& m, int b) {
    int c = 0;
    RBDGRAD_TREE_UNROLL
    for (int r = 0; r < n; ++r) c += is_root(m, r) && size(m, r) == b ? 1 : 0;
    return c;
  }
  // the k-th block of b joints: its first joint and where it starts in the packed matrices
  static RBDGRAD_HD void block(const Model& m, int b, int k, int& first, int& packed) {
    int found = 0, at = 0;
    first = packed = 0;
    RBDGRAD_TREE_UNROLL
    for (int r = 0; r < n; ++r) {
      if (!is_root(m, r)) continue;
      if (size(m, r) == b) {
        if (found == k) first = r, packed = at;
        ++found;
      }
      at += size(m, r) * size(m, r);
    }
  }
  static RBDGRAD_HD int roots(const Model& m) {
    int c = 0;
    RBDGRAD_TREE_UNROLL
    for (int r = 0; r < n; ++r) c += is_root(m, r) ? 1 : 0;
    return c;
  }
};

// The items of a pass of `per_row ? rows : tiles` of the blocks: for each block size (in the
// order of the first root of that size), per block b rows, or tree_tiles(b) tiles of b columns
// each (tiles of kTreeTileRowsOf<Model> rows at most); each size's items rounded up to whole warps.
template <class Model>
RBDGRAD_HD int tree_block_items(const Model& m, bool per_row) {
  using Blocks = TreeBlocks<Model>;
  int items = 0;
  RBDGRAD_TREE_UNROLL
  for (int root = 0; root < Blocks::n; ++root) {
    if (!Blocks::is_root(m, root) || !Blocks::leads(m, root)) continue;
    const int b = Blocks::size(m, root);
    items += whole_warps(Blocks::count(m, b) * (per_row ? b : b * tree_tiles<kTreeTileRowsOf<Model>>(b)));
  }
  return items;
}

// Item t of tree_block_items(m, per_row): f(first, b, packed, x, col) for the block of b joints
// from `first`, packed at `packed`, and its row x (per_row; col 0) or tile x and column col (both
// within the block). Nothing for the items that round a size's up to whole warps.
template <class Model, class F>
RBDGRAD_HD void tree_block_item(const Model& m, int t, bool per_row, F&& f) {
  using Blocks = TreeBlocks<Model>;
  int base = 0;
  RBDGRAD_TREE_UNROLL
  for (int root = 0; root < Blocks::n; ++root) {
    if (!Blocks::is_root(m, root) || !Blocks::leads(m, root)) continue;
    const int b = Blocks::size(m, root), blocks = Blocks::count(m, b);
    const int per_block = per_row ? b : b * tree_tiles<kTreeTileRowsOf<Model>>(b);
    if (t >= base && t < base + blocks * per_block) {
      const int local = t - base, k = blocks > 1 ? local / per_block : 0, x = local - k * per_block;
      int first, packed;
      Blocks::block(m, b, k, first, packed);
      if (per_row) {
        f(first, b, packed, x, 0);
      } else {
        const int tile = x / b;
        f(first, b, packed, tile, x - tile * b);
      }
    }
    base += whole_warps(blocks * per_block);
  }
}

// sink(i, j, sum over r of a(i, r) d(r, j)) for the rows i of `tile` within the block (a and d
// b x b, row-major): the tile's rows share each load of d's column j, their sums independent
// chains; a's rows two entries a load where `pairs` (a 2-scalar aligned, b even). Tiles of R rows
// at most, as tree_block_item's (kTreeTileRowsOf<Model>).
template <int R, class S, class Sink>
RBDGRAD_HD void tree_tile_product(const S* a, const S* d, int b, int tile, int col, bool pairs, Sink&& sink) {
  const int rows_per_tile = tree_tile_rows<R>(b), row0 = tile * rows_per_tile;
  const bool whole = b % rows_per_tile == 0;  // every tile full: no row to clamp
  const S* rows[R];
  S s[R];
  RBDGRAD_TREE_UNROLL
  for (int k = 0; k < R; ++k) {
    const int i = row0 + k;
    // a row past the block (the last tile's) reads the block's last again, and is not written
    rows[k] = a + (whole || i < b ? i : b - 1) * b;
    s[k] = S(0);
  }
  const S* const dc = d + col;
  if (pairs) {
    RBDGRAD_TREE_UNROLL
    for (int r = 0; r < b; r += 2) {
      const S x0 = dc[r * b], x1 = dc[(r + 1) * b];
      RBDGRAD_TREE_UNROLL
      for (int k = 0; k < R; ++k) {
        if (k >= rows_per_tile) break;
        S a0, a1;
        load_pair(rows[k] + r, a0, a1);
        s[k] += a0 * x0;
        s[k] += a1 * x1;
      }
    }
  } else {
    RBDGRAD_TREE_UNROLL
    for (int r = 0; r < b; ++r) {
      const S x = dc[r * b];
      RBDGRAD_TREE_UNROLL
      for (int k = 0; k < R; ++k) {
        if (k >= rows_per_tile) break;
        s[k] += rows[k][r] * x;
      }
    }
  }
  RBDGRAD_TREE_UNROLL
  for (int k = 0; k < R; ++k)
    if (k < rows_per_tile && (whole || row0 + k < b)) sink(row0 + k, col, s[k]);
}

// the sum over r of a_row(r) x(r), r < b: a_row two entries a load where `pairs` (a_row 2-scalar
// aligned, b even)
template <class S>
RBDGRAD_HD S tree_row_product(const S* a_row, const S* x, int b, bool pairs) {
  S s = S(0);
  if (pairs) {
    RBDGRAD_TREE_UNROLL
    for (int r = 0; r < b; r += 2) {
      S a0, a1;
      load_pair(a_row + r, a0, a1);
      s += a0 * x[r];
      s += a1 * x[r + 1];
    }
  } else {
    RBDGRAD_TREE_UNROLL
    for (int r = 0; r < b; ++r) s += a_row[r] * x[r];
  }
  return s;
}

// The entries of an n x n matrix between the blocks (zero where M^-1 and d tau/d u are block
// diagonal): a warp's 32 items, item `lane` zero(i, j) for its columns j = lane, lane + 32, ...
// and each row i outside j's block. Nothing where the tree has one root.
template <class Model>
RBDGRAD_HD int tree_zero_items(const Model& m) {
  return TreeBlocks<Model>::roots(m) > 1 ? 32 : 0;
}
template <class Model, class F>
RBDGRAD_HD void tree_zero_entries(const Model& m, int lane, F&& zero) {
  using Blocks = TreeBlocks<Model>;
  constexpr int n = Blocks::n;
  RBDGRAD_TREE_UNROLL
  for (int root = 0; root < n; ++root) {
    if (!Blocks::is_root(m, root)) continue;
    const int end = root + Blocks::size(m, root);
    RBDGRAD_TREE_UNROLL
    for (int chunk = 0; chunk < (n + 31) / 32; ++chunk) {
      const int j = lane + 32 * chunk;
      if (j < n && (j < root || j >= end)) {
        RBDGRAD_TREE_UNROLL
        for (int i = root; i < end; ++i) zero(i, j);
      }
    }
  }
}

}  // namespace rbdgrad::cuda
