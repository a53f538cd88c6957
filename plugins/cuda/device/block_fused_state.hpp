// One state of a batch on a group of threads: the forward-dynamics gradient refactored for the GPU
// as paper 000's Algorithm 4 asks. The per-body work of each pass runs in parallel, entry by entry.
// The recursions over the tree become sums over a joint's ancestors (world-frame velocities and
// accelerations are prefix sums of per-joint terms, found by scanning the joints before it with
// the ancestor test, whose loads do not wait on each other as a walk up the parent chain does) or
// over its subtree (a contiguous index range in depth-first order). The columns of dc'/du and of
// M^-1 are found in parallel. Only M^-1's articulated inertias (block_mass_inverse.hpp) and, in
// f32, the articulated-body pass for qdd go a tree level a pass. The working set stays in shared
// memory.
//
// The math is that of fused_state.hpp (the one-thread kernel): the same passes, algorithms and
// checks, so that both kernels fail a state for the same reason and agree to rounding (one sum
// regrouped: the subtree force due to qdd from Ic and Ic S, below, where that kernel sums
// I a_qdd). It covers the gradient request of MPC (outputs among qdd, M^-1, d qdd/d q,
// d qdd/d qd, from tau or qdd, with or without external forces, M^-1 computed here or the
// caller's); block_kernel_supports says so, and any other request goes to the one-thread kernel.
//
// Stages (issue 8): the d/dq and d/dqd columns and the inversion of M run only when needed. The
// kernel compiled for any robot decides per batch (its outputs, whether it brings M^-1); a kernel
// compiled for a scene has them fixed (kStages >= 0, BlockStages), and the code of the others is
// not in it.
#pragma once

#include "block_articulated_body.hpp"
#include "block_stages.hpp"
#include "block_mass_inverse.hpp"
#include "block_tree_chains.hpp"
#include "block_tree_products.hpp"
#include "block_tree_sums.hpp"
#include "fused_state.hpp"
#include "scalar_pairs.hpp"

namespace rbdgrad::cuda {

// The largest model the passes' index arithmetic is written for (cuda_instance.hpp's kMaxNv).
inline constexpr int kMaxBlockNv = 64;
inline constexpr std::uint32_t kBlockOutputs = kOutputQdd | kOutputMinv | kOutputDqddDq | kOutputDqddDqd;

// A caller's M^-1 with the MINV output asked as well (which is then M^-1(q) computed here, plugin_api.h)
// goes to the one-thread kernel.
template <class S>
RBDGRAD_HD bool block_kernel_supports(const BatchPointers<S>& b) {
  return (b.outputs & ~kBlockOutputs) == 0 && (b.outputs & (kOutputMinv | kOutputDqddDq | kOutputDqddDqd)) != 0 &&
         (b.minv == nullptr || (b.outputs & kOutputMinv) == 0) && b.qd != nullptr && b.u != nullptr;
}


// Whether S takes the f32 algorithms (qdd from tau by the articulated-body pass, as
// fd_derivatives says why) or the f64 ones (qdd through M^-1): a trait, so that a counting scalar
// type (bench/plugins/cuda_flop_count.cpp) can stand in for either.
template <class S>
struct SinglePrecision : std::is_same<S, float> {};

template <class S>
constexpr RBDGRAD_HD bool block_uses_aba(bool tau_input) {
  return SinglePrecision<S>::value && tau_input;
}

// Scalars of one state's working set for a batch (block_workspace.hpp), as the kernel carves them.
template <class S>
RBDGRAD_HD std::size_t block_state_scalars(const ModelView<S>& model, bool tau_input, bool minv_supplied,
                                           bool compact, bool lean = false) {
  return BlockWorkspace<S>::scalars(model.nv, block_uses_aba<S>(tau_input),
                                    block_matrices(model.nv, model.matrix_scalars, compact, minv_supplied), lean);
}

namespace block {

// (A x)_k of a 6x6 A at body i of `base` (kBodyMatrixStride apart); (A^T x)_k
template <class S>
RBDGRAD_HD S row_dot(const S* base, int i, int k, const S* x) {
  const S* row = base + kBodyMatrixStride * i + 6 * k;
  S s = row[0] * x[0];
  for (int c = 1; c < 6; ++c) s += row[c] * x[c];
  return s;
}
template <class S>
RBDGRAD_HD S col_dot(const S* base, int i, int k, const S* x) {
  const S* col = base + kBodyMatrixStride * i + k;
  S s = col[0] * x[0];
  for (int r = 1; r < 6; ++r) s += col[6 * r] * x[r];
  return s;
}
// (A x)_k of a symmetric A at body i of `base` (its upper triangle, kSymmetricStride apart)
template <class S>
RBDGRAD_HD S symmetric_row_dot(const S* base, int i, int k, const S* x) {
  const S* A = base + kSymmetricStride * i;
  S s = A[symmetric_index(k, 0)] * x[0];
  for (int c = 1; c < 6; ++c) s += A[symmetric_index(k, c)] * x[c];
  return s;
}
template <class S>
RBDGRAD_HD S dot6(const S* a, const S* b) {
  S s = a[0] * b[0];
  for (int k = 1; k < 6; ++k) s += a[k] * b[k];
  return s;
}

// t / n and t % n by a float reciprocal: an integer division by a run-time n costs about twenty
// instructions, and the passes over matrix entries do one per item. Exact for t < 2^20, n <= 64
// (the rounding error of (t + 1/2) / n stays far below the 1/(2n) margin to the next integer).
struct Divider {
  int n;
  float inverse;
  RBDGRAD_HD explicit Divider(int d) : n(d), inverse(1.0f / static_cast<float>(d)) {}
  RBDGRAD_HD int quotient(int t) const { return static_cast<int>((static_cast<float>(t) + 0.5f) * inverse); }
  RBDGRAD_HD int remainder(int t) const { return t - quotient(t) * n; }
};
// The same by a compile-time N (a kernel compiled for one robot): a multiply and a shift.
template <int N>
struct FixedDivider {
  RBDGRAD_HD int quotient(int t) const { return t / N; }
  RBDGRAD_HD int remainder(int t) const { return t % N; }
};
template <class Model>
RBDGRAD_HD auto divider_for(int n) {
  if constexpr (FixedSizes<Model>::nv > 0) return FixedDivider<FixedSizes<Model>::nv>{};
  else return Divider(n);
}

// Components of the spatial cross products, the operands read in place (element e of x at
// x[e * stride]): one component per thread, and no local array indexed at run time.
template <class S>
RBDGRAD_HD S cross3_at(const S* a, int sa, const S* b, int sb, int r) {
  const int r1 = r == 2 ? 0 : r + 1, r2 = r == 0 ? 2 : r - 1;
  return a[r1 * sa] * b[r2 * sb] - a[r2 * sa] * b[r1 * sb];
}
// The three below (and inertia_parameters.hpp's row products) compute both halves' terms and
// select: a warp's lanes take consecutive components of a few bodies, so that a branch on c < 3
// ran both paths one after the other with half the lanes idle. The selected value is the one the
// branch computed, the same operations in the same order.
// (m1 x m2)_c
template <class S>
RBDGRAD_HD S cross_motion_at(const S* m1, int s1, const S* m2, int s2, int c) {
  const bool angular = c < 3;
  const int r = angular ? c : c - 3;
  const S first = cross3_at(m1, s1, angular ? m2 : m2 + 3 * s2, s2, r);
  const S second = cross3_at(m1 + 3 * s1, s1, m2, s2, r);
  return angular ? first : first + second;
}
// (m x* f)_c
template <class S>
RBDGRAD_HD S cross_force_at(const S* m, int sm, const S* f, int sf, int c) {
  const bool angular = c < 3;
  const int r = angular ? c : c - 3;
  const S first = cross3_at(m, sm, angular ? f : f + 3 * sf, sf, r);
  const S second = cross3_at(m + 3 * sm, sm, f + 3 * sf, sf, r);
  return angular ? first + second : first;
}
// Components r + 1 and r + 2 (mod 3) of the halves of the 6-vector at p (aligned to pairs: the
// lean layout's), all a cross product's component r needs: the vector read whole, three
// 16-byte loads that a body's lanes share, and the four picked by selects. Read a component a
// load, a lean pass's three lanes a body met the banks three ways where two would do (bodies 8
// apart share them) and a vector took four loads: 306 of a talos_reduced state's 882 wavefronts
// there were conflicts (cuda_shared_wavefronts).
template <class S>
struct CrossOperand {
  S angular1, angular2, linear1, linear2;
};
template <class S>
RBDGRAD_HD CrossOperand<S> cross_operand(const S* p, int r) {
  S x[6];
  load_six<true>(p, x);
  const int r1 = r == 2 ? 0 : r + 1, r2 = r == 0 ? 2 : r - 1;
  return {pick3(x[0], x[1], x[2], r1), pick3(x[0], x[1], x[2], r2), pick3(x[3], x[4], x[5], r1),
          pick3(x[3], x[4], x[5], r2)};
}
// cross3_at's component r of a x b from the two operands' components r1 and r2
template <class S>
RBDGRAD_HD S cross3_of(S a1, S a2, S b1, S b2) {
  return a1 * b2 - a2 * b1;
}
// Components r and 3 + r (r < 3) of the two above at once (unit strides; kWhole: 6-vectors
// aligned to pairs, read by cross_operand), for an item that takes both: the terms each
// component's select keeps, in the same order. kWhole where talos_reduced's kernel keeps to its
// 64 registers without spills with it (block_evaluate_state's kWholeCross); in the other passes'
// items, in the combinations tried, ptxas spilled 8 to 56 bytes.
template <bool kWhole = false, class S>
RBDGRAD_HD void cross_motion_pair(const S* m1, const S* m2, int r, S& angular, S& linear) {
  if constexpr (kWhole) {
    const CrossOperand<S> x = cross_operand(m1, r), y = cross_operand(m2, r);
    angular = cross3_of(x.angular1, x.angular2, y.angular1, y.angular2);
    linear = cross3_of(x.angular1, x.angular2, y.linear1, y.linear2) +
             cross3_of(x.linear1, x.linear2, y.angular1, y.angular2);
  } else {
    angular = cross3_at(m1, 1, m2, 1, r);
    linear = cross3_at(m1, 1, m2 + 3, 1, r) + cross3_at(m1 + 3, 1, m2, 1, r);
  }
}
template <bool kWhole = false, class S>
RBDGRAD_HD void cross_force_pair(const S* m, const S* f, int r, S& angular, S& linear) {
  if constexpr (kWhole) {
    const CrossOperand<S> x = cross_operand(m, r), y = cross_operand(f, r);
    angular = cross3_of(x.angular1, x.angular2, y.angular1, y.angular2) +
              cross3_of(x.linear1, x.linear2, y.linear1, y.linear2);
    linear = cross3_of(x.angular1, x.angular2, y.linear1, y.linear2);
  } else {
    angular = cross3_at(m, 1, f, 1, r) + cross3_at(m + 3, 1, f + 3, 1, r);
    linear = cross3_at(m, 1, f + 3, 1, r);
  }
}
// (m x* A(:, k))_c of a symmetric A (its upper triangle at A), as cross_force_at on a column
template <class S>
RBDGRAD_HD S cross_force_column_at(const S* m, const S* A, int k, int c) {
  auto col = [&](int r) { return A[symmetric_index(r, k)]; };
  auto cross3 = [&](int mo, int fo, int r) {
    const int r1 = r == 2 ? 0 : r + 1, r2 = r == 0 ? 2 : r - 1;
    return m[mo + r1] * col(fo + r2) - m[mo + r2] * col(fo + r1);
  };
  const bool angular = c < 3;
  const int r = angular ? c : c - 3;
  const S first = cross3(0, angular ? 0 : 3, r), second = cross3(3, 3, r);
  return angular ? first + second : first;
}
// skew(x)(row, col)
template <class S>
RBDGRAD_HD S skew_at(const S* x, int row, int col) {
  if (row == col) return S(0);
  const S value = x[3 - row - col];
  return (col - row + 3) % 3 == 1 ? -value : value;
}
// x[i] of a 3-vector a thread holds, by selects: indexed at run time, ptxas puts the array in
// local memory (talos_reduced's inertia pass: 48 bytes of its kernel's stack frame, stored and
// loaded through L1 on every item)
template <class S>
RBDGRAD_HD S held_at(const S (&x)[3], int i) {
  return i == 0 ? x[0] : i == 1 ? x[1] : x[2];
}
// skew_at for a 3-vector a thread holds
template <class S>
RBDGRAD_HD S skew_held(const S (&x)[3], int row, int col) {
  if (row == col) return S(0);
  const S value = held_at(x, 3 - row - col);
  return (col - row + 3) % 3 == 1 ? -value : value;
}
// the gravity acceleration [0; -g], component c. By selects, not m.gravity[c - 3]: an index known
// only at run time puts the whole model view in local memory (ptxas: a 272-byte stack frame for
// talos_reduced's f64 kernel, 128 without)
template <class S>
RBDGRAD_HD S gravity_at(const ModelView<S>& m, int c) {
  return c < 3 ? S(0) : c == 3 ? -m.gravity[0] : c == 4 ? -m.gravity[1] : -m.gravity[2];
}
// Columns c0 .. c0 + K - 1 of body i's world placement [R p] (column 3 is p), through its
// ancestors' transforms from the local ones (R_local, p_local): a row of an ancestor's rotation
// read once for the K columns
template <int K, class S, class Model>
RBDGRAD_HD void place_columns(const Model& m, const BlockWorkspace<S>& w, int i, int c0) {
  S x[K][3];
  for (int k = 0; k < K; ++k)
    for (int r = 0; r < 3; ++r) x[k][r] = c0 + k < 3 ? w.R_local[9 * i + 3 * r + c0 + k] : w.p_local[3 * i + r];
  for (int j = m.parent[i]; j >= 0; j = m.parent[j]) {
    S y[K][3];
    for (int r = 0; r < 3; ++r) {
      const S* row = w.R_local + 9 * j + 3 * r;
      const S r0 = row[0], r1 = row[1], r2 = row[2];
      for (int k = 0; k < K; ++k)
        y[k][r] = r0 * x[k][0] + r1 * x[k][1] + r2 * x[k][2] + (K == 1 && c0 == 3 ? w.p_local[3 * j + r] : S(0));
    }
    for (int k = 0; k < K; ++k)
      for (int r = 0; r < 3; ++r) x[k][r] = y[k][r];
    // (p's translation added after the rotation where K > 1, in the sum where K = 1: the same
    // operations, in the forms that ptxas kept talos_reduced's builds at 64 registers without
    // spills)
    if (K > 1 && c0 + K - 1 == 3)
      for (int r = 0; r < 3; ++r) x[K - 1][r] += w.p_local[3 * j + r];
  }
  for (int k = 0; k < K; ++k)
    for (int r = 0; r < 3; ++r) {
      if (c0 + k < 3) w.R[9 * i + 3 * r + c0 + k] = x[k][r];
      else w.p[3 * i + r] = x[k][r];
    }
}
// ([0; -g] x S)_c, the root's a_parent x S: zero for c < 3, (-g x S_angular)_(c - 3) after
template <class S, class Model>
RBDGRAD_HD S gravity_cross_at(const Model& m, const S* Si, int c) {
  const int r = c < 3 ? 0 : c - 3, r1 = r == 2 ? 0 : r + 1, r2 = r == 0 ? 2 : r - 1;
  const S x = gravity_at(m, 3 + r1) * Si[r2] - gravity_at(m, 3 + r2) * Si[r1];
  return c < 3 ? S(0) : x;
}

}  // namespace block

// A state's outputs in the batch (null: not asked, or the state is inactive)
template <class IO>
struct BlockOutputs {
  IO *qdd, *minv, *dq, *dqd;
};

// Reads the state's inputs q, qd and u into w.q, w.qd, w.u, each by the thread that uses it in the
// first pass. The kernel does it before it loads the robot's constants, so that the two reads'
// latencies (the inputs may be host memory, over PCIe) overlap. IO: the batch's scalar type, S or
// float (an f32 batch computed in f64).
template <class S, class IO>
RBDGRAD_HD void block_load_inputs(int n, const BlockWorkspace<S>& w, const BatchPointers<IO>& b, std::uint64_t state,
                                  const ThreadGroup& g) {
  const std::uint64_t vec = static_cast<std::uint64_t>(n);
  g.for_each(n, [&](int i) {
    w.q[i] = static_cast<S>(b.q[state * vec + i]);
    w.qd[i] = static_cast<S>(b.qd[state * vec + i]);
    w.u[i] = static_cast<S>(b.u[state * vec + i]);
  });
}

// Computes `state` of b (block_kernel_supports(b)) with the group's threads and writes its outputs
// and status; an inactive group (past the end of the batch) runs on `state` for the syncs' sake and
// writes nothing. The inputs are in w.q, w.qd and w.u already (block_load_inputs, by the same
// threads).
// Model: ModelView<S>, or FixedSizeModelView<S, ...> for a kernel compiled for one robot. IO: the
// batch's scalar type (block_load_inputs); an output that leaves IO's range is flagged as not
// finite.
// kStages: block_stages (a scene's fixed stages, which the batch follows) or kPerBatch.
// kPacked: M, M^-1 computed here and d tau/d u packed by the roots' blocks (ModelView::matrix_row;
// the compact kernel, block_kernel_entry.hpp), w's matrices sized so; else dense nv x nv.
// kLean: w is the lean layout (block_workspace.hpp): I, Ic and B's and Bc's symmetric parts by
// their parameters (inertia_parameters.hpp), B's and Bc's antisymmetric parts by h and hc.
template <class S, class Model, class IO, int kStages = block_stages::kPerBatch, bool kPacked = false,
          bool kLean = false>
RBDGRAD_HD void block_evaluate_state(const Model& m, const BlockWorkspace<S>& w, const BatchPointers<IO>& b,
                                     std::uint32_t state, bool active, const ThreadGroup& g) {
  using block::col_dot;
  using block::cross_force_at;
  using block::cross_motion_at;
  using block::dot6;
  using block::gravity_at;
  using block::row_dot;
  using block::symmetric_row_dot;
  const int n = m.nv;
  const std::uint64_t vec = static_cast<std::uint64_t>(n), mat = vec * vec;
  // (6 state fits 32 bits: kDefaultBlockMaxStates; a 64-bit product here, ptxas spilled at 64
  // registers)
  const IO* fext = b.fext ? b.fext + static_cast<std::uint64_t>(6 * state) * vec : nullptr;
  const auto by_n = block::divider_for<Model>(n);
  // compile-time constants in a scene's kernel: the branches below then leave no code behind
  constexpr bool kFixed = kStages != block_stages::kPerBatch;
  const bool want_dq = kFixed ? (kStages & block_stages::kDq) != 0 : (b.outputs & kOutputDqddDq) != 0;
  const bool want_dqd = kFixed ? (kStages & block_stages::kDqd) != 0 : (b.outputs & kOutputDqddDqd) != 0;
  const bool minv_supplied = kFixed ? (kStages & block_stages::kMinvSupplied) != 0 : b.minv != nullptr;
  // where row i of M (of M^-1 computed here) and of d tau/d u starts: entry (i, j) at row_at(i) + j,
  // j in row i's block where packed (entries between blocks are zero and not stored)
  const auto row_at = [&](int i) {
    if constexpr (kPacked) return m.matrix_row[i];
    else return i * n;
  };
  // the same for M^-1: a caller's stays dense
  const auto inverse_row = [&](int i) { return minv_supplied ? i * n : row_at(i); };
  // the lean layout's 6-vectors (and M^-1 computed here) read as pairs (scalar_pairs.hpp): into a
  // thread's registers, and in a product with a vector a thread holds (a column's, read by the
  // lanes of a warp at once)
  constexpr bool kPairs = kLean;
  const auto load6 = [](const S* p, S(&x)[6]) { load_six<kPairs>(p, x); };
  const auto dot6_with = [&](const S* held, const S* p) {
    if constexpr (kPairs) {
      S x[6];
      load6(p, x);
      return dot6(held, x);
    } else {
      return dot6(held, p);  // (the other layouts' code as it was: through x, ptxas emits another)
    }
  };
  // (a, b) in different blocks: not stored where packed
  const auto unstored = [&](int a, int bb) { return kPacked && m.root_of[a] != m.root_of[bb]; };
  // (I x)_c and (Ic x)_c of body i: by the upper triangles, or (lean) by the parameters
  const auto I_row = [&](int i, int c, const S* x) {
    if constexpr (kLean) return block::inertia_row_dot(w.I, i, c, x, m.mass[i]);
    else return symmetric_row_dot(w.I, i, c, x);
  };
  const auto Ic_row = [&](int i, int c, const S* x) {
    if constexpr (kLean) return block::inertia_row_dot(w.Ic, i, c, x, w.Ic_mass[i]);
    else return symmetric_row_dot(w.Ic, i, c, x);
  };
  // the products whose 6-vector operands are read whole (block::cross_operand, and
  // parameter_rows_dot's vectors): in the build the plugin makes for a robot by default (M^-1 by
  // the tree's chains and columns), at the sites where talos_reduced's kernel keeps to 64
  // registers without spills: alpha's v x S, h = I v, the body forces' v x* h, beta's two cross
  // products, B's S x* hc, Dq's S x* F, and Ic a_qdd_parent (6,757 -> 6,022 shared wavefronts a
  // state with the world placements two columns a thread, cuda_shared_wavefronts). The other
  // sites, tried one at a time on top of these, spilled 16 to 32 bytes (I a, Ic S, a_qdd x S,
  // Ic beta, alpha x* hc; Ic alpha with Ic S); the build with M^-1 by the chains alone spilled 32
  // with alpha's, v x* h and Dq's
  constexpr bool kWholeCross = kLean && FixedTree<Model>::known && kPacked && TreeConstants<Model>::chains && TreeConstants<Model>::columns;
  // the lean layout's passes over a body's components take two an item, r and 3 + r (r < 3): the
  // products' angular and linear rows share their loads, and the selects that an item a component
  // needed go (rows_item: the item's body and r)
  const auto Ic_rows = [&](int i, int r, const S* x, S& angular, S& linear) {
    block::parameter_rows_dot<true>(w.Ic, i, r, x, w.Ic_mass[i], angular, linear);
  };
  // (the vector read whole where kWholeCross: above)
  const auto Ic_rows_whole = [&](int i, int r, const S* x, S& angular, S& linear) {
    block::parameter_rows_dot<true, kWholeCross>(w.Ic, i, r, x, w.Ic_mass[i], angular, linear);
  };
  const auto Bc_sym_rows = [&](int i, int r, const S* x, S& angular, S& linear) {
    block::parameter_rows_dot<false>(w.Bc_sym, i, r, x, S(0), angular, linear);
  };
  constexpr int kComponentsPerItem = kLean ? 2 : 1;
  const int component_items = 6 / kComponentsPerItem * n;
  // item t of a pass over the bodies' components: out_i = the sum over joint i's ancestors-or-self
  // (the joints of its block from the root on that contain it) of x_j y_j, x 6-vectors, after
  // gravity where `gravity`, in the joints' order. The lean passes' items take components c and
  // c + 1 (c even): x_j's pair one load (scalar_pairs.hpp), the tree's test and y_j once for both.
  const auto ancestor_sums_item = [&](const S* x, const S* y, S* out, int t, bool gravity) {
    if constexpr (kLean) {
      const int i = t / 3, c = 2 * (t - 3 * i);
      S s0 = gravity ? gravity_at(m, c) : S(0), s1 = gravity ? gravity_at(m, c + 1) : S(0);
      for (int j = m.root_of[i]; j <= i; ++j) {
        if (!m.contains(j, i)) continue;
        S x0, x1;
        load_pair(x + 6 * j + c, x0, x1);
        const S yj = y[j];
        s0 += x0 * yj;
        s1 += x1 * yj;
      }
      out[6 * i + c] = s0;
      out[6 * i + c + 1] = s1;
    } else {
      const int i = t / 6, c = t % 6;
      S s = gravity ? gravity_at(m, c) : S(0);
      for (int j = m.root_of[i]; j <= i; ++j)
        if (m.contains(j, i)) s += x[6 * j + c] * y[j];
      out[t] = s;
    }
  };
  // the same sums by the tree where the model type fixes it (block_tree_sums.hpp): an item a
  // component, every joint (0.8% off the kernel at 65536 f64 talos_reduced states, 0.9% f32
  // batches, run 144, H100)
  constexpr bool kTreeFixed = kLean && FixedTree<Model>::known;
  const int ancestor_items = kTreeFixed ? 6 : component_items;
  const auto ancestor_sums_at = [&](const S* x, const S* y, S* out, int t, bool gravity) {
    if constexpr (kTreeFixed) tree_ancestor_sums(m, x + t, y, out + t, gravity ? gravity_at(m, t) : S(0));
    else ancestor_sums_item(x, y, out, t, gravity);
  };
  // the entries a body's inertia, and B's symmetric part, are computed as: their parameters
  // (lean) or the 36 of the matrix
  constexpr int kBodyEntries = kLean ? kInertiaParameterStride : 36;

  if (g.rank == 0) *w.failed_pivot = *w.not_finite = 0;
  // the joint transforms in the parent frames
  g.for_each(n, [&](int i) {
    const S qi = w.q[i];
    if (!b.tau_input) w.qdd[i] = w.u[i];
    const S* R0 = m.joint_rotation + 9 * i;
    S* Rl = w.R_local + 9 * i;
    S* pl = w.p_local + 3 * i;
    for (int e = 0; e < 9; ++e) Rl[e] = R0[e];
    for (int r = 0; r < 3; ++r) pl[r] = m.joint_translation[3 * i + r];
    if (!m.prismatic[i]) {
      using std::cos;
      using std::sin;
      const S s = sin(qi), c = cos(qi);
      // R0 * Rz(q): only the first two columns mix
      for (int r = 0; r < 3; ++r) {
        Rl[3 * r] = c * R0[3 * r] + s * R0[3 * r + 1];
        Rl[3 * r + 1] = c * R0[3 * r + 1] - s * R0[3 * r];
      }
    } else {
      for (int r = 0; r < 3; ++r) pl[r] += qi * R0[3 * r + 2];
    }
  });
  g.sync();
  // world placements (block::place_columns)
  if constexpr (kWholeCross) {
    // two columns a thread, item t = h n + i (a warp's lanes the same columns): each ancestor's
    // rotation read once for both, 6,757 -> 6,548 shared wavefronts a talos_reduced state
    // (cuda_shared_wavefronts). Four a thread spilled 20 to 28 bytes at 64 registers, and two
    // spilled 8 to 144 in the lean builds with M^-1 by the chains alone or by levels: so in the
    // default build alone (kWholeCross)
    g.for_each(2 * n, [&](int t) { block::place_columns<2>(m, w, t % n, 2 * (t / n)); });
  } else {
    g.for_each(4 * n, [&](int t) { block::place_columns<1>(m, w, t / 4, t % 4); });
  }
  g.sync();
  // axes, centres of mass and rotational inertias in world axes, external forces in the world:
  // every entry of every body in parallel (the local transforms are not needed any more, their
  // arrays hold c = R com and Icw = R Ic R^T). Item t is term t / n of body t % n: the lanes of a
  // warp take the same term of consecutive bodies, so that its branches do not diverge.
  S* const com_w = w.p_local;
  S* const Icw = w.R_local;
  constexpr int kBodyTerms = 24;  // axis 6, c 3, Icw 9, external force 6
  g.for_each(kBodyTerms * n, [&](int t) {
    const int e = by_n.quotient(t), i = t - e * n;
    const S* R = w.R + 9 * i;
    const S* p = w.p + 3 * i;
    if (e < 6) {
      // revolute: [z; p x z], prismatic: [0; z], z = R e_z
      auto z = [&](int r) { return R[3 * r + 2]; };
      S x;
      if (!m.prismatic[i]) x = e < 3 ? z(e) : p[(e + 1) % 3] * z((e + 2) % 3) - p[(e + 2) % 3] * z((e + 1) % 3);
      else x = e < 3 ? S(0) : z(e - 3);
      w.axis[6 * i + e] = x;
    } else if (e < 9) {
      const int r = e - 6;
      const S* com = m.com + 3 * i;
      com_w[3 * i + r] = R[3 * r] * com[0] + R[3 * r + 1] * com[1] + R[3 * r + 2] * com[2];
    } else if (e < 18) {
      // (R Ic) R^T, entry (r, k), in the order of mul and mul_transposed
      const int r = (e - 9) / 3, k = (e - 9) % 3;
      const S* Ic = m.inertia_com + 9 * i;
      S RIc[3];
      for (int b2 = 0; b2 < 3; ++b2) RIc[b2] = R[3 * r] * Ic[b2] + R[3 * r + 1] * Ic[3 + b2] + R[3 * r + 2] * Ic[6 + b2];
      Icw[9 * i + 3 * r + k] = RIc[0] * R[3 * k] + RIc[1] * R[3 * k + 1] + RIc[2] * R[3 * k + 2];
    } else if (fext) {
      // [moment about the link origin; force] in the URDF link frame -> world axes, world origin:
      // force Rl f, moment Rl n + p x (Rl f), Rl = R * link_rotation
      const int r = e - 18;
      const S* lr = m.link_rotation + 9 * i;
      const IO* fl = fext + 6 * i;
      auto rotated = [&](int row, const IO* x) {
        S Rl[3];
        for (int b2 = 0; b2 < 3; ++b2)
          Rl[b2] = R[3 * row] * lr[b2] + R[3 * row + 1] * lr[3 + b2] + R[3 * row + 2] * lr[6 + b2];
        return Rl[0] * static_cast<S>(x[0]) + Rl[1] * static_cast<S>(x[1]) + Rl[2] * static_cast<S>(x[2]);
      };
      S x;
      if (r >= 3) {
        x = rotated(r - 3, fl + 3);
      } else {
        const int r1 = (r + 1) % 3, r2 = (r + 2) % 3;
        x = rotated(r, fl) + (p[r1] * rotated(r2, fl + 3) - p[r2] * rotated(r1, fl + 3));
      }
      w.f_ext[6 * i + r] = x;
    }
  });
  g.sync();
  // spatial inertias at the world origin (centre of mass c + p) and, for the articulated-body
  // pass, at the joint point (c), entry by entry as spatial_inertia builds them; in the same pass
  // (one sync less: each pass costs about 650 cycles even when short, docs/benchmarks/cuda.md),
  // the velocities: sums of S_j qd_j over the ancestors-or-self (which are in the joint's block,
  // from its root on). The entries go as the terms above: entry t / n of body t % n. The lean
  // layout keeps I's nine parameters (inertia_parameters.hpp) where the other keeps its upper
  // triangle (of 36 entries, those below the diagonal skipped); the joint point's inertia follows
  // either.
  const int inertia_items = (w.I_joint ? kBodyEntries + 36 : kBodyEntries) * n;
  g.for_each(inertia_items + ancestor_items, [&](int t) {
    if (t >= inertia_items) {
      ancestor_sums_at(w.axis, w.qd, w.v, t - inertia_items, false);
      return;
    }
    const int local = by_n.quotient(t), i = t - local * n;
    const bool joint_point = local >= kBodyEntries;
    if (kLean && !joint_point) {
      // h = m c, then J(r, k) = Icw(r, k) - (mc x c x)(r, k) of the upper triangle
      const S mass = m.mass[i];
      S c[3];
      for (int x = 0; x < 3; ++x) c[x] = com_w[3 * i + x] + w.p[3 * i + x];
      const S mc[3] = {mass * c[0], mass * c[1], mass * c[2]};
      S value;
      if (local < 3) {
        value = block::held_at(mc, local);
      } else {
        const int r = local < 6 ? 0 : local < 8 ? 1 : 2, k = local < 6 ? local - 3 : local < 8 ? local - 5 : 2;
        using block::skew_held;
        value = Icw[9 * i + 3 * r + k] - (skew_held(mc, r, 0) * skew_held(c, 0, k) +
                                          skew_held(mc, r, 1) * skew_held(c, 1, k) +
                                          skew_held(mc, r, 2) * skew_held(c, 2, k));
      }
      w.I[kInertiaParameterStride * i + local] = value;
      return;
    }
    const int e = kLean ? (joint_point ? local - kBodyEntries : local) : local % 36, r = e / 6, k = e % 6;
    if (!joint_point && r > k) return;  // I is symmetric: its upper triangle
    const S mass = m.mass[i];
    S c[3];
    for (int x = 0; x < 3; ++x) c[x] = com_w[3 * i + x] + (joint_point ? S(0) : w.p[3 * i + x]);
    const S mc[3] = {mass * c[0], mass * c[1], mass * c[2]};
    S value;
    if (r < 3 && k < 3) {
      using block::skew_held;
      const S mcxcx = skew_held(mc, r, 0) * skew_held(c, 0, k) + skew_held(mc, r, 1) * skew_held(c, 1, k) +
                      skew_held(mc, r, 2) * skew_held(c, 2, k);
      value = Icw[9 * i + 3 * r + k] - mcxcx;
    } else if (r < 3) {
      value = block::skew_held(mc, r, k - 3);
    } else if (k < 3) {
      value = -block::skew_held(mc, r - 3, k);
    } else {
      value = r == k ? mass : S(0);
    }
    if (joint_point) w.I_joint[36 * i + e] = value;
    else w.I[kSymmetricStride * i + symmetric_index(r, k)] = value;
  });
  g.sync();
  // alpha = v_parent x S (v x S qd = v_parent x S qd since S x S = 0), and the momentum h = I v
  // (in F until the subtree sums, in the default layout)
  g.for_each(component_items, [&](int t) {
    if constexpr (kLean) {
      const int i = t / 3, r = t - 3 * i, par = m.parent[i];
      const int a = 6 * i + r, l = a + 3;
      if (par < 0) {
        w.alpha[a] = w.alpha[l] = S(0);
      } else {
        block::cross_motion_pair<kWholeCross>(w.v + 6 * par, w.axis + 6 * i, r, w.alpha[a], w.alpha[l]);
      }
      block::parameter_rows_dot<true, kWholeCross>(w.I, i, r, w.v + 6 * i, m.mass[i], w.h[a], w.h[l]);
    } else {
      const int i = t / 6, c = t % 6, par = m.parent[i];
      w.alpha[t] = par < 0 ? S(0) : cross_motion_at(w.v + 6 * par, 1, w.axis + 6 * i, 1, c);
      w.h[t] = I_row(i, c, w.v + 6 * i);
    }
  });
  g.sync();
  // accelerations with qdd = 0: gravity plus the sums of alpha_j qd_j
  g.for_each(ancestor_items, [&](int t) { ancestor_sums_at(w.alpha, w.qd, w.a, t, true); });
  g.sync();
  // body forces f = I a + v x* h - f_ext, and B = v x* I - I v x + h-bar entry by entry (entry
  // e of body i at item 6 n + e n + i, as the inertias). B's symmetric part is v x* I - I v x (the
  // rate of I moving with v), its antisymmetric part h-bar = -[hn x, hf x; hf x, 0]; the lean
  // layout keeps the first (by its parameters, inertia_parameters.hpp) and leaves the second to
  // h: B x = B_sym x + x x* h and B^T x = B_sym x - x x* h, and the subtree sums need h's (hc)
  // alone.
  // The lean layout also takes beta's part known before qdd here (for the d/dq stage), a_parent x
  // S + v_parent x alpha (gravity, v = 0 at the root), so that v and a die with this pass (beta =
  // that + a_qdd_parent x S, below).
  const int beta_items = kLean && want_dq ? component_items : 0;
  g.for_each(component_items + kBodyEntries * n + beta_items, [&](int t) {
    if (t < component_items) {
      if constexpr (kLean) {
        const int i = t / 3, r = t - 3 * i;
        const int a = 6 * i + r, l = a + 3;
        S Ia[2], vh[2];
        block::parameter_rows_dot<true>(w.I, i, r, w.a + 6 * i, m.mass[i], Ia[0], Ia[1]);
        block::cross_force_pair<kWholeCross>(w.v + 6 * i, w.h + 6 * i, r, vh[0], vh[1]);
        w.f[a] = Ia[0] + (vh[0] - (fext ? w.f_ext[a] : S(0)));
        w.f[l] = Ia[1] + (vh[1] - (fext ? w.f_ext[l] : S(0)));
      } else {
        const int i = t / 6, c = t % 6;
        const S Ia = I_row(i, c, w.a + 6 * i);
        w.f[t] = Ia + (cross_force_at(w.v + 6 * i, 1, w.h + 6 * i, 1, c) - (fext ? w.f_ext[t] : S(0)));
      }
      return;
    }
    if (kLean && t < component_items + beta_items) {
      const int beta_item = t - component_items, i = beta_item / 3, r = beta_item - 3 * i, par = m.parent[i];
      const int a = 6 * i + r, l = a + 3;
      const S* Si = w.axis + 6 * i;
      if (par >= 0) {
        S x[2], y[2];
        block::cross_motion_pair<kWholeCross>(w.a + 6 * par, Si, r, x[0], x[1]);
        block::cross_motion_pair<kWholeCross>(w.v + 6 * par, w.alpha + 6 * i, r, y[0], y[1]);
        w.beta[a] = x[0] + y[0];
        w.beta[l] = x[1] + y[1];
      } else {
        w.beta[a] = S(0);
        w.beta[l] = block::gravity_cross_at(m, Si, 3 + r);
      }
      return;
    }
    const int e = by_n.quotient(t - component_items - beta_items), i = t - component_items - beta_items - e * n;
    if constexpr (kLean) {
      w.B_sym[kInertiaParameterStride * i + e] =
          block::inertia_rate_parameter(w.I + kInertiaParameterStride * i, m.mass[i], w.v + 6 * i, e);
    } else {
      const int r = e / 6, c = e % 6;
      const S* v = w.v + 6 * i;
      const S* I = w.I + kSymmetricStride * i;
      // (v x* I)(r, c) + (v x* I)(c, r): columns c and r of I
      S value = block::cross_force_column_at(v, I, c, r) + block::cross_force_column_at(v, I, r, c);
      const S* h = w.h + 6 * i;
      // - hn x in the top-left block, - hf x in the two off-diagonal blocks
      if (r < 3 && c < 3) value -= block::skew_at(h, r, c);
      else if (r < 3) value -= block::skew_at(h + 3, r, c - 3);
      else if (c < 3) value -= block::skew_at(h + 3, r - 3, c);
      w.B[kBodyMatrixStride * i + e] = value;
    }
  });
  g.sync();
  // subtree sums (the subtree of i is [i, subtree_end[i])): Ic, Bc (lean: the parameters of Ic
  // and of Bc's symmetric part, Ic's mass, and hc), F. The tree fixed at compile time (the lean
  // kernel compiled for the robot): a thread a component over the whole tree (block_tree_sums.hpp),
  // in three groups by stride, a warp each where the group has 96 threads or more: I's and B_sym's
  // parameters, h's and f's components, the mass (6.0% off the kernel at 65536 f64 talos_reduced
  // states, 6.4% f32 batches, run 144, H100). Otherwise an item a body and component: two sums
  // over alternate bodies, so that a long subtree (20 bodies in talos_reduced's torso) is two
  // chains of adds whose loads do not wait on each other; the divisions by constants.
  if constexpr (kTreeFixed) {
    constexpr int P = kInertiaParameterStride;
    g.for_each(96, [&](int t) {
      const int group = t / 32, x = t - 32 * group;
      if (group == 0 && x < 2 * P) {
        const int k = x < P ? x : x - P;
        tree_subtree_sums<P>(m, (x < P ? w.I : w.B_sym) + k, (x < P ? w.Ic : w.Bc_sym) + k);
      } else if (group == 1 && x < 12) {
        const int k = x < 6 ? x : x - 6;
        tree_subtree_sums<6>(m, (x < 6 ? w.h : w.f) + k, (x < 6 ? w.hc : w.F) + k);
      } else if (group == 2 && x == 0) {
        tree_subtree_sums<1>(m, m.mass, w.Ic_mass);
      }
    });
  } else {
    g.for_each((kLean ? 31 : 63) * n, [&](int t) {
      const S* from;
      S* to;
      int stride, i, x;
      if constexpr (kLean) {
        constexpr int P = kInertiaParameterStride;
        if (t < P * n) {
          from = w.I, to = w.Ic, stride = P, i = t / P, x = t - P * i;
        } else if (t < 2 * P * n) {
          from = w.B_sym, to = w.Bc_sym, stride = P, i = (t - P * n) / P, x = t - P * n - P * i;
        } else if (t < (2 * P + 6) * n) {
          from = w.h, to = w.hc, stride = 6, i = (t - 2 * P * n) / 6, x = t - 2 * P * n - 6 * i;
        } else if (t < (2 * P + 12) * n) {
          from = w.f, to = w.F, stride = 6, i = (t - (2 * P + 6) * n) / 6, x = t - (2 * P + 6) * n - 6 * i;
        } else {
          from = m.mass, to = w.Ic_mass, stride = 1, i = t - (2 * P + 12) * n, x = 0;
        }
      } else {
        if (t < 21 * n) {
          from = w.I, to = w.Ic, stride = kSymmetricStride, i = t / 21, x = t - 21 * i;
        } else if (t < 57 * n) {
          from = w.B, to = w.Bc, stride = kBodyMatrixStride, i = (t - 21 * n) / 36, x = t - 21 * n - 36 * i;
        } else {
          from = w.f, to = w.F, stride = 6, i = (t - 57 * n) / 6, x = t - 57 * n - 6 * i;
        }
      }
      const S* entry = from + x;
      const int end = m.subtree_end[i];
      S s0 = entry[stride * i], s1 = S(0);
      int j = i + 1;
      for (; j + 1 < end; j += 2) {
        s0 += entry[stride * j];
        s1 += entry[stride * (j + 1)];
      }
      if (j < end) s0 += entry[stride * j];
      to[stride * i + x] = s0 + s1;
    });
  }
  g.sync();
  // per body: Ic S, Bc^T S, E = 2 Ic alpha + Bc S; f64 from tau: u = tau - c, c = tau(qdd = 0) =
  // S . F, in place (qdd = M^-1 (tau - c) below; f32 has qdd from the articulated-body pass)
  const bool qdd_by_inverse = !SinglePrecision<S>::value && b.tau_input;
  g.for_each(qdd_by_inverse ? component_items + n : component_items, [&](int t) {
    if (t >= component_items) {
      const int i = t - component_items;
      w.u[i] -= dot6(w.axis + 6 * i, w.F + 6 * i);
      return;
    }
    if constexpr (kLean) {
      const int i = t / 3, r = t - 3 * i;
      const S* Si = w.axis + 6 * i;
      S* const IcS = w.Ic_S + 6 * i;
      S* const BcS = w.Bc_t_S + 6 * i;
      Ic_rows(i, r, Si, IcS[r], IcS[3 + r]);
      S sym[2], anti[2];
      Bc_sym_rows(i, r, Si, sym[0], sym[1]);
      block::cross_force_pair<kWholeCross>(Si, w.hc + 6 * i, r, anti[0], anti[1]);
      BcS[r] = sym[0] - anti[0];
      BcS[3 + r] = sym[1] - anti[1];
      if (want_dqd) {
        S Ic_alpha[2];
        Ic_rows(i, r, w.alpha + 6 * i, Ic_alpha[0], Ic_alpha[1]);
        w.E[6 * i + r] = S(2) * Ic_alpha[0] + (sym[0] + anti[0]);
        w.E[6 * i + 3 + r] = S(2) * Ic_alpha[1] + (sym[1] + anti[1]);
      }
    } else {
      const int i = t / 6, c = t % 6;
      const S* Si = w.axis + 6 * i;
      w.Ic_S[t] = Ic_row(i, c, Si);
      w.Bc_t_S[t] = col_dot(w.Bc, i, c, Si);
      if (want_dqd) w.E[t] = S(2) * symmetric_row_dot(w.Ic, i, c, w.alpha + 6 * i) + row_dot(w.Bc, i, c, Si);
    }
  });
  g.sync();
  if constexpr (SinglePrecision<S>::value) {
    if (b.tau_input) block_articulated_body(m, w, fext != nullptr, g);
  }

  // M^-1 (computed here into M's matrix, or the caller's), the inversion's pivots, and row i's
  // block (below)
  S* const inverse = w.M;
  S* const pivots = w.pivots;
  auto block_begin = [&](int i) { return m.root_of[i]; };
  auto block_end = [&](int i) { return m.subtree_end[m.root_of[i]]; };

  // d qdd/d u = -M^-1 dc'/du, every entry in parallel (after the inversion); each thread writes
  // its own entries (consecutive items, consecutive addresses) and flags what is not finite.
  // Column j of d tau/d u is zero outside j's block, and so is row i of M^-1 computed here.
  // The outputs' pointers: taken here, or after M^-1 where it goes by the tree's chains (so taken,
  // neither build spills at 64 registers; ptxas's allocation there is chaotic).
  const auto block_outputs = [&] {
    return BlockOutputs<IO>{active ? b.out[output_index(kOutputQdd)] : nullptr,
                            active ? b.out[output_index(kOutputMinv)] : nullptr,
                            active ? b.out[output_index(kOutputDqddDq)] : nullptr,
                            active ? b.out[output_index(kOutputDqddDqd)] : nullptr};
  };
  constexpr bool kChainsBuild = kTreeFixed && kPacked && TreeConstants<Model>::chains;
  BlockOutputs<IO> outputs_before{};
  if constexpr (!kChainsBuild) outputs_before = block_outputs();
  auto write = [&](S x, IO* out, std::uint64_t at) {
    const IO y = static_cast<IO>(x);
    if (!is_finite(y)) *w.not_finite = 1;
    if (out) out[at] = y;
  };
  // -M^-1 dtau for rows 8 p .. 8 p + 7 of column j (item t = p n + j, so that a warp's lanes
  // write consecutive entries of its rows): the eight rows share each load of dtau, and their
  // eight sums are independent chains. A row outside j's block (M^-1 computed here) gives zero.
  // Eight rows an item where there were four: half the loads of dtau a product, 1.5% (f64) and
  // 2.0% (f32 batches) off the kernel at 65536 talos_reduced states, whose busiest unit is the
  // shared-memory pipe (runs 124 and 125, H100; at 64 registers without spills).
  constexpr int kProductRows = 8;
  const int product_items = (n + kProductRows - 1) / kProductRows * n;
  auto minus_product_rows = [&](const S* dtau, int t, IO* out) {
    const int p = by_n.quotient(t), j = t - p * n, first = block_begin(j), end = block_end(j);
    const S* rows[kProductRows];
    S s[kProductRows];
    for (int k = 0; k < kProductRows; ++k) {
      const int i = kProductRows * p + k;
      if constexpr (kPacked) {
        // a row outside j's block (whose sum is not used) reads the block's first row: its own
        // has no entries in j's columns
        const int r = i < n ? i : n - 1;
        rows[k] = inverse + (!minv_supplied && block_begin(r) != first ? row_at(first) : inverse_row(r));
      } else {
        rows[k] = inverse + (i < n ? i : n - 1) * n;
      }
      s[k] = S(0);
    }
    // a tile whose rows are all outside j's block (M^-1 computed here) is zero: no sums
    const int row0 = kProductRows * p;
    const int r_end = minv_supplied || (row0 < end && row0 + kProductRows > first) ? end : first;
    if constexpr (kPacked) {
      // column j of the block, (end - first) apart from row to row
      const int size = end - first;
      const S* const dtau_j = dtau + row_at(first) + j;
      // M^-1's rows two entries a load (the same products in the same order) where the block's
      // rows start at even offsets: the block's at an even offset and of even size (talos_reduced's
      // three; r_end - first, the size or zero, is then even); the lanes of a warp read the same
      // entries (broadcasts). One loop for both forms: as two loops, or pairs and a tail, ptxas
      // spilled talos_reduced's kernel at its 64 registers.
      const bool pairs = kPairs && !minv_supplied && ((row_at(first) + first) & 1) == 0 && (size & 1) == 0;
      for (int r = first; r < r_end; r += pairs ? 2 : 1) {
        const S x0 = dtau_j[(r - first) * size];
        if (pairs) {
          const S x1 = dtau_j[(r + 1 - first) * size];
          for (int k = 0; k < kProductRows; ++k) {
            S a0, a1;
            load_pair(rows[k] + r, a0, a1);
            s[k] += a0 * x0;
            s[k] += a1 * x1;
          }
        } else {
          for (int k = 0; k < kProductRows; ++k) s[k] += rows[k][r] * x0;
        }
      }
    } else {
      for (int r = first; r < r_end; ++r) {
        const S x = dtau[r * n + j];
        for (int k = 0; k < kProductRows; ++k) s[k] += rows[k][r] * x;
      }
    }
    for (int k = 0; k < kProductRows; ++k) {
      const int i = kProductRows * p + k;
      if (i >= n) break;
      write(minv_supplied || block_begin(i) == first ? -s[k] : -S(0), out, state * mat + static_cast<std::uint64_t>(i) * vec + j);
    }
  };

  // The same products by the tree's blocks where the model type fixes the tree and M^-1 is
  // computed here (block_tree_products.hpp: a warp's lanes one block size's code, its offsets
  // constants): a warp for the entries between blocks, then the tiles of every block; qdd's rows.
  // (This order and the finite flag once an item: ptxas spilled talos_reduced's kernels at 64
  // registers in the others tried.)
  constexpr bool kTreeProducts = kTreeFixed && kPacked;
  const bool by_tree = kTreeProducts && !minv_supplied;
  int tree_product_items = 0, tree_row_items = 0;
  if constexpr (kTreeProducts) {
    tree_product_items = tree_block_items(m, false) + tree_zero_items(m);
    tree_row_items = tree_block_items(m, true);
  }
  // the blocks' packed matrices two entries a load where they start at even offsets and are of
  // even size (the lean layout aligns M^-1 to pairs)
  const auto tree_pairs = [](int size, int packed) { return kPairs && packed % 2 == 0 && size % 2 == 0; };
  // (out: the state's matrix, or null)
  auto minus_product_by_tree = [&](const S* dtau, int t, IO* out) {
    if constexpr (kTreeProducts) {
      const int zeros = tree_zero_items(m);
      if (t >= zeros) {
        t -= zeros;
        bool finite = true;
        tree_block_item(m, t, false, [&](int first, int size, int packed, int tile, int col) {
          const bool pairs = tree_pairs(size, packed);
          tree_tile_product<kTreeTileRowsOf<Model>>(inverse + packed, dtau + packed, size, tile, col, pairs,
                                                    [&](int i, int j, S s) {
                                                      const IO y = static_cast<IO>(-s);
                                                      finite &= is_finite(y);
                                                      if (out) out[(first + i) * n + first + j] = y;
                                                    });
        });
        if (!finite) *w.not_finite = 1;
      } else {
        tree_zero_entries(m, t, [&](int i, int j) {
          if (out) out[i * n + j] = static_cast<IO>(-S(0));
        });
      }
    }
  };
  const auto state_matrix = [&](IO* out) { return out ? out + state * mat : out; };
  auto qdd_by_tree = [&](int t) {
    if constexpr (kTreeProducts) {
      tree_block_item(m, t, true, [&](int first, int size, int packed, int row, int) {
        w.qdd[first + row] = tree_row_product(inverse + packed + row * size, w.u + first, size, tree_pairs(size, packed));
      });
    }
  };

  // d tau/d qd and d tau/d q row by row: entry (r, c) is S_r . X_c where r is an ancestor-or-self
  // of c, Ic S_r . Y_c + Bc^T S_r . Z_c where c is a strict ancestor of r (d tau/d qd: X = E,
  // Y = 2 alpha, Z = S, the 2 taken into Ic S_r; d tau/d q: X = Dq, Y = beta, Z = alpha), zero
  // elsewhere: the same products as an item an entry (and its mirror) took. Item t is row t % n,
  // its columns t / n, t / n + G, ... of its block (of every column where dense), G the group's
  // threads over n: a thread keeps its row's vectors in registers, and the lanes of a warp
  // (consecutive rows) read the same column's vectors at once (broadcasts), where an item an entry
  // read both vectors of each product (9.3% off the kernel at 65536 f64 talos_reduced states, 9.7%
  // f32 batches, run 132, H100). The columns before r (its ancestors among them), then from r on
  // (its subtree's first).
  const int row_groups = g.size / n > 1 ? g.size / n : 1;
  const int row_items = n * row_groups;
  // (its threads a row: row_groups, or fewer where the pass leaves a warp to M^-1's chains)
  int dqd_groups = row_groups;
  auto fill_dtau_dqd = [&](int t) {
    const int c0 = by_n.quotient(t), r = t - c0 * n;
    S* const row = w.dtau_dqd + row_at(r);
    int c = (kPacked ? block_begin(r) : 0) + c0;
    {
      S IcSr[6], BcSr[6];
      load6(w.Ic_S + 6 * r, IcSr);
      load6(w.Bc_t_S + 6 * r, BcSr);
      for (int x = 0; x < 6; ++x) IcSr[x] *= S(2);
#if defined(__CUDA_ARCH__)
#pragma unroll 1
#endif
      for (; c < r; c += dqd_groups)
        row[c] = r < m.subtree_end[c] ? dot6_with(IcSr, w.alpha + 6 * c) + dot6_with(BcSr, w.axis + 6 * c) : S(0);
    }
    S Sr[6];
    load6(w.axis + 6 * r, Sr);
    const int end = kPacked ? block_end(r) : n, r_end = m.subtree_end[r];
#if defined(__CUDA_ARCH__)
#pragma unroll 1
#endif
    for (; c < end; c += dqd_groups) row[c] = c < r_end ? dot6_with(Sr, w.E + 6 * c) : S(0);
  };
  // d tau/d q's in two passes: the columns before r in Dq's (they do not need Dq), the rest after
  // it; and before r one of the row's vectors at a time (in one pass and with both, as d tau/d
  // qd's, ptxas spilled at talos_reduced's 64 registers)
  auto fill_dtau_dq_ancestors = [&](int t) {
    const int c0 = by_n.quotient(t), r = t - c0 * n;
    S* const row = w.dtau_dq + row_at(r);
    const int c_first = (kPacked ? block_begin(r) : 0) + c0;
    S v[6];
    load6(w.Ic_S + 6 * r, v);
#if defined(__CUDA_ARCH__)
#pragma unroll 1
#endif
    for (int c = c_first; c < r; c += row_groups)
      row[c] = r < m.subtree_end[c] ? dot6_with(v, w.beta + 6 * c) : S(0);
    load6(w.Bc_t_S + 6 * r, v);
#if defined(__CUDA_ARCH__)
#pragma unroll 1
#endif
    for (int c = c_first; c < r; c += row_groups)
      if (r < m.subtree_end[c]) row[c] += dot6_with(v, w.alpha + 6 * c);
  };
  auto fill_dtau_dq_subtree = [&](int t) {
    const int c0 = by_n.quotient(t), r = t - c0 * n;
    S* const row = w.dtau_dq + row_at(r);
    const int end = kPacked ? block_end(r) : n, r_end = m.subtree_end[r];
    S v[6];
    load6(w.axis + 6 * r, v);
    // the first of the item's columns at or after r (no integer division)
    int c = (kPacked ? block_begin(r) : 0) + c0;
    while (c < r) c += row_groups;
#if defined(__CUDA_ARCH__)
#pragma unroll 1
#endif
    for (; c < end; c += row_groups) row[c] = c < r_end ? dot6_with(v, w.Dq + 6 * c) : S(0);
  };
  const int dqd_fill_items = want_dqd ? row_items : 0;

  // M^-1 into M's matrix (block_mass_inverse.hpp: by the articulated-body recursion, M itself is
  // never formed), a pass a tree level, the first of which also fills d tau/d qd, then a pass of a
  // thread a column; or the caller's M^-1, read by every thread. The tree fixed (the lean kernel
  // compiled for the robot, built so) and its chains fitting one warp: all of it by the chains,
  // on the group's first warp where it has two or more, d tau/d qd's rows on the others, in one
  // pass (block_tree_chains.hpp).
  bool by_chains = false;
  if constexpr (kChainsBuild) {
    // (M^-1's scalars, where the chains leave their P: the packed size, a constant where fixed)
    constexpr int kFixedPacked = FixedSizes<Model>::matrix_scalars;
    const int packed = kFixedPacked > 0 ? kFixedPacked : static_cast<const ModelView<S>&>(m).matrix_scalars;
    by_chains = !minv_supplied && tree_chains_fit(m, packed);
  }
  if (by_chains) {
    if constexpr (kChainsBuild) {
      // (d tau/d qd's rows on the threads the chains leave, if they leave any)
      if (tree_chains_split(g)) dqd_groups = (g.size - 32) / n > 1 ? (g.size - 32) / n : 1;
      tree_mass_inverse<kPairs>(m, w.axis, w.Ic_S, w.IA_S, pivots, w.failed_pivot, inverse, row_at, g,
                                want_dqd ? n * dqd_groups : 0, fill_dtau_dqd);
    }
  } else if (minv_supplied) {
    // the caller's M^-1 (checked by the caller; a value that is not finite shows in the results)
    const IO* minv = b.minv + state * mat;
    g.for_each(n * n + dqd_fill_items, [&](int t) {
      if (t < n * n) inverse[t] = static_cast<S>(minv[t]);
      else fill_dtau_dqd(t - n * n);
    });
  } else {
    articulated_axes<kPairs>(m, w.axis, w.Ic_S, w.IA_S, pivots, w.failed_pivot, g, dqd_fill_items, fill_dtau_dqd);
    // (dense: the entries between blocks, zero)
    const int zero_items = kPacked ? 0 : n * n;
    g.for_each(n + zero_items, [&](int t) {
      if (t < n) {
        inverse_column<kPairs>(m, w.axis, w.IA_S, pivots, inverse, row_at, t);
        return;
      }
      const int e = t - n, i = by_n.quotient(e);
      if (m.root_of[i] != m.root_of[e - i * n]) inverse[e] = S(0);
    });
  }
  g.sync();
  const BlockOutputs<IO> outputs = kChainsBuild ? block_outputs() : outputs_before;
  IO* const out_qdd = outputs.qdd;
  IO* const out_minv = outputs.minv;
  IO* const out_dq = outputs.dq;
  IO* const out_dqd = outputs.dqd;
  // the columns of M^-1 that row i of a product with it needs: row i's block, or every column
  // for a caller's M^-1 (whose entries between blocks are the caller's)
  auto inverse_begin = [&](int i) { return minv_supplied ? 0 : block_begin(i); };
  auto inverse_end = [&](int i) { return minv_supplied ? n : block_end(i); };
  // f64: qdd = M^-1 (tau - c) (u holds tau - c; f32 has qdd from the articulated-body pass), in
  // one pass with the product of d tau/d qd
  const int qdd_items = qdd_by_inverse ? (by_tree ? tree_row_items : n) : 0;
  const int dqd_product_items = want_dqd ? (by_tree ? tree_product_items : product_items) : 0;
  if (qdd_items + dqd_product_items > 0) {
    IO* const dqd_matrix = state_matrix(out_dqd);
    g.for_each(qdd_items + dqd_product_items, [&](int t) {
      if (t >= qdd_items) {
        if (by_tree) minus_product_by_tree(w.dtau_dqd, t - qdd_items, dqd_matrix);
        else minus_product_rows(w.dtau_dqd, t - qdd_items, out_dqd);
        return;
      }
      if (by_tree) {
        qdd_by_tree(t);
        return;
      }
      S s = S(0);
      for (int j = inverse_begin(t); j < inverse_end(t); ++j) s += inverse[inverse_row(t) + j] * w.u[j];
      w.qdd[t] = s;
    });
    g.sync();
  }

  // d tau/d q: the motion due to qdd (prefix sums of S_j qdd_j), then beta and the total subtree
  // force
  if (want_dq) {
    g.for_each(ancestor_items, [&](int t) { ancestor_sums_at(w.axis, w.qdd, w.a_qdd, t, false); });
    g.sync();
    g.for_each(component_items, [&](int t) {
      // beta = a_parent x S + v_parent x alpha with the final a_parent (gravity, v = 0 at the
      // root); the lean layout has the part before qdd from pass 7 (in place).
      // F_total = F + the subtree's sum of I_j a_qdd_j. With a_qdd_j = a_qdd_parent + the sum of
      // S_k qdd_k over k from i to j, that sum is Ic a_qdd_parent + the subtree's sum of
      // Ic_k S_k qdd_k: from Ic and Ic S, so that I and a pass of its own are not needed (in
      // place in F, which only this item reads). Two chains a component, as the subtree sums.
      if constexpr (kLean) {
        const int i = t / 3, r = t - 3 * i, par = m.parent[i];
        const int a = 6 * i + r, l = a + 3;
        S s0[2] = {w.F[a], w.F[l]}, s1[2] = {S(0), S(0)};
        if (par >= 0) {
          S x[2];
          block::cross_motion_pair(w.a_qdd + 6 * par, w.axis + 6 * i, r, x[0], x[1]);
          w.beta[a] += x[0];
          w.beta[l] += x[1];
          Ic_rows_whole(i, r, w.a_qdd + 6 * par, x[0], x[1]);
          s0[0] += x[0];
          s0[1] += x[1];
        }
        const int end = m.subtree_end[i];
        int j = i;
        for (; j + 1 < end; j += 2) {
          const S q0 = w.qdd[j], q1 = w.qdd[j + 1];
          s0[0] += w.Ic_S[6 * j + r] * q0;
          s0[1] += w.Ic_S[6 * j + 3 + r] * q0;
          s1[0] += w.Ic_S[6 * (j + 1) + r] * q1;
          s1[1] += w.Ic_S[6 * (j + 1) + 3 + r] * q1;
        }
        if (j < end) {
          s0[0] += w.Ic_S[6 * j + r] * w.qdd[j];
          s0[1] += w.Ic_S[6 * j + 3 + r] * w.qdd[j];
        }
        w.F_total[a] = s0[0] + s1[0];
        w.F_total[l] = s0[1] + s1[1];
      } else {
        const int i = t / 6, c = t % 6, par = m.parent[i];
        S a_par[6];
        for (int x = 0; x < 6; ++x) a_par[x] = par < 0 ? gravity_at(m, x) : w.a[6 * par + x] + w.a_qdd[6 * par + x];
        S beta = cross_motion_at(a_par, 1, w.axis + 6 * i, 1, c);
        if (par >= 0) beta += cross_motion_at(w.v + 6 * par, 1, w.alpha + 6 * i, 1, c);
        w.beta[t] = beta;
        S s0 = w.F[t] + (par >= 0 ? Ic_row(i, c, w.a_qdd + 6 * par) : S(0)), s1 = S(0);
        const int end = m.subtree_end[i];
        int j = i;
        for (; j + 1 < end; j += 2) {
          s0 += w.Ic_S[6 * j + c] * w.qdd[j];
          s1 += w.Ic_S[6 * (j + 1) + c] * w.qdd[j + 1];
        }
        if (j < end) s0 += w.Ic_S[6 * j + c] * w.qdd[j];
        w.F_total[t] = s0 + s1;
      }
    });
    g.sync();
    // Dq = S x* F + Ic beta + Bc alpha, and d tau/d q's entries before each row's joint (which
    // do not need Dq), then the rest of d tau/d q, as d tau/d qd above
    g.for_each(component_items + row_items, [&](int t) {
      if (t >= component_items) {
        fill_dtau_dq_ancestors(t - component_items);
        return;
      }
      if constexpr (kLean) {
        const int i = t / 3, r = t - 3 * i;
        const S* alpha_i = w.alpha + 6 * i;
        S SF[2], Ic_beta[2], sym[2], anti[2];
        block::cross_force_pair<kWholeCross>(w.axis + 6 * i, w.F_total + 6 * i, r, SF[0], SF[1]);
        Ic_rows(i, r, w.beta + 6 * i, Ic_beta[0], Ic_beta[1]);
        Bc_sym_rows(i, r, alpha_i, sym[0], sym[1]);
        block::cross_force_pair(alpha_i, w.hc + 6 * i, r, anti[0], anti[1]);
        w.Dq[6 * i + r] = SF[0] + Ic_beta[0] + (sym[0] + anti[0]);
        w.Dq[6 * i + 3 + r] = SF[1] + Ic_beta[1] + (sym[1] + anti[1]);
      } else {
        const int i = t / 6, c = t % 6;
        w.Dq[t] = cross_force_at(w.axis + 6 * i, 1, w.F_total + 6 * i, 1, c) + Ic_row(i, c, w.beta + 6 * i) +
                  row_dot(w.Bc, i, c, w.alpha + 6 * i);
      }
    });
    g.sync();
    g.for_each(row_items, [&](int t) { fill_dtau_dq_subtree(t); });
    g.sync();
  }

  // the other outputs: qdd, then the d/dq entries and M^-1 of the stages that ran
  const bool want_minv = (b.outputs & kOutputMinv) != 0;
  const int dq_items = want_dq ? (by_tree ? tree_product_items : product_items) : 0;
  // entry e of M^-1 computed here (the MINV output never comes with a caller's, block_kernel_supports)
  const auto minv_entry = [&](int e) {
    if constexpr (kPacked) {
      const int i = by_n.quotient(e), j = e - i * n;
      return unstored(i, j) ? S(0) : inverse[row_at(i) + j];
    } else {
      return inverse[e];
    }
  };
  // (by the tree: qdd's items whole warps, so that the products' start a warp)
  const int qdd_write_items = by_tree ? whole_warps(n) : n;
  IO* const dq_matrix = state_matrix(out_dq);
  g.for_each(qdd_write_items + dq_items + (want_minv ? n * n : 0), [&](int t) {
    if (t < qdd_write_items) {
      if (t < n) write(w.qdd[t], out_qdd, state * vec + t);
    } else if (t < qdd_write_items + dq_items) {
      if (by_tree) minus_product_by_tree(w.dtau_dq, t - qdd_write_items, dq_matrix);
      else minus_product_rows(w.dtau_dq, t - qdd_write_items, out_dq);
    } else {
      const int e = t - qdd_write_items - dq_items;
      write(minv_entry(e), out_minv, state * mat + e);
    }
  });
  g.sync();
  if (g.rank == 0 && active) {
    // the core's first failing pivot (its order: last joint first) is the largest one that failed
    std::uint32_t s = 0;
    if (*w.failed_pivot != 0) {
      const int pv = static_cast<int>(*w.failed_pivot) - 1;
      s = state_status(is_finite(pivots[pv]) ? Reason::kMassNotPositive : Reason::kMassNotFinite, Algorithm::kNone, pv);
    } else if (*w.not_finite) {
      s = not_finite<S>(Algorithm::kFdDerivatives);
    }
    b.status[state] = s;
  }
}

}  // namespace rbdgrad::cuda
