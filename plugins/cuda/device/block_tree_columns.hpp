// M^-1's columns (block_mass_inverse.hpp: inverse_column) by a tree fixed at compile time (the lean
// block kernel compiled for one robot, model_view.hpp: TreeModelView, with M^-1 by the tree's
// chains, block_tree_chains.hpp). The generic column walks up its joint's ancestors by the parents
// read from shared memory, each step's joint known only after the load before it, then down its
// block, reading at run time where each joint's subtree ends and where a branch starts. Here a
// lane's column takes its block's code: the blocks of one shape (the same size and parents, a
// humanoid's two legs) share it. Up, the column's ancestors are a bit mask of the block's joints
// (from constants), each step's joint the mask's highest bit: no load waits on another. Down, a
// segment of joints with one child each at a time, its bounds, where its joints' subtrees end
// and, where a branch starts, its parent's ancestors all constants; the lanes of a block read the
// same joint's S, U and pivot at once (broadcasts). The operations are inverse_column's in its
// order, so the columns are the same bits (block_tree_columns_test.cpp).
// On by default with the chains (the plugin option block_tree_columns; TreeConstants' columns, the
// build's tree_columns, kernel_source.hpp): talos_reduced's kernel at 65536 states 0.2-0.3% (f64)
// and 0.6-0.7% (f32 batches) faster with it over the products' tiles of 5 rows (runs 154 and 158,
// H100, docs/benchmarks/cuda.md). NVRTC: talos_reduced's lean build with it and tiles of 4
// spilled 12 bytes (f64; 8 for f32 batches) at its 64 registers; with the tiles of 5
// (kTreeTileRows) it spills none.
#pragma once

#include "block_mass_inverse.hpp"
#include "block_tree_products.hpp"  // RBDGRAD_TREE_UNROLL
#include "scalar_pairs.hpp"

namespace rbdgrad::cuda {

// The roots' blocks of an N-joint tree and their shapes: block k is [first[k], first[k] + size[k]),
// in the joints' order, and runs the code of block shape[k], the first of its size and parents.
// Each joint's parent and subtree end relative to its block's first joint. Built at compile time
// where the tree is constexpr (tree_mass_inverse), so that every read of it folds to a constant.
template <int N>
struct TreeColumns {
  int blocks = 0;
  int first[N] = {};
  int size[N] = {};
  int shape[N] = {};
  int parent[N] = {};  // -1 at a root
  int end[N] = {};
  // the tree's runs [top, bottom] (in the joints' order) of joints with one child each, the next,
  // but the bottom: within one, every joint's subtree ends where the bottom's does (segment_end,
  // relative as end); the top's parent (relative as parent). (Kept a segment, not read through
  // the joint: a table read at an index read from the table kept the table on the stack.)
  int segments = 0;
  int segment_top[N] = {};
  int segment_bottom[N] = {};
  int segment_end[N] = {};
  int segment_parent[N] = {};
};

// parent(i) for i < N (-1 at a root; depth-first order, a parent before its children)
template <int N, class Parent>
RBDGRAD_HD constexpr TreeColumns<N> tree_columns(const Parent& parent) {
  TreeColumns<N> t;
  int root_of[N] = {};
  for (int i = 0; i < N; ++i) {
    const int p = parent(i);
    if (p < 0) {
      t.first[t.blocks] = i;
      ++t.blocks;
    }
    root_of[i] = t.first[t.blocks - 1];
    t.parent[i] = p < 0 ? -1 : p - root_of[i];
    t.end[i] = i - root_of[i] + 1;
  }
  // a subtree's end: past its last descendant (children after their parents)
  for (int i = N - 1; i >= 0; --i)
    if (parent(i) >= 0 && t.end[i] > t.end[parent(i)]) t.end[parent(i)] = t.end[i];
  int children[N] = {};
  for (int i = 0; i < N; ++i)
    if (parent(i) >= 0) ++children[parent(i)];
  for (int i = 0; i < N; ++i) {
    if (i == 0 || children[i - 1] != 1 || parent(i) != i - 1) {
      t.segment_top[t.segments] = i;
      ++t.segments;
    }
    t.segment_bottom[t.segments - 1] = i;
  }
  for (int q = 0; q < t.segments; ++q) {
    t.segment_end[q] = t.end[t.segment_bottom[q]];
    t.segment_parent[q] = t.parent[t.segment_top[q]];
  }
  for (int k = 0; k < t.blocks; ++k) {
    t.size[k] = (k + 1 < t.blocks ? t.first[k + 1] : N) - t.first[k];
    t.shape[k] = k;
    for (int q = k - 1; q >= 0; --q) {
      if (t.size[q] != t.size[k]) continue;
      bool same = true;
      for (int r = 0; r < t.size[k]; ++r) same = same && t.parent[t.first[q] + r] == t.parent[t.first[k] + r];
      if (same) t.shape[k] = q;
    }
  }
  return t;
}

// the highest set bit of x != 0
RBDGRAD_HD int highest_bit(unsigned long long x) {
#if defined(__CUDA_ARCH__)
  return 63 - __clzll(static_cast<long long>(x));
#else
  return 63 - __builtin_clzll(x);
#endif
}

// The 6-vector steps of the column walks with each pair of p's loaded just before its use (a
// thread holds two of p's entries, not six), in inverse_column's order of operations: s - p . F,
// F + p y, and p . a.
template <bool kPairs, class S>
RBDGRAD_HD S minus_dot6(S s, const S* p, const S (&F)[6]) {
  for (int c = 0; c < 6; c += 2) {
    S p0, p1;
    load_pair_or_two<kPairs>(p + c, p0, p1);
    s -= p0 * F[c];
    s -= p1 * F[c + 1];
  }
  return s;
}
template <bool kPairs, class S>
RBDGRAD_HD void add_scaled6(S (&F)[6], const S* p, S y) {
  for (int c = 0; c < 6; c += 2) {
    S p0, p1;
    load_pair_or_two<kPairs>(p + c, p0, p1);
    F[c] += p0 * y;
    F[c + 1] += p1 * y;
  }
}
template <bool kPairs, class S>
RBDGRAD_HD S dot6_loaded(const S* p, const S (&a)[6]) {
  S s = S(0);
  for (int c = 0; c < 6; c += 2) {
    S p0, p1;
    load_pair_or_two<kPairs>(p + c, p0, p1);
    s = c == 0 ? p0 * a[0] : s + p0 * a[c];
    s += p1 * a[c + 1];
  }
  return s;
}

// Column jj (within the block) of M^-1 for a block of the shape of block k: its axes, U and
// pivots in `axis`, `U`, `pivots` as block k's are in the tree's (joint i of k's block at i: the
// tree's arrays, shifted for another block of k's shape), entry (r, jj) at column[r * stride].
// inverse_column's operations, in its order. (The loops run over the tree's joints, so that every
// read of the table is within it: one past it, where a loop over the block went on, kept the table
// on the stack.)
template <bool kPairs, int kSegments, class S, int N>
RBDGRAD_HD void tree_block_column(const TreeColumns<N>& t, int k, const S* axis, const S* U, const S* pivots,
                                  S* column, int stride, int jj) {
  const int root = t.first[k], b = t.size[k];
  // joint i of k's block (r = i - root) ancestor-or-self of the block's joint j
  const auto in_block = [&](int i) { return i >= root && i < root + b; };
  const auto contains = [&](int i, int j) { return i - root <= j && j < t.end[i]; };
  // Up: the part D_r^-1 (delta_r,jj - S_r . F) of qdd_r along jj's ancestors-or-self, nearest first:
  // the ancestors as a mask of the block's joints, each step's joint its highest bit. (Unrolled
  // over the block's joints instead, each step predicated, it spilled 44 bytes or more at
  // talos_reduced's 64 registers.)
  unsigned long long ancestors = 0;
  RBDGRAD_TREE_UNROLL
  for (int i = 0; i < N; ++i)
    if (in_block(i) && contains(i, jj)) ancestors |= 1ull << (i - root);
  S F[6];
  for (int c = 0; c < 6; ++c) F[c] = S(0);
  S delta = S(1);
  while (ancestors != 0) {
    const int r = highest_bit(ancestors), i = root + r;
    ancestors ^= 1ull << r;
    const S x = minus_dot6<kPairs>(delta, axis + 6 * i, F) * pivots[i];
    column[r * stride] = x;
    add_scaled6<kPairs>(F, U + 6 * i, x);
    delta = S(0);
  }
  // Down the block in depth-first order: qdd_r = that part - D_r^-1 U_r . a_parent, a_r = a_parent +
  // S_r qdd_r; where a branch starts, a_parent the sum of S_h qdd_h over its parent's
  // ancestors-or-self. A run of the tree's segments at a time, a loop over its joints (not
  // unrolled, as the walk up), whose subtrees end alike.
  S a[6];
  for (int c = 0; c < 6; ++c) a[c] = S(0);
  RBDGRAD_TREE_UNROLL
  for (int q = 0; q < kSegments; ++q) {
    if (q >= t.segments) break;
    const int top = t.segment_top[q], bottom = t.segment_bottom[q];
    if (!in_block(top)) continue;
    const int p = t.segment_parent[q];
    if (top > root && p != top - root - 1) {
      for (int c = 0; c < 6; ++c) a[c] = S(0);
      RBDGRAD_TREE_UNROLL
      for (int h = 0; h < N; ++h) {
        if (!in_block(h) || h - root > p || !contains(h, p)) continue;
        add_scaled6<kPairs>(a, axis + 6 * h, column[(h - root) * stride]);
      }
    }
    const int end = t.segment_end[q];
#if defined(__CUDA_ARCH__)
#pragma unroll 1
#endif
    for (int i = top; i <= bottom; ++i) {
      const int r = i - root;
      const S s = dot6_loaded<kPairs>(U + 6 * i, a);
      const S part = r <= jj && jj < end ? column[r * stride] : S(0);
      const S x = part - s * pivots[i];
      column[r * stride] = x;
      add_scaled6<kPairs>(a, axis + 6 * i, x);
    }
  }
}

// Column j of M^-1 into inverse, as inverse_column (entry (i, j) at row_at(i) + j; row_at linear
// within a block, its rows a stride apart, as the packed and the dense layouts are), by the code
// of its block's shape. kBlocks, kSegments: t.blocks and t.segments, or more (a table built at run
// time): constants, so that the loops over them unroll before the table is read.
template <bool kPairs, int kBlocks, int kSegments, class S, int N, class RowAt>
RBDGRAD_HD void tree_inverse_column(const TreeColumns<N>& t, const S* axis, const S* IA_S, const S* pivots, S* inverse,
                                    const RowAt& row_at, int j) {
  RBDGRAD_TREE_UNROLL
  for (int k = 0; k < kBlocks; ++k) {
    if (k >= t.blocks) break;
    if (t.shape[k] != k) continue;
    // j's block if it is of k's shape
    int first = -1;
    RBDGRAD_TREE_UNROLL
    for (int q = 0; q < kBlocks; ++q) {
      if (q >= t.blocks) break;
      if (t.shape[q] == k && j >= t.first[q] && j < t.first[q] + t.size[q]) first = t.first[q];
    }
    if (first < 0) continue;
    const int row = row_at(first), stride = t.size[k] > 1 ? row_at(first + 1) - row : 0;
    // (another block of k's shape: the arrays shifted to it, so that k's code takes them; for a
    // shape of one block, no shift, and every address a constant offset)
    const int shift = first - t.first[k];
    tree_block_column<kPairs, kSegments>(t, k, axis + 6 * shift, IA_S + 6 * shift, pivots + shift, inverse + row + j,
                                         stride, j - first);
    // (no return: a loop that may leave early is not unrolled, and the table goes to the stack)
  }
}

}  // namespace rbdgrad::cuda
