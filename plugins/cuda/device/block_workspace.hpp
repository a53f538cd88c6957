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
  // per body 6x6 (row-major, kBodyMatrixStride apart): inertia at the world origin, its B
  // operator, and their subtree sums
  S *I, *B, *Ic, *Bc;
  // nv x nv row-major: M (M^-1 after the inversion, in place, or the caller's), d tau/d q, d tau/d qd
  S *M, *dtau_dq, *dtau_dqd;
  // articulated-body pass about the joint points (f32 only, null otherwise): inertia about the
  // joint point, articulated inertia, what a body passes to its parent (6x6 then 6), bias force,
  // U = IA S, c = alpha qd about the joint point, acceleration, d = S^T U and u = tau - S^T pA
  S *I_joint, *IA, *to_parent, *pA, *U, *aba_c, *aba_a, *aba_d, *aba_u;
  // state_status of the state (0 = computed so far), and a flag set when an output is not finite
  std::uint32_t *status, *not_finite;

  // scalars of S per state
  static RBDGRAD_HD std::size_t scalars(int nv, bool with_aba) {
    const std::size_t n = static_cast<std::size_t>(nv);
    return (5 + 24 + 90 + 4 * kBodyMatrixStride + (with_aba ? 140 : 0)) * n + 3 * n * n + kStatusScalars;
  }

  RBDGRAD_HD BlockWorkspace(S* base, int nv, bool with_aba) : next_(base) {
    const int n = nv;
    // arrays rather than initializer lists: device code has no std::initializer_list
    S** const vectors[] = {&q, &qd, &u, &qdd, &c};
    for (S** x : vectors) *x = take(n);
    R_local = take(9 * n);
    p_local = take(3 * n);
    R = take(9 * n);
    p = take(3 * n);
    S** const sixes[] = {&axis, &v, &alpha, &a, &beta, &a_qdd, &f, &F, &f_qdd, &F_total, &Ic_S, &Bc_t_S, &E, &Dq, &f_ext};
    for (S** x : sixes) *x = take(6 * n);
    S** const inertias[] = {&I, &B, &Ic, &Bc};
    for (S** x : inertias) *x = take(kBodyMatrixStride * n);
    S** const matrices[] = {&M, &dtau_dq, &dtau_dqd};
    for (S** x : matrices) *x = take(n * n);
    if (with_aba) {
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
    status = flags;
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
