// M^-1 without M (block_mass_inverse.hpp) by the chains of a tree fixed at compile time (the lean
// block kernel compiled for one robot, model_view.hpp: TreeModelView).
//
// The generic passes find U_i = IA_i S_i a tree level a pass, each entry a sum over all of the
// joint's descendants: talos_reduced's 10 levels are 10 synced passes of one busy warp, 125
// descendant terms a state, each read from shared memory by six lanes (run 141: 4,677 warp
// instructions and 1,601 wavefronts a state with d tau/d qd's rows), then M^-1's columns in a
// pass of their own. Here the tree is cut into chains: a chain runs up from a joint with no child
// or with several (its bottom) while each joint is its parent's only child (in depth-first order,
// [top, bottom] is a range). Six lanes walk a chain up, lane e taking row e of
//   P = the sum over the joints k below of U_k U_k^T / D_k,
// so that U_i = Ic_i S_i - P S_i and D_i = S_i . U_i, then P += U_i U_i^T / D_i: the articulated
// inertia IA_i = Ic_i - P, never formed, each step a fixed amount of work. P's rows wait in M^-1's
// matrix, which the columns write only after (not in registers: with them, ptxas spilled
// talos_reduced's kernel at its 64 registers). A chain whose bottom has several children starts
// from the sum of their chains' P, which they leave there too; it runs in a later round. Every
// round's chains fit one warp (five chains of six lanes); in a group of whole warps the first
// walks them, a warp sync a step (a step finds D_i and P from U_i, then its lane's entry of the
// next joint's U from the P it holds, not read back from the scratch), then finds M^-1's
// columns (inverse_column, or block_tree_columns.hpp's), a thread a column, while the other
// warps run the caller's work
// (d tau/d qd's rows): one synced pass for the caller, where the generic form takes a pass a level
// and one for the columns.
// The sums are those of the generic passes in another order, so the results match the core as
// closely, not bit for bit (the block state tests' FixedTreeMatchesTheCore).
#pragma once

#include "block_tree_columns.hpp"
#include "block_tree_products.hpp"  // RBDGRAD_TREE_UNROLL
#include "model_view.hpp"
#include "scalar_pairs.hpp"
#include "thread_group.hpp"

namespace rbdgrad::cuda {

// a lane an entry of U_i; chains a warp
inline constexpr int kChainLanes = 6;
inline constexpr int kChainsPerWarp = 32 / kChainLanes;
// scalars of M^-1's matrix that a chain's P takes (its rows, 6 x 6) until the columns are found
inline constexpr int kChainScratch = 36;

// The chains of an N-joint tree by round: a chain's round is 0 if its bottom has no child, else one
// more than the largest of its bottom's children's chains'. A round's chains in the order of their
// bottoms.
template <int N>
struct TreeChains {
  bool fits = true;  // every round's chains on one warp, every chain a range [top, bottom]
  int rounds = 0;
  int count[N] = {};    // chains in round r
  int longest[N] = {};  // joints of round r's longest chain
  int bottom[N][kChainsPerWarp] = {};
  int length[N][kChainsPerWarp] = {};
  int top_slot[N][kChainsPerWarp] = {};  // where the chain leaves its P for its top's parent, -1 at a root
  int slots = 0;                        // chains whose top has a parent
  int slot_parent[N] = {};
};

// parent(i) for i < N (-1 at a root; depth-first order, a parent before its children). constexpr:
// a kernel compiled for a robot builds the table at compile time (ConstantParent below).
template <int N, class Parent>
RBDGRAD_HD constexpr TreeChains<N> tree_chains(const Parent& parent) {
  TreeChains<N> t;
  int children[N] = {}, round_of[N] = {}, slot_of[N] = {};
  for (int i = 0; i < N; ++i) {
    slot_of[i] = -1;
    if (parent(i) >= 0) ++children[parent(i)];
  }
  for (int i = 0; i < N; ++i) {
    // a joint with one child is followed by it (else the chain is not a range)
    if (children[i] == 1 && (i + 1 >= N || parent(i + 1) != i)) t.fits = false;
    const int p = parent(i);
    if (p >= 0 && children[p] >= 2) {
      slot_of[i] = t.slots;
      t.slot_parent[t.slots] = p;
      ++t.slots;
    }
  }
  if (!t.fits) return t;
  // the rounds, the last bottoms first (a bottom's children's chains come after it)
  for (int b = N - 1; b >= 0; --b) {
    if (children[b] == 1) continue;
    int r = 0;
    for (int c = b + 1; c < N; ++c) {
      if (parent(c) != b) continue;
      int cb = c;
      while (children[cb] == 1) ++cb;
      if (round_of[cb] + 1 > r) r = round_of[cb] + 1;
    }
    round_of[b] = r;
  }
  for (int b = 0; b < N; ++b) {
    if (children[b] == 1) continue;
    int top = b;
    while (parent(top) >= 0 && children[parent(top)] == 1) top = parent(top);
    const int r = round_of[b], k = t.count[r]++;
    if (r + 1 > t.rounds) t.rounds = r + 1;
    if (k >= kChainsPerWarp) {
      t.fits = false;
      continue;
    }
    t.bottom[r][k] = b;
    t.length[r][k] = b - top + 1;
    t.top_slot[r][k] = slot_of[top];
    if (b - top + 1 > t.longest[r]) t.longest[r] = b - top + 1;
  }
  return t;
}

// A joint's parent as tree_chains takes it: a constant expression where the model type's tree is
// constexpr (the kernel compiled for a robot, TreeModelView), else from the view (the host tests'
// model types).
template <class Model>
struct ConstantParent {
  RBDGRAD_HD constexpr int operator()(int i) const { return TreeConstants<Model>::parent(i); }
};
template <class Model>
struct ViewParent {
  const Model& m;
  RBDGRAD_HD int operator()(int i) const { return FixedTree<Model>::parent(m, i); }
};

// Whether tree_mass_inverse takes m's tree: its chains fit, and their P (a warp's chains' and the
// slots') in M^-1's `matrix_scalars`.
template <class Model>
RBDGRAD_HD bool tree_chains_fit(const Model& m, int matrix_scalars) {
  constexpr int n = FixedSizes<Model>::nv;
  static_assert(n > 0 && FixedTree<Model>::known, "the tree's chains need the tree at compile time");
  const auto fit = [&](const TreeChains<n>& chains) {
    return chains.fits && kChainScratch * (chains.slots + kChainsPerWarp) <= matrix_scalars;
  };
  if constexpr (TreeConstants<Model>::known) {
    constexpr TreeChains<n> chains = tree_chains<n>(ConstantParent<Model>{});
    return fit(chains);
  } else {
    return fit(tree_chains<n>(ViewParent<Model>{m}));
  }
}

// One lane's chain in a round, and its entry e. What a lane carries from step to step (row e of P)
// is in the scratch, not in registers (held there, with S_i and U_i, it made ptxas spill
// talos_reduced's kernel at its 64 registers), so that a thread may take several lanes.
struct ChainLane {
  int bottom = 0, length = 0, top_slot = -1, entry = 0, chain = 0;
  bool active = false;
};
template <int N>
RBDGRAD_HD ChainLane chain_lane(const TreeChains<N>& t, int round, int lane) {
  ChainLane c;
  const int k = lane / kChainLanes;
  c.entry = lane - kChainLanes * k;
  c.chain = k;
  RBDGRAD_TREE_UNROLL
  for (int kk = 0; kk < kChainsPerWarp; ++kk) {
    if (kk == k && kk < t.count[round]) {
      c.bottom = t.bottom[round][kk];
      c.length = t.length[round][kk];
      c.top_slot = t.top_slot[round][kk];
      c.active = true;
    }
  }
  return c;
}

// Row e of the lane's P in the scratch: the chains' P after the slots
template <class S, int N>
RBDGRAD_HD S* chain_row(const TreeChains<N>& t, const ChainLane& c, S* scratch) {
  return scratch + kChainScratch * (t.slots + c.chain) + 6 * c.entry;
}

// U_i's entry e = Ic_i S_i - P S_i, P's row e given (a lane's, in registers: the step that found
// it, so that it is not read back from the scratch)
template <bool kPairs, class S>
RBDGRAD_HD S chain_u_entry(const S* axis_i, S Ic_S_entry, const S (&P)[6]) {
  S ps = S(0);
  for (int k = 0; k < 6; k += 2) {
    S s0, s1;
    load_pair_or_two<kPairs>(axis_i + k, s0, s1);
    ps = k == 0 ? P[k] * s0 : ps + P[k] * s0;
    ps += P[k + 1] * s1;
  }
  return Ic_S_entry - ps;
}

// P at the chain's bottom: zero, or the sum of its children's chains' (round > 0); and the
// chain's first step's entry of U (its bottom's) from it
// (kSlots: t.slots, or more: a constant, so that the loop unrolls before the table is read)
template <bool kPairs, int kSlots, class S, int N>
RBDGRAD_HD void chain_start(const TreeChains<N>& t, int round, const ChainLane& c, const S* axis, const S* Ic_S,
                            S* IA_S, S* scratch) {
  if (!c.active) return;
  S P[6];
  for (int k = 0; k < 6; ++k) P[k] = S(0);
  if (round > 0) {
    RBDGRAD_TREE_UNROLL
    for (int slot = 0; slot < kSlots; ++slot) {
      if (slot >= t.slots || t.slot_parent[slot] != c.bottom) continue;
      const S* row = scratch + kChainScratch * slot + 6 * c.entry;
      for (int k = 0; k < 6; ++k) P[k] += row[k];
    }
  }
  S* const row = chain_row(t, c, scratch);
  for (int k = 0; k < 6; ++k) row[k] = P[k];
  const int i = c.bottom;
  IA_S[6 * i + c.entry] = chain_u_entry<kPairs>(axis + 6 * i, Ic_S[6 * i + c.entry], P);
}

// Step s of the chain (its joint i = bottom - s), after the warp's sync (U_i whole): D_i = S_i .
// U_i and its pivot (as articulated_axes keeps it: 1/D_i, or D_i where that is not positive,
// flagged), P += U_i U_i^T / D_i; then the next step's entry of U (U_(i-1) = Ic S - P S) from the
// P just found, or at the chain's top, P for its parent's chain
template <bool kPairs, class S, int N>
RBDGRAD_HD void chain_step(const TreeChains<N>& t, const ChainLane& c, int s, const S* axis, const S* Ic_S, S* IA_S,
                           S* pivots, std::uint32_t* failed, S* scratch) {
  if (!c.active || s >= c.length) return;
  const int i = c.bottom - s;
  const S* const Ui = IA_S + 6 * i;
  S d = S(0);
  for (int k = 0; k < 6; k += 2) {
    S u0, u1, s0, s1;
    load_pair_or_two<kPairs>(Ui + k, u0, u1);
    load_pair_or_two<kPairs>(axis + 6 * i + k, s0, s1);
    d = k == 0 ? s0 * u0 : d + s0 * u0;
    d += s1 * u1;
  }
  const bool positive = is_finite(d) && d > S(0);
  const S pivot = positive ? S(1) / d : d;
  if (c.entry == 0) {
    pivots[i] = pivot;
    if (!positive) group_max(failed, static_cast<std::uint32_t>(i) + 1u);
  }
  // (U_i read again: held through the division, it made ptxas spill at 64 registers)
  const S scaled = Ui[c.entry] * pivot;
  S* const P = chain_row(t, c, scratch);
  const bool top = s == c.length - 1;
  // at the chain's top, P for its parent's chain (in its slot)
  S* const to = top && c.top_slot >= 0 ? scratch + kChainScratch * c.top_slot + 6 * c.entry : P;
  // (the next entry's product summed as P's row is stored: held as a row, it made ptxas spill)
  const S* const next_axis = axis + 6 * (top ? i : i - 1);
  S ps = S(0);
  for (int k = 0; k < 6; k += 2) {
    S u0, u1, p0, p1, s0, s1;
    load_pair_or_two<kPairs>(Ui + k, u0, u1);
    load_pair_or_two<kPairs>(P + k, p0, p1);
    p0 += scaled * u0;
    p1 += scaled * u1;
    store_pair_or_two<kPairs>(to + k, p0, p1);
    load_pair_or_two<kPairs>(next_axis + k, s0, s1);
    ps = k == 0 ? p0 * s0 : ps + p0 * s0;
    ps += p1 * s1;
  }
  if (!top) IA_S[6 * (i - 1) + c.entry] = Ic_S[6 * (i - 1) + c.entry] - ps;
}

// Whether a group's chains take its first warp and its other threads the caller's extra work: a
// group of whole warps, two at least. Otherwise every thread takes part in every step, then in the
// extra work.
RBDGRAD_HD bool tree_chains_split(const ThreadGroup& g) { return g.size % 32 == 0 && g.size >= 64; }

// The steps of every round on the group t (lanes as items; synced as a warp where t is one), then
// M^-1's columns: inverse_column's, or by the tree's blocks where the model type says so
// (TreeConstants' columns; block_tree_columns.hpp, by the table `columns`). kRounds, kSlots,
// kBlocks, kSegments: chains.rounds, chains.slots, columns.blocks and columns.segments, or more
// (the host tests' tables, built at run time): constants, so that the loops over them unroll
// before the table is read, and every read of it folds to a constant (else ptxas keeps the table
// on the stack).
template <bool kPairs, int kRounds, int kSlots, int kBlocks, int kSegments, class S, class Model, int N, class RowAt>
RBDGRAD_HD void tree_chains_walk(const TreeChains<N>& chains, const TreeColumns<N>& columns, const Model& m,
                                 const S* axis, const S* Ic_S, S* IA_S, S* pivots, std::uint32_t* failed, S* inverse,
                                 const RowAt& row_at, const ThreadGroup& t) {
  RBDGRAD_TREE_UNROLL
  for (int round = 0; round < kRounds; ++round) {
    if (round >= chains.rounds) break;
    // (a lane's P is its own until its chain's top: no sync before a step's first entry of U)
    t.for_each(32, [&](int lane) {
      chain_start<kPairs, kSlots>(chains, round, chain_lane(chains, round, lane), axis, Ic_S, IA_S, inverse);
    });
#if defined(__CUDA_ARCH__)
#pragma unroll 1
#endif
    for (int s = 0; s < chains.longest[round]; ++s) {
      t.sync();
      t.for_each(32, [&](int lane) {
        chain_step<kPairs>(chains, chain_lane(chains, round, lane), s, axis, Ic_S, IA_S, pivots, failed, inverse);
      });
    }
    t.sync();
  }
  t.for_each(N, [&](int j) {
    if constexpr (TreeConstants<Model>::columns)
      tree_inverse_column<kPairs, kBlocks, kSegments>(columns, axis, IA_S, pivots, inverse, row_at, j);
    else
      inverse_column<kPairs>(m, axis, IA_S, pivots, inverse, row_at, j);
  });
}

// U = IA S and the pivots into IA_S and pivots (as articulated_axes), then M^-1 into inverse (as
// inverse_column for every column; its rows at row_at); extra(e) for e in [0, extra_items), work
// independent of this: on the group's other warps where tree_chains_split(g), else after it. Needs
// tree_chains_fit(m, M^-1's scalars); the caller syncs after.
template <bool kPairs, int kRounds, int kSlots, int kBlocks, int kSegments, class S, class Model, int N, class RowAt,
          class Extra>
RBDGRAD_HD void tree_chains_mass_inverse(const TreeChains<N>& chains, const TreeColumns<N>& columns, const Model& m,
                                         const S* axis, const S* Ic_S, S* IA_S, S* pivots, std::uint32_t* failed,
                                         S* inverse, const RowAt& row_at, const ThreadGroup& g, int extra_items,
                                         const Extra& extra) {
#if defined(__CUDA_ARCH__)
  if (tree_chains_split(g)) {
    if (g.rank >= 32) {
      for (int e = g.rank - 32; e < extra_items; e += g.size - 32) extra(e);
      return;
    }
    ThreadGroup warp = g;
    warp.size = 32;
    warp.warp_sync = true;
    tree_chains_walk<kPairs, kRounds, kSlots, kBlocks, kSegments>(chains, columns, m, axis, Ic_S, IA_S, pivots, failed,
                                                                  inverse, row_at, warp);
    return;
  }
#endif
#if defined(RBDGRAD_SHARED_TRACE) && !defined(__CUDA_ARCH__)
  // (a host tool tracing the GPU's threads: the split as the GPU runs it)
  if (g.trace != nullptr && tree_chains_split(g)) {
    ThreadGroup warp = g, others = g;
    warp.size = 32;
    warp.warp_sync = true;
    others.first_rank = 32;
    others.size = g.size - 32;
    tree_chains_walk<kPairs, kRounds, kSlots, kBlocks, kSegments>(chains, columns, m, axis, Ic_S, IA_S, pivots, failed,
                                                                  inverse, row_at, warp);
    others.for_each(extra_items, extra);
    return;
  }
#endif
  tree_chains_walk<kPairs, kRounds, kSlots, kBlocks, kSegments>(chains, columns, m, axis, Ic_S, IA_S, pivots, failed,
                                                                inverse, row_at, g);
  g.for_each(extra_items, extra);
}

// The same with m's chains (built at compile time where the tree is constexpr)
template <bool kPairs, class S, class Model, class RowAt, class Extra>
RBDGRAD_HD void tree_mass_inverse(const Model& m, const S* axis, const S* Ic_S, S* IA_S, S* pivots,
                                  std::uint32_t* failed, S* inverse, const RowAt& row_at, const ThreadGroup& g,
                                  int extra_items, const Extra& extra) {
  constexpr int n = FixedSizes<Model>::nv;
  if constexpr (TreeConstants<Model>::known) {
    constexpr TreeChains<n> chains = tree_chains<n>(ConstantParent<Model>{});
    // (the columns' table only where they take it: the kernel without it is the one timed)
    constexpr TreeColumns<n> columns =
        TreeConstants<Model>::columns ? tree_columns<n>(ConstantParent<Model>{}) : TreeColumns<n>{};
    tree_chains_mass_inverse<kPairs, chains.rounds, chains.slots, columns.blocks, columns.segments>(
        chains, columns, m, axis, Ic_S, IA_S, pivots, failed, inverse, row_at, g, extra_items, extra);
  } else {
    const TreeChains<n> chains = tree_chains<n>(ViewParent<Model>{m});
    const TreeColumns<n> columns = tree_columns<n>(ViewParent<Model>{m});
    tree_chains_mass_inverse<kPairs, n, n, n, n>(chains, columns, m, axis, Ic_S, IA_S, pivots, failed, inverse,
                                                 row_at, g, extra_items, extra);
  }
}

}  // namespace rbdgrad::cuda
