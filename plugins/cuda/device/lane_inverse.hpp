// M^-1 of one state by one warp, for the block kernel compiled for a robot of at most 32 joints
// whose roots' blocks have at most K joints each (block_fused_state.hpp, option
// block_lane_inverse). Lane j holds column j of its block in registers and the exchange steps go
// by shuffles: no sync of the state's group a step, where the group's steps take one each (about
// 1,450 cycles a step for talos_reduced, 39% of a state's chain: run 89). The other warps of the
// group meanwhile do the pass that the steps used to follow.
//
// The steps, their order and each entry's arithmetic are the group's: leaves first within each
// block, the blocks side by side, so that the pivots (the core's D[k]) and a failing state's joint
// are the same, and the results the same bits where the compiler contracts both alike (the host
// tests check the bits).
//
// Compiled as plain C++ (the host tests), one call runs all 32 lanes, each shuffle returning what
// it returns on the GPU (lanes_exchange_inverse says how).
#pragma once

#include "model_view.hpp"
#include "thread_group.hpp"

// loops over a column's registers unrolled, so that each register index is a constant (an index
// known only at run time would put the column in local memory)
#if defined(__CUDA_ARCH__)
#define RBDGRAD_LANE_UNROLL _Pragma("unroll")
#else
#define RBDGRAD_LANE_UNROLL
#endif

namespace rbdgrad::cuda {

inline constexpr int kWarpLanes = 32;

namespace lane_inverse {

// A lane's column: joint `joint` in the block [end - size, end); entry e of the lane's registers
// is row end - 1 - e, counted from the block's end, so that step s pivots on entry s in every
// block (every lane makes the same comparisons). A lane past the joints has size 0.
struct Column {
  int joint = 0, end = 0, size = 0;
};

template <class Model>
RBDGRAD_HD Column column_of(const Model& m, int lane) {
  Column c;
  c.joint = lane;
  if (lane < m.nv) {
    const int first = m.root_of[lane];
    c.end = m.subtree_end[first];
    c.size = c.end - first;
  }
  return c;
}

// Exchange step s of the lane's column. get(x, lane) is x of `lane` (a shuffle; each entry of the
// pivot's column is read before any lane replaces it). A block without a step s (smaller than
// s + 1) leaves its columns alone; its lanes still take part in the shuffles. s is known only at
// run time (the steps unrolled made talos_reduced's kernel 2.8 times the code, 349 KB of cubin):
// the column's entries are picked by comparisons, never by an index, which would put them in local
// memory.
// The lane whose joint is the step's pivot keeps it in own_pivot (each lane of a block is that
// lane once).
template <int K, class S, class Get>
RBDGRAD_HD void step(S (&col)[K], int s, const Column& c, Get get, S& own_pivot) {
  const int pv = c.end - 1 - s;
  const bool on_step = s < c.size;
  const int from = on_step ? pv : c.joint;  // the pivot's lane, or the lane itself
  S a_pj = col[0];  // the lane's entry in the pivot's row
  RBDGRAD_LANE_UNROLL
  for (int e = 1; e < K; ++e)
    if (e == s) a_pj = col[e];
  const S pivot = get(a_pj, from);  // the pivot lane's entry in its own row
  const bool pivot_lane = on_step && c.joint == pv;
  const S r = reciprocal(pivot);
  if (pivot_lane) own_pivot = pivot;
  RBDGRAD_LANE_UNROLL
  for (int e = 0; e < K; ++e) {
    const S a_ip = get(col[e], from);  // the pivot's column at this entry's row
    S x;
    if (e == s && pivot_lane) x = r;
    else if (e == s) x = -a_pj * r;
    else if (pivot_lane) x = a_ip * r;
    else x = col[e] - a_ip * r * a_pj;
    if (on_step) col[e] = x;
  }
}

}  // namespace lane_inverse

// M^-1 in place of M (entry (i, j) at row_at(i) + j, M block diagonal over the roots' blocks of at
// most K joints, nv <= 32) by the group's first warp; each block's pivots in `pivots`, the largest
// joint whose pivot is not positive (+1) in *failed_pivot (group_max). The group's threads are a
// whole number of warps. Only the first warp's threads call this on the GPU.
template <int K, class S, class Model, class RowAt>
RBDGRAD_HD void lanes_exchange_inverse(const Model& m, RowAt row_at, S* M, S* pivots, std::uint32_t* failed_pivot,
                                       int lane) {
  static_assert(K >= 1 && K <= kWarpLanes, "a block of at most 32 joints");
  auto load = [&](S (&col)[K], const lane_inverse::Column& c) {
    RBDGRAD_LANE_UNROLL
    for (int e = 0; e < K; ++e) col[e] = e < c.size ? M[row_at(c.end - 1 - e) + c.joint] : S(0);
  };
  // the column back into M, the lane's pivot kept and checked
  auto store = [&](const S (&col)[K], const lane_inverse::Column& c, S own_pivot) {
    RBDGRAD_LANE_UNROLL
    for (int e = 0; e < K; ++e)
      if (e < c.size) M[row_at(c.end - 1 - e) + c.joint] = col[e];
    if (c.size > 0) {
      pivots[c.joint] = own_pivot;
      if (!(is_finite(own_pivot) && own_pivot > S(0)))
        group_max(failed_pivot, static_cast<std::uint32_t>(c.joint) + 1u);
    }
  };
#if defined(__CUDA_ARCH__)
  const lane_inverse::Column c = lane_inverse::column_of(m, lane);
  S col[K], own_pivot = S(0);
  load(col, c);
  auto get = [](S x, int from) { return __shfl_sync(0xffffffffu, x, from); };
#pragma unroll 1
  for (int s = 0; s < K; ++s) lane_inverse::step<K>(col, s, c, get, own_pivot);
  store(col, c, own_pivot);
#else
  // Each lane's k-th shuffle of a step passes a value that depends on the lane's column as the step
  // began, never on what an earlier shuffle returned. So a step runs twice: once on copies to
  // record what each lane passes (returning its own values, its pivot set aside), then for real,
  // each shuffle returning what the lane it names passed at the same call.
  (void)lane;
  lane_inverse::Column c[kWarpLanes];
  S cols[kWarpLanes][K], passed[kWarpLanes][K + 1], own_pivot[kWarpLanes] = {};
  for (int l = 0; l < kWarpLanes; ++l) {
    c[l] = lane_inverse::column_of(m, l);
    load(cols[l], c[l]);
  }
  for (int s = 0; s < K; ++s) {
    for (int l = 0; l < kWarpLanes; ++l) {
      S copy[K];
      for (int e = 0; e < K; ++e) copy[e] = cols[l][e];
      int k = 0;
      auto record = [&](S x, int) { return passed[l][k++] = x; };
      S unused = S(0);
      lane_inverse::step<K>(copy, s, c[l], record, unused);
    }
    for (int l = 0; l < kWarpLanes; ++l) {
      int k = 0;
      auto shuffle = [&](S, int from) { return passed[from][k++]; };
      lane_inverse::step<K>(cols[l], s, c[l], shuffle, own_pivot[l]);
    }
  }
  for (int l = 0; l < kWarpLanes; ++l) store(cols[l], c[l], own_pivot[l]);
#endif
}

}  // namespace rbdgrad::cuda

#undef RBDGRAD_LANE_UNROLL
