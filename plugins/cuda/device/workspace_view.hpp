// One thread slot's scratch for the fused kernel: the fields of core's WorkspaceTpl, in device
// memory. The scratch of all slots is one array, interleaved so that element e of slot t is at
// base[e * slots + t]: the threads of a warp run the same loop over the same robot and touch the
// same element at once, so their accesses coalesce.
#pragma once

#include "spatial.hpp"

namespace rbdgrad::cuda {

// One field of one slot: element e at p[e * stride].
template <class S>
struct Strided {
  S* p = nullptr;
  std::size_t stride = 1;
  RBDGRAD_HD S& operator[](int e) const { return p[static_cast<std::size_t>(e) * stride]; }
};

// A row-major nv x nv matrix field.
template <class S>
struct StridedMatrix {
  Strided<S> f;
  int nv = 0;
  RBDGRAD_HD S& operator()(int i, int j) const { return f[i * nv + j]; }
};

// A row-major nv x nv matrix in plain memory (the caller's M^-1).
template <class S>
struct DenseMatrix {
  const S* p = nullptr;
  int nv = 0;
  RBDGRAD_HD S operator()(int i, int j) const { return p[i * nv + j]; }
};

// scalars per body of each per-body or vector field of WorkspaceView, in its constructor's order
inline constexpr int kWorkspaceFields = 29;
constexpr RBDGRAD_HD int workspace_field_size(int k) {
  constexpr int sizes[kWorkspaceFields] = {9, 3, 6, 6, 6, 6, 36, 36, 36, 36, 6, 6, 6, 6, 6,
                                           6, 6, 6, 6, 36, 6, 6, 6, 1, 1, 1, 1, 1, 1};
  return sizes[k];
}
constexpr RBDGRAD_HD int workspace_scalars_per_body() {
  int sum = 0;
  for (int k = 0; k < kWorkspaceFields; ++k) sum += workspace_field_size(k);
  return sum;
}

template <class S>
struct WorkspaceView {
  // per body, world frame at the world origin (as in core/include/rbdgrad/workspace.hpp)
  Strided<S> R, p, axis, v, a, a_qdd, I, I_joint, Ic, Bc, h, f_qdd, f, alpha, beta, u, w;
  // articulated-body recursion, about each body's joint point
  Strided<S> aba_axis, aba_c, IA, pA, U, aba_a, aba_d, aba_u;
  // vectors (nv)
  Strided<S> tau, qdd, D, Dinv;
  // matrices (nv x nv)
  StridedMatrix<S> M, Minv, dtau_dq, dtau_dqd, dqdd_dq, dqdd_dqd, L, Linv;

  // scalars per slot for a model of nv joints
  static RBDGRAD_HD std::size_t scalars(int nv) {
    return static_cast<std::size_t>(kPerBody) * nv + 8u * nv * nv;
  }

  // slot t of `slots` interleaved slots starting at base
  RBDGRAD_HD WorkspaceView(S* base, std::size_t slot, std::size_t slots, int nv)
      : base_(base), slot_(slot), slots_(slots) {
    Strided<S>* const per_body[] = {&R, &p, &axis, &v, &a, &a_qdd, &I, &I_joint, &Ic, &Bc, &h, &f_qdd, &f,
                                    &alpha, &beta, &u, &w, &aba_axis, &aba_c, &IA, &pA, &U, &aba_a,
                                    &aba_d, &aba_u, &tau, &qdd, &D, &Dinv};
    static_assert(sizeof(per_body) / sizeof(per_body[0]) == kFields);
    for (int k = 0; k < kFields; ++k) take(*per_body[k], workspace_field_size(k) * nv);
    StridedMatrix<S>* const matrices[] = {&M, &Minv, &dtau_dq, &dtau_dqd, &dqdd_dq, &dqdd_dqd, &L, &Linv};
    for (StridedMatrix<S>* m : matrices) {
      take(m->f, nv * nv);
      m->nv = nv;
    }
  }

 private:
  // the next `count` elements of this slot
  RBDGRAD_HD void take(Strided<S>& field, int count) {
    field.p = base_ + next_ * slots_ + slot_;
    field.stride = slots_;
    next_ += static_cast<std::size_t>(count);
  }

  static constexpr int kFields = kWorkspaceFields;
  static constexpr int kPerBody = workspace_scalars_per_body();
  S* base_;
  std::size_t slot_, slots_, next_ = 0;
};

// Loads and stores of body i's small fields.
template <class S>
RBDGRAD_HD Vec6<S> load6(const Strided<S>& f, int i) {
  Vec6<S> out;
  for (int k = 0; k < 6; ++k) out.v[k] = f[6 * i + k];
  return out;
}
template <class S>
RBDGRAD_HD void store6(const Strided<S>& f, int i, const Vec6<S>& x) {
  for (int k = 0; k < 6; ++k) f[6 * i + k] = x.v[k];
}
template <class S>
RBDGRAD_HD Vec3<S> load3(const Strided<S>& f, int i) {
  return Vec3<S>{{f[3 * i], f[3 * i + 1], f[3 * i + 2]}};
}
template <class S>
RBDGRAD_HD void store3(const Strided<S>& f, int i, const Vec3<S>& x) {
  for (int k = 0; k < 3; ++k) f[3 * i + k] = x.v[k];
}
template <class S>
RBDGRAD_HD Mat3<S> load33(const Strided<S>& f, int i) {
  Mat3<S> out;
  for (int k = 0; k < 9; ++k) out.m[k] = f[9 * i + k];
  return out;
}
template <class S>
RBDGRAD_HD void store33(const Strided<S>& f, int i, const Mat3<S>& x) {
  for (int k = 0; k < 9; ++k) f[9 * i + k] = x.m[k];
}
template <class S>
RBDGRAD_HD Mat6<S> load66(const Strided<S>& f, int i) {
  Mat6<S> out;
  for (int k = 0; k < 36; ++k) out.m[k] = f[36 * i + k];
  return out;
}
template <class S>
RBDGRAD_HD void store66(const Strided<S>& f, int i, const Mat6<S>& x) {
  for (int k = 0; k < 36; ++k) f[36 * i + k] = x.m[k];
}

}  // namespace rbdgrad::cuda
