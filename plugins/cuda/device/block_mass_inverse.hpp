// M^-1 in the block kernel (block_fused_state.hpp) without M: the articulated-body recursion in
// world axes about the world origin (the direct M^-1 of Carpentier and Mansard, 2018, in the
// world-frame form that Pinocchio's computeMinverse takes). In those axes nothing is transformed
// on the way up or down the tree: a pass a tree level for the articulated inertias' U = IA S and
// D, then one in which a thread carries a column of M^-1 as a 6-vector in registers along the
// tree (talos_reduced: 11 synced passes where M and its inversion by exchange steps took 22, one
// a joint of the largest block; 3.4% off the kernel at 65536 f64 states, 4.1% f32, runs 128-129).
#pragma once

#include "model_view.hpp"
#include "scalar_pairs.hpp"
#include "thread_group.hpp"

namespace rbdgrad::cuda {

// U_i = IA_i S_i and 1/D_i, D_i = S_i . U_i, of every joint, IA_i the articulated inertia of i's
// subtree. Unrolled, the recursion IA_i = I_i + sum over children c of IA_c - U_c U_c^T / D_c
// is IA_i = Ic_i - sum over i's descendants k of U_k U_k^T / D_k, so that
//   U_i = Ic_i S_i - sum over descendants k of U_k (U_k . S_i) / D_k
// from Ic S (the subtree sums' pass): a tree level at a time, deepest first (a descendant is one
// level down or more), a thread an entry of U_i, IA never formed. Each of a joint's six threads
// also finds D_i = S_i . Ic_i S_i - sum over descendants k of (U_k . S_i)^2 / D_k from the same
// terms (the same operations in each; the first keeps it), so that no thread holds all of U_i.
// D_i is the pivot of joint i in the core's factorization M = L^T D L (the Schur complement of its
// descendants' joints), so a state fails at the same joint for the same reason: pivots[i] holds
// 1/D_i, or D_i where that is not positive, flagged in *failed (group_max: the core checks the last
// joint first, so the largest failing joint is the one reported).
// The first pass (the deepest level's) also runs extra(t) for t in [0, extra_items): work of the
// group's that is independent of this.
// kPairs: axis and IA_S read two scalars a load (scalar_pairs.hpp; the lean layout aligns them).
template <bool kPairs, class S, class Model, class Extra>
RBDGRAD_HD void articulated_axes(const Model& m, const S* axis, const S* Ic_S, S* IA_S, S* pivots,
                                 std::uint32_t* failed, const ThreadGroup& g, int extra_items, const Extra& extra) {
  for (int level = m.levels - 1; level >= 0; --level) {
    const int first = m.level_start[level], count = 6 * (m.level_start[level + 1] - first);
    g.for_each(count + (level == m.levels - 1 ? extra_items : 0), [&](int t) {
      if (t >= count) {
        extra(t - count);
        return;
      }
      const int i = m.level_joints[first + t / 6], r = t % 6;
      const S* Si = axis + 6 * i;
      const S* IcSi = Ic_S + 6 * i;
      S u = IcSi[r];
      S d = Si[0] * IcSi[0];
      for (int c = 1; c < 6; ++c) d += Si[c] * IcSi[c];
      // Not unrolled: unrolled, its loads' registers made the talos_reduced kernel spill at its 64
      // (a thread a joint, unrolled and spilling, measured 3% faster, runs 127 and 129; S_i read
      // again each term so as not to spill, 9% slower, run 129: docs/benchmarks/cuda.md)
#if defined(__CUDA_ARCH__)
#pragma unroll 1
#endif
      for (int k = i + 1; k < m.subtree_end[i]; ++k) {
        const S* Uk = IA_S + 6 * k;
        S U[6], Sv[6];
        load_six<kPairs>(Uk, U);
        load_six<kPairs>(Si, Sv);
        S s = U[0] * Sv[0];
        for (int c = 1; c < 6; ++c) s += U[c] * Sv[c];
        const S sd = s * pivots[k];
        u -= Uk[r] * sd;
        d -= s * sd;
      }
      IA_S[6 * i + r] = u;
      if (r == 0) {
        const bool positive = is_finite(d) && d > S(0);
        pivots[i] = positive ? S(1) / d : d;
        if (!positive) group_max(failed, static_cast<std::uint32_t>(i) + 1u);
      }
    });
    g.sync();
  }
}

// Column j of M^-1 into inverse (entry (i, j) at row_at(i) + j, rows of j's block [first, end)):
// the articulated-body algorithm's answer to a unit torque at j, velocity and gravity zero. Up j's
// ancestors-or-self, nearest first: the part D_i^-1 (delta_ij - S_i . F) of qdd_i, F the bias
// force passed up so far (F += U_i times that part). Then down the block in depth-first order:
// qdd_i = that part (zero off j's ancestors) - D_i^-1 U_i . a_parent, and a_i = a_parent + S_i qdd_i,
// a_parent the joint before's a where it is the parent, else (a branch starts) the sum of S_k qdd_k
// over the parent's ancestors-or-self, the same adds in the same order. The lanes of a warp that
// take the columns of one block read the same joint's constants at once (broadcasts) and write
// consecutive entries of a row. kPairs: as articulated_axes.
template <bool kPairs, class S, class Model, class RowAt>
RBDGRAD_HD void inverse_column(const Model& m, const S* axis, const S* IA_S, const S* pivots, S* inverse,
                               const RowAt& row_at, int j) {
  const int first = m.root_of[j], end = m.subtree_end[first];
  S F[6];
  for (int c = 0; c < 6; ++c) F[c] = S(0);
  S delta = S(1);
  const auto load6 = [](const S* p, S(&x)[6]) { load_six<kPairs>(p, x); };
  for (int i = j; i >= first; i = m.parent[i]) {
    S v[6];
    load6(axis + 6 * i, v);
    S s = delta;
    for (int c = 0; c < 6; ++c) s -= v[c] * F[c];
    const S x = s * pivots[i];
    inverse[row_at(i) + j] = x;
    load6(IA_S + 6 * i, v);
    for (int c = 0; c < 6; ++c) F[c] += v[c] * x;
    delta = S(0);
  }
  S a[6];
  for (int c = 0; c < 6; ++c) a[c] = S(0);
  for (int i = first; i < end; ++i) {
    const int par = m.parent[i];
    if (par != i - 1) {
      for (int c = 0; c < 6; ++c) a[c] = S(0);
      for (int k = first; k <= par; ++k) {
        if (!m.contains(k, par)) continue;
        const S x = inverse[row_at(k) + j];
        S v[6];
        load6(axis + 6 * k, v);
        for (int c = 0; c < 6; ++c) a[c] += v[c] * x;
      }
    }
    S v[6];
    load6(IA_S + 6 * i, v);
    S s = v[0] * a[0];
    for (int c = 1; c < 6; ++c) s += v[c] * a[c];
    const S part = m.contains(i, j) ? inverse[row_at(i) + j] : S(0);
    const S x = part - s * pivots[i];
    inverse[row_at(i) + j] = x;
    load6(axis + 6 * i, v);
    for (int c = 0; c < 6; ++c) a[c] += v[c] * x;
  }
}

}  // namespace rbdgrad::cuda
