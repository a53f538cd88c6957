// One state's working set in the block kernel: plain arrays (stride 1) in the block's shared
// memory, carved out of one base pointer. The fields follow core's WorkspaceTpl where they have
// the same meaning; the others are the intermediate terms that the parallel passes of
// block_fused_state.hpp hand to each other.
#pragma once

#include "spatial.hpp"

namespace rbdgrad::cuda {

// Scalars from one body's 6x6 matrix (row-major) to the next: 36 and one of padding, so that the
// lanes of a warp that take the same entry of consecutive bodies hit different shared-memory
// banks (at 36 doubles apart, 8 lanes share a bank).
inline constexpr int kBodyMatrixStride = 37;
// A symmetric 6x6 matrix (the inertias) as its upper triangle, row by row: 21 scalars a body (at
// 21 doubles apart, a warp's lanes hit different banks too).
inline constexpr int kSymmetricStride = 21;
RBDGRAD_HD constexpr int symmetric_index(int r, int c) {
  return r <= c ? r * 6 - r * (r - 1) / 2 + (c - r) : c * 6 - c * (c - 1) / 2 + (r - c);
}

// Scalars of a state's d tau/d u (matrix) and M, M^-1 (minv): nv x nv each, or (the compact kernel,
// block_kernel_entry.hpp) packed by the roots' blocks, ModelView::matrix_scalars of them, except
// a caller's M^-1, which stays dense.
struct BlockMatrices {
  int matrix = 0, minv = 0;
};
RBDGRAD_HD BlockMatrices block_matrices(int nv, int packed_scalars, bool compact, bool minv_supplied) {
  const int dense = nv * nv, matrix = compact ? packed_scalars : dense;
  return {matrix, compact && !minv_supplied ? matrix : dense};
}

// The arrays whose lifetimes do not overlap share memory, so that three states of talos_reduced
// fit an SM's shared memory (at most 66 KiB of working set each): f and E sit where the local
// placements were (dead after the inertias), the external forces where Bc will be (without the
// articulated-body pass, which reads them later), the d/dq stage's vectors in B after the inversion's
// pivots (B is dead after the subtree sums), and d tau/d qd and d tau/d q share one matrix (each
// product with M^-1 follows its own).
template <class S>
struct BlockWorkspace {
  // per joint vectors (nv): inputs, qdd, c = tau(qdd = 0)
  S *q, *qd, *u, *qdd, *c;
  // per body: local and world placements (row-major 3x3 and 3-vectors)
  S *R_local, *p_local, *R, *p;
  // per body 6-vectors: axis S, velocity, alpha = v_parent x S, acceleration (qdd = 0), beta,
  // motion due to qdd, body force (qdd = 0), subtree force, body force due to qdd, total subtree
  // force, Ic S, Bc^T S, 2 Ic alpha + Bc S, the d tau/d q column term, external force (world)
  S *axis, *v, *alpha, *a, *beta, *a_qdd, *f, *F, *f_qdd, *F_total, *Ic_S, *Bc_t_S, *E, *Dq, *f_ext;
  // per body: the inertia at the world origin and its subtree sum (symmetric, kSymmetricStride
  // apart), the B operator and its subtree sum (6x6 row-major, kBodyMatrixStride apart)
  S *I, *B, *Ic, *Bc;
  // nv x nv row-major, or packed by the roots' blocks (the compact kernel): M (M^-1 after the
  // inversion, in place, or the caller's, always dense); d tau/d qd, then d tau/d q, in one matrix
  S *M, *dtau_dq, *dtau_dqd;
  // articulated-body pass about the joint points (f32 only, null otherwise): inertia about the
  // joint point, articulated inertia, what a body passes to its parent (6x6 then 6), bias force,
  // U = IA S, c = alpha qd about the joint point, acceleration, d = S^T U and u = tau - S^T pA
  S *I_joint, *IA, *to_parent, *pA, *U, *aba_c, *aba_a, *aba_d, *aba_u;
  // one plus the last joint whose pivot in the inversion of M failed (0 = none), and a flag set
  // when an output is not finite
  std::uint32_t *failed_pivot, *not_finite;

  // the scalars before the d/dq stage's vectors in B: the inversion's pivots and snapshots
  static constexpr int kInversionScalarsPerJoint = 5;
  static_assert(kInversionScalarsPerJoint + 5 * 6 <= kBodyMatrixStride, "the d/dq stage's vectors fit in B");

  // scalars of S per state, its matrices dense, or as `matrices` says
  static RBDGRAD_HD std::size_t scalars(int nv, bool with_aba) {
    return scalars(nv, with_aba, block_matrices(nv, 0, false, false));
  }
  static RBDGRAD_HD std::size_t scalars(int nv, bool with_aba, BlockMatrices matrices) {
    const std::size_t n = static_cast<std::size_t>(nv);
    return (5 + 24 + 42 + 2 * kSymmetricStride + 2 * kBodyMatrixStride + (with_aba ? 146 : 0)) * n +
           static_cast<std::size_t>(matrices.matrix) + static_cast<std::size_t>(matrices.minv) + kStatusScalars;
  }

  RBDGRAD_HD BlockWorkspace(S* base, int nv, bool with_aba)
      : BlockWorkspace(base, nv, with_aba, block_matrices(nv, 0, false, false)) {}
  RBDGRAD_HD BlockWorkspace(S* base, int nv, bool with_aba, BlockMatrices matrices) : next_(base) {
    const int n = nv;
    // arrays rather than initializer lists: device code has no std::initializer_list
    S** const vectors[] = {&q, &qd, &u, &qdd, &c};
    for (S** x : vectors) *x = take(n);
    R_local = take(9 * n);
    p_local = take(3 * n);
    R = take(9 * n);
    p = take(3 * n);
    f = R_local;
    E = R_local + 6 * n;
    S** const sixes[] = {&axis, &v, &alpha, &a, &F, &Ic_S, &Bc_t_S};
    for (S** x : sixes) *x = take(6 * n);
    I = take(kSymmetricStride * n);
    B = take(kBodyMatrixStride * n);
    Ic = take(kSymmetricStride * n);
    Bc = take(kBodyMatrixStride * n);
    S** const late_sixes[] = {&beta, &a_qdd, &f_qdd, &F_total, &Dq};
    for (int k = 0; k < 5; ++k) *late_sixes[k] = B + (kInversionScalarsPerJoint + 6 * k) * n;
    M = take(matrices.minv);
    dtau_dq = dtau_dqd = take(matrices.matrix);
    if (with_aba) {
      f_ext = take(6 * n);
      I_joint = take(36 * n);
      IA = take(36 * n);
      to_parent = take(42 * n);
      S** const aba_sixes[] = {&pA, &U, &aba_c, &aba_a};
      for (S** x : aba_sixes) *x = take(6 * n);
      aba_d = take(n);
      aba_u = take(n);
    } else {
      f_ext = Bc;
      I_joint = IA = to_parent = pA = U = aba_c = aba_a = aba_d = aba_u = nullptr;
    }
    auto* flags = reinterpret_cast<std::uint32_t*>(take(kStatusScalars));
    failed_pivot = flags;
    not_finite = flags + 1;
  }

 private:
  // two uint32 flags in whole scalars of S (float or double)
  static constexpr std::size_t kStatusScalars = 2;
  RBDGRAD_HD S* take(int count) {
    S* at = next_;
    next_ += count;
    return at;
  }
  S* next_;
};

}  // namespace rbdgrad::cuda
