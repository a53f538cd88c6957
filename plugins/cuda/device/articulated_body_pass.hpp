// The articulated-body recursion about each joint point, ported from
// core/src/algorithm/articulated_body_pass.hpp: forward dynamics qdd = FD(q, qd, tau), and qdd for
// the gradient in f32 (about the world origin, S^T IA S of a distal joint loses three digits).
#pragma once

#include "world_passes.hpp"

namespace rbdgrad::cuda {

// Any symmetric 6x6 inertia-like operator about point A, re-expressed about A + d and added to
// body `at` of `out`: T^T I T with T = [[1, 0], [dx, 1]]; blocks [[P, Q], [Q^T, R]] ->
// P + Q D - D Q^T - D R D, Q - D R.
template <class S>
RBDGRAD_HD void shift_inertia_add(const Mat6<S>& I, const S* d, const Strided<S>& out, int at) {
  const Mat3<S> D = skew(d);
  Mat3<S> P, Q, Rb;
  for (int r = 0; r < 3; ++r)
    for (int k = 0; k < 3; ++k) {
      P.m[3 * r + k] = I.m[6 * r + k];
      Q.m[3 * r + k] = I.m[6 * r + k + 3];
      Rb.m[3 * r + k] = I.m[6 * (r + 3) + k + 3];
    }
  const Mat3<S> DR = mul(D, Rb);
  const Mat3<S> QD = mul(Q, D);
  const Mat3<S> DRD = mul(DR, D);
  for (int r = 0; r < 3; ++r)
    for (int k = 0; k < 3; ++k) {
      // D Q^T = -(Q D)^T, D^T = -D
      out[36 * at + 6 * r + k] += P.m[3 * r + k] + QD.m[3 * r + k] + QD.m[3 * k + r] - DRD.m[3 * r + k];
      const S qn = Q.m[3 * r + k] - DR.m[3 * r + k];
      out[36 * at + 6 * r + k + 3] += qn;
      out[36 * at + 6 * (k + 3) + r] += qn;
      out[36 * at + 6 * (r + 3) + k + 3] += Rb.m[3 * r + k];
    }
}

// Articulated-body algorithm (RBDA table 7.1), after forward_pass with for_aba at kDynamics or
// above (world placements, velocities, alpha and joint-point inertias set). Writes qdd.
template <class S>
RBDGRAD_HD void articulated_body_pass(const ModelView<S>& m, const WorkspaceView<S>& ws, const S* qd, const S* tau,
                                      const S* fext, const Strided<S>& qdd) {
  const int n = m.nv;
  // joint-centred axis, bias acceleration and bias force of each body
  for (int i = 0; i < n; ++i) {
    const Vec3<S> p = load3(ws.p, i);
    const Mat3<S> R = load33(ws.R, i);
    const S z[3] = {R.m[2], R.m[5], R.m[8]};
    Vec6<S> Sj{};
    for (int r = 0; r < 3; ++r) Sj.v[m.prismatic[i] ? r + 3 : r] = z[r];
    store6(ws.aba_axis, i, Sj);
    const Vec6<S> v = shift_motion(load6(ws.v, i), p.v);
    store6(ws.aba_c, i, scaled(shift_motion(load6(ws.alpha, i), p.v), qd[i]));
    const Mat6<S> Ij = load66(ws.I_joint, i);
    Vec6<S> pA = cross_force(v, mul(Ij, v));
    if (fext) {
      const Vec6<S> fe = shift_force(world_force(m, ws, i, fext + 6 * i), p.v);
      for (int k = 0; k < 6; ++k) pA.v[k] -= fe.v[k];
    }
    store6(ws.pA, i, pA);
    store66(ws.IA, i, Ij);
  }
  // backward pass: articulated inertias and bias forces, children folded into parents
  for (int i = n - 1; i >= 0; --i) {
    const Vec6<S> Sj = load6(ws.aba_axis, i);
    const Mat6<S> IA = load66(ws.IA, i);
    const Vec6<S> U = mul(IA, Sj);
    store6(ws.U, i, U);
    const Vec6<S> pA = load6(ws.pA, i);
    const S d = dot(Sj, U);
    const S u = tau[i] - dot(Sj, pA);
    ws.aba_d[i] = d;
    ws.aba_u[i] = u;
    const int par = m.parent[i];
    if (par < 0) continue;
    const S dinv = S(1) / d;
    const Vec6<S> Ud = scaled(U, dinv);
    Mat6<S> Ia = IA;
    for (int r = 0; r < 6; ++r)
      for (int k = 0; k < 6; ++k) Ia.m[6 * r + k] -= Ud.v[r] * U.v[k];
    Vec6<S> pa = add(pA, mul(Ia, load6(ws.aba_c, i)));
    add_scaled(pa, Ud, u);
    // move to the parent's joint point
    const Vec3<S> pp = load3(ws.p, par), pi = load3(ws.p, i);
    const S dist[3] = {pp.v[0] - pi.v[0], pp.v[1] - pi.v[1], pp.v[2] - pi.v[2]};
    shift_inertia_add(Ia, dist, ws.IA, par);
    store6(ws.pA, par, add(load6(ws.pA, par), shift_force(pa, dist)));
  }
  // forward pass: accelerations from the root down, each about its joint point
  const Vec6<S> a_gravity = gravity_acceleration(m);
  for (int i = 0; i < n; ++i) {
    const int par = m.parent[i];
    Vec6<S> a = a_gravity;
    if (par >= 0) {
      const Vec3<S> pp = load3(ws.p, par), pi = load3(ws.p, i);
      const S dist[3] = {pi.v[0] - pp.v[0], pi.v[1] - pp.v[1], pi.v[2] - pp.v[2]};
      a = shift_motion(load6(ws.aba_a, par), dist);
    }
    a = add(a, load6(ws.aba_c, i));
    const S x = (ws.aba_u[i] - dot(load6(ws.U, i), a)) / ws.aba_d[i];
    qdd[i] = x;
    add_scaled(a, load6(ws.aba_axis, i), x);
    store6(ws.aba_a, i, a);
  }
}

}  // namespace rbdgrad::cuda
