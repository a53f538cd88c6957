// The recursions over bodies, ported from core/src/algorithm/world_passes.hpp (the specification):
// all spatial quantities in the world frame at the world origin. Forward pass: placements, RNEA
// motion and body forces (paper 000, Algorithm 1) and the alpha, beta, B terms of its derivatives;
// backward pass: composite inertias, tau, M and the derivatives of tau (Algorithm 2).
#pragma once

#include "model_view.hpp"
#include "workspace_view.hpp"

namespace rbdgrad::cuda {

// What a pass computes, cumulative (core's detail::Level).
enum class Level {
  kInertia,      // placements, axes, body inertias (CRBA, M^-1)
  kDynamics,     // + velocities, accelerations, body forces (RNEA)
  kDerivatives,  // + alpha, beta and the Bc operators (derivatives)
};

template <class S>
RBDGRAD_HD Vec6<S> gravity_acceleration(const ModelView<S>& m) {
  return Vec6<S>{{S(0), S(0), S(0), -m.gravity[0], -m.gravity[1], -m.gravity[2]}};
}

// body i placement, joint axis and inertias in the world
template <class S>
RBDGRAD_HD void place_body(const ModelView<S>& m, const WorkspaceView<S>& ws, int i, S qi, bool joint_inertia) {
  const int par = m.parent[i];
  const Mat3<S> R0 = m.mat3(m.joint_rotation, i);
  Mat3<S> Rl = R0;
  S pl[3] = {m.joint_translation[3 * i], m.joint_translation[3 * i + 1], m.joint_translation[3 * i + 2]};
  if (!m.prismatic[i]) {
    using std::cos;
    using std::sin;
    const S s = sin(qi), c = cos(qi);
    // R0 * Rz(q): only the first two columns mix
    for (int r = 0; r < 3; ++r) {
      Rl.m[3 * r] = c * R0.m[3 * r] + s * R0.m[3 * r + 1];
      Rl.m[3 * r + 1] = c * R0.m[3 * r + 1] - s * R0.m[3 * r];
    }
  } else {
    for (int r = 0; r < 3; ++r) pl[r] += qi * R0.m[3 * r + 2];
  }
  Mat3<S> R;
  Vec3<S> p;
  if (par < 0) {
    R = Rl;
    p = Vec3<S>{{pl[0], pl[1], pl[2]}};
  } else {
    const Mat3<S> Rp = load33(ws.R, par);
    R = mul(Rp, Rl);
    p = load3(ws.p, par);
    const Vec3<S> d = mul(Rp, pl);
    for (int r = 0; r < 3; ++r) p.v[r] += d.v[r];
  }
  store33(ws.R, i, R);
  store3(ws.p, i, p);
  const S z[3] = {R.m[2], R.m[5], R.m[8]};
  Vec6<S> axis;
  if (!m.prismatic[i]) {
    for (int r = 0; r < 3; ++r) axis.v[r] = z[r];
    cross3(p.v, z, axis.v + 3);
  } else {
    for (int r = 0; r < 3; ++r) {
      axis.v[r] = S(0);
      axis.v[r + 3] = z[r];
    }
  }
  store6(ws.axis, i, axis);
  // body inertia in world axes about the world origin, and about the joint point when the
  // articulated-body pass follows
  const Vec3<S> c = mul(R, m.com + 3 * i);
  const Mat3<S> Icw = mul_transposed(mul(R, m.mat3(m.inertia_com, i)), R);
  if (joint_inertia) store66(ws.I_joint, i, spatial_inertia(m.mass[i], c, Icw));
  const Vec3<S> cw{{c.v[0] + p.v[0], c.v[1] + p.v[1], c.v[2] + p.v[2]}};
  store66(ws.I, i, spatial_inertia(m.mass[i], cw, Icw));
}

// External force on body i given in its URDF link frame ([moment about the link origin; force]),
// moved to world axes at the world origin.
template <class S>
RBDGRAD_HD Vec6<S> world_force(const ModelView<S>& m, const WorkspaceView<S>& ws, int i, const S* fext_link) {
  const Mat3<S> R = mul(load33(ws.R, i), m.mat3(m.link_rotation, i));
  const Vec3<S> f = mul(R, fext_link + 3);
  const Vec3<S> n = mul(R, fext_link);
  Vec6<S> out{{n.v[0], n.v[1], n.v[2], f.v[0], f.v[1], f.v[2]}};
  const Vec3<S> p = load3(ws.p, i);
  cross3(p.v, out.v + 3, out.v, true);
  return out;
}

// No joint acceleration: the forward pass then runs with qdd = 0.
struct NoQdd {};

// Forward pass over bodies: placement and inertia; at kDynamics also velocity, acceleration
// (qdd = 0 when it is NoQdd) and body force; at kDerivatives also alpha, beta and B.
// Initialises the composites (Ic, Bc) with the body's own terms for the backward pass.
// for_aba: also the inertias about the joint points that articulated_body_pass needs.
// Qdd: NoQdd, the caller's array (const S*) or a workspace field (Strided<S>).
template <class S, Level kLevel, class Qdd = NoQdd>
RBDGRAD_HD void forward_pass(const ModelView<S>& m, const WorkspaceView<S>& ws, const S* q, const S* qd,
                             const Qdd& qdd, const S* fext, bool for_aba = false) {
  constexpr bool kHasQdd = !std::is_same_v<Qdd, NoQdd>;
  const Vec6<S> a_gravity = gravity_acceleration(m);
  for (int i = 0; i < m.nv; ++i) {
    place_body(m, ws, i, q[i], for_aba);
    const Mat6<S> I = load66(ws.I, i);
    store66(ws.Ic, i, I);
    if constexpr (kLevel != Level::kInertia) {
      const int par = m.parent[i];
      const Vec6<S> Si = load6(ws.axis, i);
      const Vec6<S> v_par = par < 0 ? Vec6<S>{} : load6(ws.v, par);
      const Vec6<S> a_par = par < 0 ? a_gravity : load6(ws.a, par);
      // v x S qd equals v_parent x S qd since S x S = 0
      const Vec6<S> alpha = cross_motion(v_par, Si);
      Vec6<S> v = v_par;
      add_scaled(v, Si, qd[i]);
      Vec6<S> a = a_par;
      add_scaled(a, alpha, qd[i]);
      if constexpr (kHasQdd) add_scaled(a, Si, S(qdd[i]));
      const Vec6<S> h = mul(I, v);
      Vec6<S> f = add(mul(I, a), cross_force(v, h));
      if (fext) {
        const Vec6<S> fe = world_force(m, ws, i, fext + 6 * i);
        for (int k = 0; k < 6; ++k) f.v[k] -= fe.v[k];
      }
      store6(ws.v, i, v);
      store6(ws.a, i, a);
      store6(ws.alpha, i, alpha);
      store6(ws.h, i, h);
      store6(ws.f, i, f);
      if constexpr (kLevel == Level::kDerivatives) {
        // beta needs the final accelerations: without qdd, add_acceleration_pass sets it
        if constexpr (kHasQdd) store6(ws.beta, i, add(cross_motion(a_par, Si), cross_motion(v_par, alpha)));
        // B = v x* I - I v x + h-bar with (v x* I)^T = -I v x
        Mat6<S> C;
        for (int k = 0; k < 6; ++k) {
          Vec6<S> col;
          for (int r = 0; r < 6; ++r) col.v[r] = I.m[6 * r + k];
          const Vec6<S> vc = cross_force(v, col);
          for (int r = 0; r < 6; ++r) C.m[6 * r + k] = vc.v[r];
        }
        Mat6<S> B;
        for (int r = 0; r < 6; ++r)
          for (int k = 0; k < 6; ++k) B.m[6 * r + k] = C.m[6 * r + k] + C.m[6 * k + r];
        const Mat3<S> hn = skew(h.v), hf = skew(h.v + 3);
        for (int r = 0; r < 3; ++r)
          for (int k = 0; k < 3; ++k) {
            B.m[6 * r + k] -= hn.m[3 * r + k];
            B.m[6 * r + k + 3] -= hf.m[3 * r + k];
            B.m[6 * (r + 3) + k] -= hf.m[3 * r + k];
          }
        store66(ws.Bc, i, B);
      }
    }
  }
}

// Mass matrix entries of column i and its ancestors: M(r, i) = S_r . (Ic_i S_i), r ancestor-or-self.
template <class S>
RBDGRAD_HD void mass_matrix_column(const ModelView<S>& m, const WorkspaceView<S>& ws, int i, const Vec6<S>& Ic_Si) {
  store6(ws.u, i, Ic_Si);
  for (int r = i; r >= 0; r = m.parent[r]) {
    const S value = dot(load6(ws.axis, r), Ic_Si);
    ws.M(r, i) = value;
    ws.M(i, r) = value;
  }
}

template <class S>
RBDGRAD_HD void add_into(const Strided<S>& f, int at, int count, const Strided<S>& g, int from) {
  for (int k = 0; k < count; ++k) f[at * count + k] += g[from * count + k];
}

// Backward pass over bodies. Accumulates the subtree force f into the parents and fills
// tau = S . f when kLevel >= kDynamics; with_mass: composite inertias Ic and M (always at
// kDerivatives, which needs Ic); at kDerivatives also Bc and dtau_dqd, and dtau_dq when with_dq
// (it needs beta, i.e. the final accelerations).
template <class S, Level kLevel>
RBDGRAD_HD void backward_pass(const ModelView<S>& m, const WorkspaceView<S>& ws, bool with_mass, bool with_dq) {
  with_mass = with_mass || kLevel != Level::kDynamics;
  for (int i = m.nv - 1; i >= 0; --i) {
    const int par = m.parent[i];
    const Vec6<S> Si = load6(ws.axis, i);
    if constexpr (kLevel != Level::kInertia) ws.tau[i] = dot(Si, load6(ws.f, i));
    if constexpr (kLevel != Level::kDerivatives) {
      if (with_mass) mass_matrix_column(m, ws, i, mul(load66(ws.Ic, i), Si));
    } else {
      const Mat6<S> Ic = load66(ws.Ic, i);
      const Mat6<S> Bc = load66(ws.Bc, i);
      const Vec6<S> alpha = load6(ws.alpha, i);
      const Vec6<S> u = mul(Ic, Si);
      const Vec6<S> Ic_alpha = mul(Ic, alpha);
      const Vec6<S> Bc_S = mul(Bc, Si);
      const Vec6<S> w = mul_transposed(Bc, Si);
      store6(ws.w, i, w);
      mass_matrix_column(m, ws, i, u);
      // column i, rows r ancestor-or-self of i: d tau_r / d qd_i = S_r . (2 Ic alpha + Bc S)
      const Vec6<S> E = add(scaled(Ic_alpha, S(2)), Bc_S);
      Vec6<S> Dq{};
      if (with_dq) {
        const Vec6<S> beta = load6(ws.beta, i);
        Dq = add(add(cross_force(Si, load6(ws.f, i)), mul(Ic, beta)), mul(Bc, alpha));
      }
      for (int r = i; r >= 0; r = m.parent[r]) {
        const Vec6<S> Sr = load6(ws.axis, r);
        ws.dtau_dqd(r, i) = dot(Sr, E);
        if (with_dq) ws.dtau_dq(r, i) = dot(Sr, Dq);
      }
      // row i, columns j strict ancestors of i
      const Vec6<S> u2 = scaled(u, S(2));
      for (int j = par; j >= 0; j = m.parent[j]) {
        const Vec6<S> alpha_j = load6(ws.alpha, j);
        ws.dtau_dqd(i, j) = dot(u2, alpha_j) + dot(w, load6(ws.axis, j));
        if (with_dq) ws.dtau_dq(i, j) = dot(u, load6(ws.beta, j)) + dot(w, alpha_j);
      }
    }
    if (par >= 0) {
      if (with_mass) add_into(ws.Ic, par, 36, ws.Ic, i);
      if constexpr (kLevel != Level::kInertia) add_into(ws.f, par, 6, ws.f, i);
      if constexpr (kLevel == Level::kDerivatives) add_into(ws.Bc, par, 36, ws.Bc, i);
    }
  }
}

// With tau as input, the forward pass ran with qdd = 0 and qdd was found afterwards. Adds the
// motion due to qdd: a += a_qdd, beta from the final accelerations, and I a_qdd either into the
// body forces (before the backward pass) or into f_qdd (after it, for derivative_dq_pass).
template <class S>
RBDGRAD_HD void add_acceleration_pass(const ModelView<S>& m, const WorkspaceView<S>& ws, const Strided<S>& qdd,
                                      bool into_body_force) {
  const Vec6<S> a_gravity = gravity_acceleration(m);
  for (int i = 0; i < m.nv; ++i) {
    const int par = m.parent[i];
    const Vec6<S> Si = load6(ws.axis, i);
    Vec6<S> a_qdd = scaled(Si, qdd[i]);
    if (par >= 0) a_qdd = add(a_qdd, load6(ws.a_qdd, par));
    store6(ws.a_qdd, i, a_qdd);
    // a[par] is already final (parents first)
    const Vec6<S> v_par = par < 0 ? Vec6<S>{} : load6(ws.v, par);
    const Vec6<S> a_par = par < 0 ? a_gravity : load6(ws.a, par);
    store6(ws.beta, i, add(cross_motion(a_par, Si), cross_motion(v_par, load6(ws.alpha, i))));
    store6(ws.a, i, add(load6(ws.a, i), a_qdd));
    const Vec6<S> Ia = mul(load66(ws.I, i), a_qdd);
    if (into_body_force) store6(ws.f, i, add(load6(ws.f, i), Ia));
    else store6(ws.f_qdd, i, Ia);
  }
}

// Second backward pass, after backward_pass ran with qdd = 0 and add_acceleration_pass put the qdd
// part of the forces in f_qdd: subtree force F = F(qdd = 0) + sum of I a_qdd, then dtau_dq.
template <class S>
RBDGRAD_HD void derivative_dq_pass(const ModelView<S>& m, const WorkspaceView<S>& ws) {
  for (int i = m.nv - 1; i >= 0; --i) {
    const int par = m.parent[i];
    const Vec6<S> Si = load6(ws.axis, i);
    const Vec6<S> F = add(load6(ws.f, i), load6(ws.f_qdd, i));
    const Vec6<S> alpha = load6(ws.alpha, i);
    const Vec6<S> Dq =
        add(add(cross_force(Si, F), mul(load66(ws.Ic, i), load6(ws.beta, i))), mul(load66(ws.Bc, i), alpha));
    for (int r = i; r >= 0; r = m.parent[r]) ws.dtau_dq(r, i) = dot(load6(ws.axis, r), Dq);
    const Vec6<S> u = load6(ws.u, i), w = load6(ws.w, i);
    for (int j = par; j >= 0; j = m.parent[j])
      ws.dtau_dq(i, j) = dot(u, load6(ws.beta, j)) + dot(w, load6(ws.alpha, j));
    if (par >= 0) add_into(ws.f_qdd, par, 6, ws.f_qdd, i);
  }
}

}  // namespace rbdgrad::cuda
