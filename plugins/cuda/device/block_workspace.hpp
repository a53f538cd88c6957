// One state's working set in the block kernel: plain arrays (stride 1) in the block's shared
// memory, carved out of one base pointer. The fields follow core's WorkspaceTpl where they have
// the same meaning; the others are the intermediate terms that the parallel passes of
// block_fused_state.hpp hand to each other.
#pragma once

#include "inertia_parameters.hpp"
#include "spatial.hpp"

namespace rbdgrad::cuda {

// Scalars from one body's 6x6 matrix (row-major) to the next: 36 and one of padding, so that the
// lanes of a warp that take the same entry of consecutive bodies hit different shared-memory
// banks (at 36 doubles apart, 8 lanes share a bank).
inline constexpr int kBodyMatrixStride = 37;
// A symmetric 6x6 matrix (the inertias; B's symmetric part in the lean layout) as its upper
// triangle, row by row: 21 scalars a body (at 21 doubles apart, a warp's lanes hit different banks
// too).
inline constexpr int kSymmetricStride = 21;
RBDGRAD_HD constexpr int symmetric_index(int r, int c) {
  return r <= c ? r * 6 - r * (r - 1) / 2 + (c - r) : c * 6 - c * (c - 1) / 2 + (r - c);
}

// Scalars of a state's d tau/d u (matrix) and M, M^-1 (minv): nv x nv each, or (the compact kernel,
// block_kernel_entry.hpp) packed by the roots' blocks, ModelView::matrix_scalars of them, except
// a caller's M^-1, which stays dense.
// minv_supplied: the caller's M^-1, which the inversion's arrays are not needed for.
struct BlockMatrices {
  int matrix = 0, minv = 0;
  bool minv_supplied = false;
};
RBDGRAD_HD BlockMatrices block_matrices(int nv, int packed_scalars, bool compact, bool minv_supplied) {
  const int dense = nv * nv, matrix = compact ? packed_scalars : dense;
  return {matrix, compact && !minv_supplied ? matrix : dense, minv_supplied};
}

// Two layouts. Both: d tau/d qd and d tau/d q share one matrix (each product with M^-1 follows its
// own), and arrays whose lifetimes do not overlap share memory.
//
// The default (three states of talos_reduced an SM, or four compact): f and E sit where the local
// placements were (dead after the inertias), h in F until the subtree sums, the external forces
// where Bc will be (without the articulated-body pass, which reads them later), the inversion's
// pivots, the d/dq stage's vectors (beta, a_qdd, Dq) and the inversion's IA S in B (dead after the
// subtree sums), the total subtree force in F, in place; B and Bc whole (6x6, kBodyMatrixStride
// apart).
//
// The lean layout (`lean`, the compact kernel's option: eight states of talos_reduced an SM at 128
// threads a state, 26.4 KiB of working set each): I, Ic, B's and Bc's symmetric parts (B_sym,
// Bc_sym) by their nine parameters (inertia_parameters.hpp; Ic's mass in Ic_mass, I's the model's,
// the rates' zero), B's and Bc's antisymmetric parts by h and hc (block_fused_state.hpp), and
// every array placed by its lifetime. The passes of block_fused_state.hpp, numbered, and what each
// array lives through (written .. last read):
//   1 local placements   2 world placements   3 axes, com, Icw, f_ext   4 I, v   5 alpha, h
//   6 a   7 f, B, beta's part known before qdd   8 subtree sums (Ic, Ic_mass, Bc, hc, F)
//   9 Ic S, Bc^T S, E, u = tau - c   10 the inversion (M^-1 without M, and d tau/d qd)
//   11 qdd, d tau/d qd's product   12 a_qdd   13 beta, F_total   14 Dq   15 d tau/d q   16 outputs
// Live from the subtree sums on (or from their first write, passes 3..16 at most): u, qdd, the
// pivots, Ic_mass, axis, alpha, beta, Ic, Bc_sym, hc, F (F_total in place), Ic S and Bc^T S, 64
// scalars a joint. I, v and a are not: beta's part before qdd is taken in pass 7 and F_total's
// part due to qdd by Ic and Ic S (block_fused_state.hpp), so they die in passes 7 and 8. The
// others take turns in what those hold before they are written, and in a region X made of a
// spare region T (12 scalars a joint) and the two matrices after it, free until M^-1 and d tau/d qd
// are written (10): q (0..1), p_local/com (1..4) in F; R_local/Icw (1..4) in Ic; qd (0..6) in
// Ic S; v (4..7) in hc; a (6..7) in F; f_ext (3..7) in Bc_sym; in X: R (2..3) at 0, p (2..4) at
// 9 n, I (4..8) at 12 n, B_sym (7..8) at 21 n, h (5..8) at 0, f (7..8) at 6 n (30 scalars a joint,
// T made longer where the matrices are smaller); in T then: E (9..10) at 0, the inversion's IA S
// (10) at 6 n (not with the caller's M^-1, whose T is 6 scalars a joint), a_qdd (12..13) at 0, Dq
// (14..15) at 0.
// Every 6-vector array of the lean layout, and M^-1 computed here, starts an even number of
// scalars into the state's working set (the arrays before them take even counts: 4 n, 6 n, 9 n
// twice, the spare region 12 n or 30 n less two equal matrices), and the states are an even number
// of scalars apart (scalars()): the block kernel reads them as pairs (scalar_pairs.hpp).
// The f32 articulated-body pass (with_aba, after pass 9) reads R, p, qd, v and f_ext: those then
// get arrays of their own, with the pass's own.
template <class S>
struct BlockWorkspace {
  // per joint vectors (nv): inputs (f64 from tau: u = tau - c, c = tau(qdd = 0), from the pass
  // before the inversion on), qdd
  S *q, *qd, *u, *qdd;
  // per body: local and world placements (row-major 3x3 and 3-vectors)
  S *R_local, *p_local, *R, *p;
  // per body 6-vectors: axis S, velocity, alpha = v_parent x S, acceleration (qdd = 0), beta,
  // motion due to qdd, momentum h = I v and (lean) its subtree sum, body force (qdd = 0), subtree
  // force (qdd = 0, then in place the total, F_total = F), Ic S, Bc^T S, 2 Ic alpha + Bc S, the
  // d tau/d q column term, external force (world)
  S *axis, *v, *alpha, *a, *beta, *a_qdd, *h, *hc, *f, *F, *F_total, *Ic_S, *Bc_t_S, *E, *Dq, *f_ext;
  // per body: the inertia at the world origin and its subtree sum (symmetric, kSymmetricStride
  // apart; the lean layout: their parameters, kInertiaParameterStride apart, and the subtree sums'
  // masses, Ic_mass, null in the default layout); the B operator and its subtree sum (6x6
  // row-major, kBodyMatrixStride apart; null in the lean layout), or their symmetric parts (the
  // lean layout's only, by their parameters)
  S *I, *Ic, *Ic_mass, *B, *Bc, *B_sym, *Bc_sym;
  // nv x nv row-major, or packed by the roots' blocks (the compact kernel): M (M^-1 after the
  // inversion, in place, or the caller's, always dense); d tau/d qd, then d tau/d q, in one matrix
  S *M, *dtau_dq, *dtau_dqd;
  // the inversion's pivots (nv: 1/D, block_mass_inverse.hpp) and U = IA S (6 nv)
  S *pivots, *IA_S;
  // articulated-body pass about the joint points (f32 only, null otherwise): inertia about the
  // joint point, articulated inertia, what a body passes to its parent (6x6 then 6), bias force,
  // U = IA S, c = alpha qd about the joint point, acceleration, d = S^T U and u = tau - S^T pA
  S *I_joint, *IA, *to_parent, *pA, *U, *aba_c, *aba_a, *aba_d, *aba_u;
  // one plus the last joint whose pivot in the inversion of M failed (0 = none), and a flag set
  // when an output is not finite
  std::uint32_t *failed_pivot, *not_finite;

  // the default layout: the scalars before the d/dq stage's vectors in B (the pivots), and IA S
  // after them
  static constexpr int kInversionScalarsPerJoint = 1;
  static_assert(kInversionScalarsPerJoint + 4 * 6 <= kBodyMatrixStride, "the d/dq stage's vectors and IA S fit in B");
  // (enumerators, not static members: NVRTC would emit those as unused globals)
  enum : int {
    // scalars a joint of the default layout, and of the articulated-body pass's arrays (f_ext's
    // among them)
    kScalarsPerJoint = 4 + 24 + 42 + 2 * kSymmetricStride + 2 * kBodyMatrixStride,
    kAbaScalarsPerJoint = 146,
    // the lean layout's: live from the subtree sums on, the spare region T, the region X (T and
    // the two matrices) that the passes before the subtree sums need, and with the
    // articulated-body pass R, p, qd and v (19) besides the pass's arrays
    kLeanLiveScalarsPerJoint = 64,
    kLeanSpareScalarsPerJoint = 12,
    kLeanSpareScalarsPerJointWithCallersInverse = 6,
    kLeanEarlyScalarsPerJoint = 30,
    kLeanAbaScalarsPerJoint = 19 + kAbaScalarsPerJoint,
  };
  // the lean layout's T: 12 scalars a joint (6, E's, with the caller's M^-1), more where X (T and
  // the matrices) would be shorter than the early arrays need
  static RBDGRAD_HD int lean_spare_scalars(int nv, BlockMatrices matrices) {
    const int per_joint =
        matrices.minv_supplied ? kLeanSpareScalarsPerJointWithCallersInverse : kLeanSpareScalarsPerJoint;
    const int spare = per_joint * nv, early = kLeanEarlyScalarsPerJoint * nv;
    const int with_matrices = spare + matrices.matrix + matrices.minv;
    return with_matrices >= early ? spare : early - matrices.matrix - matrices.minv;
  }

  // scalars of S per state, its matrices dense, or as `matrices` says
  static RBDGRAD_HD std::size_t scalars(int nv, bool with_aba) {
    return scalars(nv, with_aba, block_matrices(nv, 0, false, false));
  }
  static RBDGRAD_HD std::size_t scalars(int nv, bool with_aba, BlockMatrices matrices, bool lean = false) {
    const std::size_t n = static_cast<std::size_t>(nv);
    const int per_joint = lean ? kLeanLiveScalarsPerJoint + (with_aba ? kLeanAbaScalarsPerJoint : 0)
                               : kScalarsPerJoint + (with_aba ? kAbaScalarsPerJoint : 0);
    const std::size_t spare = lean ? static_cast<std::size_t>(lean_spare_scalars(nv, matrices)) : 0;
    const std::size_t scalars = static_cast<std::size_t>(per_joint) * n + spare +
                                static_cast<std::size_t>(matrices.matrix) + static_cast<std::size_t>(matrices.minv) +
                                kStatusScalars;
    // the lean layout's states an even number of scalars apart, so that each state's arrays keep
    // the pairs' alignment (scalar_pairs.hpp)
    return lean ? (scalars + 1) / 2 * 2 : scalars;
  }

  RBDGRAD_HD BlockWorkspace(S* base, int nv, bool with_aba)
      : BlockWorkspace(base, nv, with_aba, block_matrices(nv, 0, false, false)) {}
  RBDGRAD_HD BlockWorkspace(S* base, int nv, bool with_aba, BlockMatrices matrices, bool lean = false)
      : next_(base) {
    if (lean) take_lean(nv, lean_spare_scalars(nv, matrices), !matrices.minv_supplied);
    else take_default(nv);
    // (the lean layout's X: T, then these two)
    M = take(matrices.minv);
    dtau_dq = dtau_dqd = take(matrices.matrix);
    if (with_aba) {
      const int n = nv;
      if (lean) {
        // v first, at the even offset the matrices end on: the 6-vectors read whole read it as
        // pairs (scalar_pairs.hpp), and after R, p and qd (13 n) it would be odd for odd n
        v = take(6 * n);
        R = take(9 * n);
        p = take(3 * n);
        qd = take(n);
      }
      f_ext = take(6 * n);
      I_joint = take(36 * n);
      IA = take(36 * n);
      to_parent = take(42 * n);
      S** const aba_sixes[] = {&pA, &U, &aba_c, &aba_a};
      for (S** x : aba_sixes) *x = take(6 * n);
      aba_d = take(n);
      aba_u = take(n);
    } else {
      I_joint = IA = to_parent = pA = U = aba_c = aba_a = aba_d = aba_u = nullptr;
    }
    auto* flags = reinterpret_cast<std::uint32_t*>(take(kStatusScalars));
    failed_pivot = flags;
    not_finite = flags + 1;
  }

 private:
  // two uint32 flags in whole scalars of S (float or double)
  static constexpr std::size_t kStatusScalars = 2;
  // the arrays before the matrices, in each layout (the comment above)
  RBDGRAD_HD void take_default(int n) {
    // arrays rather than initializer lists: device code has no std::initializer_list
    S** const vectors[] = {&q, &qd, &u, &qdd};
    for (S** x : vectors) *x = take(n);
    R_local = take(9 * n);
    p_local = take(3 * n);
    R = take(9 * n);
    p = take(3 * n);
    f = R_local;
    E = R_local + 6 * n;
    S** const sixes[] = {&axis, &v, &alpha, &a, &F, &Ic_S, &Bc_t_S};
    for (S** x : sixes) *x = take(6 * n);
    h = F;
    I = take(kSymmetricStride * n);
    B = take(kBodyMatrixStride * n);
    Ic = take(kSymmetricStride * n);
    Bc = take(kBodyMatrixStride * n);
    Ic_mass = B_sym = Bc_sym = hc = nullptr;  // the lean layout's
    pivots = B;
    S** const late_sixes[] = {&beta, &a_qdd, &Dq, &IA_S};
    for (int k = 0; k < 4; ++k) *late_sixes[k] = B + (kInversionScalarsPerJoint + 6 * k) * n;
    F_total = F;
    f_ext = Bc;  // with the articulated-body pass, which reads them later, an array of their own
  }
  // (with the articulated-body pass v, R, p, qd and f_ext get arrays of their own after the
  // matrices, which follow T: X)
  RBDGRAD_HD void take_lean(int n, int spare_scalars, bool inversion) {
    u = take(n);
    qdd = take(n);
    pivots = take(n);
    Ic_mass = take(n);
    axis = take(6 * n);
    alpha = take(6 * n);
    beta = take(6 * n);
    Ic = take(kInertiaParameterStride * n);
    Bc_sym = take(kInertiaParameterStride * n);
    hc = take(6 * n);
    F = take(6 * n);
    Ic_S = take(6 * n);
    Bc_t_S = take(6 * n);
    S* const spare = take(spare_scalars);
    B = Bc = nullptr;
    F_total = F;
    // before their hosts are written (the comment above)
    p_local = F;
    q = F + 3 * n;
    R_local = Ic;
    qd = Ic_S;
    v = hc;
    a = F;
    f_ext = Bc_sym;
    S* const early = spare;  // X: T and the matrices after it
    R = early;
    p = early + 9 * n;
    I = early + 12 * n;
    B_sym = early + 21 * n;
    h = early;
    f = early + 6 * n;
    E = spare;
    IA_S = inversion ? spare + 6 * n : nullptr;
    a_qdd = spare;
    Dq = spare;
  }
  RBDGRAD_HD S* take(int count) {
    S* at = next_;
    next_ += count;
    return at;
  }
  S* next_;
};

}  // namespace rbdgrad::cuda
