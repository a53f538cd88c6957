// The articulated-body recursion about each joint point (private header), used by forward
// dynamics and, in f32 and fixed point, by the forward-dynamics gradient.
#pragma once

#include "world_passes.hpp"

namespace rbdgrad::detail {

// Motion vector m about point A, re-expressed about point A + d: [w; v + w x d].
template <class S>
RBDGRAD_ALWAYS_INLINE Vec6<S> shift_motion(const Vec6<S>& m, const Vec3<S>& d) {
  Vec6<S> out = m;
  cross3<S>(m.template head<3>(), d, out.template tail<3>(), true);
  return out;
}

// Force vector f about point A, re-expressed about point A + d: [n - d x f; f].
template <class S>
RBDGRAD_ALWAYS_INLINE Vec6<S> shift_force(const Vec6<S>& f, const Vec3<S>& d) {
  Vec6<S> out = f;
  cross3<S>(f.template tail<3>(), d, out.template head<3>(), true);
  return out;
}

// Any symmetric 6x6 inertia-like operator about point A, re-expressed about A + d:
// T^T I T with T = [[1, 0], [dx, 1]]; blocks [[P, Q], [Q^T, R]] -> P + Q D - D Q^T - D R D, Q - D R.
template <class S>
inline void shift_inertia_add(const Mat6<S>& I, const Vec3<S>& d, Mat6<S>& out) {
  const Mat3<S> D = skew<S>(d);
  const auto P = I.template topLeftCorner<3, 3>();
  const auto Q = I.template topRightCorner<3, 3>();
  const auto Rb = I.template bottomRightCorner<3, 3>();
  const Mat3<S> DR = D * Rb;
  const Mat3<S> QD = Q * D;
  out.template topLeftCorner<3, 3>() += P + QD + QD.transpose() - DR * D;  // D Q^T = -(Q D)^T, D^T = -D
  const Mat3<S> Qn = Q - DR;
  out.template topRightCorner<3, 3>() += Qn;
  out.template bottomLeftCorner<3, 3>() += Qn.transpose();
  out.template bottomRightCorner<3, 3>() += Rb;
}

// Articulated-body algorithm (RBDA table 7.1), after forward_pass<.., kForAba = true> at kDynamics
// or above (world placements, velocities, alpha and joint-point inertias set). Writes qdd. Vectors are in world axes but each body's are
// taken about its own joint point: about the world origin, S^T IA S of a distal joint is the small
// difference of terms of size m |p|^2, which costs three digits in float (Pinocchio's local frames
// avoid this too). Used for forward dynamics and for qdd in fd_derivatives.
// kFext: the external forces (fext, on every body or on those of `bodies` when not null) enter the
// bias forces; without, fext is never read. `gravity` as in forward_pass.
template <class S, bool kFext>
RBDGRAD_FLATTEN void articulated_body_pass(const ModelTpl<S>& m, WorkspaceTpl<S>& ws, const S* qd, const S* tau,
                                           const S* fext, const BodyMask* bodies, bool gravity, S* qdd) {
  const int n = m.nv;
  // joint-centred axis, bias acceleration and bias force of each body
  for (int i = 0; i < n; ++i) {
    const Vec3<S>& p = ws.p[i];
    Vec6<S>& Sj = ws.aba_axis[i];
    if (m.type[i] == JointType::kRevolute) {
      Sj.template head<3>() = ws.R[i].col(2);
      Sj.template tail<3>().setZero();
    } else {
      Sj.template head<3>().setZero();
      Sj.template tail<3>() = ws.R[i].col(2);
    }
    const Vec6<S> v = shift_motion<S>(ws.v[i], p);
    ws.aba_c[i] = shift_motion<S>(ws.alpha[i], p) * qd[i];
    const Vec6<S> hv = ws.I_joint[i] * v;
    ws.pA[i] = cross_force<S>(v, hv);
    ws.IA[i] = ws.I_joint[i];
  }
  // the external forces, about each body's joint point
  if constexpr (kFext) {
    const auto one = [&](int i) { ws.pA[i] -= shift_force<S>(world_force(m, ws, i, fext + 6 * i), ws.p[i]); };
    if (bodies != nullptr) bodies->for_each(n, one);
    else
      for (int i = 0; i < n; ++i) one(i);
  }
  // backward pass: articulated inertias and bias forces, children folded into parents
  for (int i = n - 1; i >= 0; --i) {
    const Vec6<S>& Sj = ws.aba_axis[i];
    ws.U[i].noalias() = ws.IA[i] * Sj;
    ws.aba_d(i) = dot<S>(Sj, ws.U[i]);
    ws.aba_u(i) = tau[i] - dot<S>(Sj, ws.pA[i]);
    const int par = m.parent[i];
    if (par < 0) continue;
    const S dinv = S(1) / ws.aba_d(i);
    const Vec6<S> Ud = ws.U[i] * dinv;
    Mat6<S> Ia = ws.IA[i];
    Ia.noalias() -= Ud * ws.U[i].transpose();
    Vec6<S> pa = ws.pA[i];
    pa.noalias() += Ia * ws.aba_c[i];
    pa += Ud * ws.aba_u(i);
    // move to the parent's joint point
    const Vec3<S> d = ws.p[par] - ws.p[i];
    shift_inertia_add<S>(Ia, d, ws.IA[par]);
    ws.pA[par] += shift_force<S>(pa, d);
  }
  // forward pass: accelerations from the root down, each about its joint point
  const Vec6<S> a_gravity = root_acceleration(m, gravity);
  for (int i = 0; i < n; ++i) {
    const int par = m.parent[i];
    Vec6<S> a = par < 0 ? a_gravity : shift_motion<S>(ws.aba_a[par], Vec3<S>(ws.p[i] - ws.p[par]));
    a += ws.aba_c[i];
    qdd[i] = (ws.aba_u(i) - dot<S>(ws.U[i], a)) / ws.aba_d(i);
    a += ws.aba_axis[i] * qdd[i];
    ws.aba_a[i] = a;
  }
}

}  // namespace rbdgrad::detail
