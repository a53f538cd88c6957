// The articulated-body recursion about each joint point (device/articulated_body_pass.hpp, the
// specification) as passes of a thread group: qdd for the f32 gradient from tau. Body terms in
// parallel; the recursion a tree level at a time, every joint of a level and every entry of its
// 6x6 in parallel. A parent gathers what its children pass up, so that siblings never write the
// same entry.
#pragma once

#include "block_workspace.hpp"
#include "model_view.hpp"
#include "thread_group.hpp"

namespace rbdgrad::cuda {

// Joint i's axis about its own joint point: rotation or translation along the world z of its frame.
template <class S>
RBDGRAD_HD Vec6<S> joint_point_axis(const ModelView<S>& m, const BlockWorkspace<S>& w, int i) {
  Vec6<S> Sj{};
  const S* R = w.R + 9 * i;
  const int off = m.prismatic[i] ? 3 : 0;
  Sj.v[off] = R[2];
  Sj.v[off + 1] = R[5];
  Sj.v[off + 2] = R[8];
  return Sj;
}

template <class S>
RBDGRAD_HD Vec6<S> get6(const S* x, int i) {
  Vec6<S> out;
  for (int k = 0; k < 6; ++k) out.v[k] = x[6 * i + k];
  return out;
}

// Entry (row, col) of T^T I T, the symmetric 6x6 I about point A re-expressed about A + d
// (shift_inertia_add of articulated_body_pass.hpp, one entry at a time).
template <class S>
RBDGRAD_HD S shifted_inertia_entry(const S* I, const S* d, int row, int col) {
  const Mat3<S> D = skew(d);
  auto Q = [&](int r, int k) { return I[6 * r + k + 3]; };
  auto Rb = [&](int r, int k) { return I[6 * (r + 3) + k + 3]; };
  auto DR = [&](int r, int k) { return D.m[3 * r] * Rb(0, k) + D.m[3 * r + 1] * Rb(1, k) + D.m[3 * r + 2] * Rb(2, k); };
  auto QD = [&](int r, int k) { return Q(r, 0) * D.m[k] + Q(r, 1) * D.m[3 + k] + Q(r, 2) * D.m[6 + k]; };
  if (row < 3 && col < 3) {
    const S DRD = DR(row, 0) * D.m[col] + DR(row, 1) * D.m[3 + col] + DR(row, 2) * D.m[6 + col];
    return I[6 * row + col] + QD(row, col) + QD(col, row) - DRD;
  }
  if (row < 3) return Q(row, col - 3) - DR(row, col - 3);
  if (col < 3) return Q(col, row - 3) - DR(col, row - 3);
  return Rb(row - 3, col - 3);
}

// qdd = FD(q, qd, tau) into w.qdd. Needs the world placements, v, alpha, I_joint and f_ext of
// the forward passes; ends with a sync.
// Model as block_evaluate_state's.
template <class S, class Model>
RBDGRAD_HD void block_articulated_body(const Model& m, const BlockWorkspace<S>& w, bool with_fext,
                                       const ThreadGroup& g) {
  const int n = m.nv;
  // body terms about the joint points
  g.for_each(37 * n, [&](int t) {
    if (t >= n) {
      w.IA[t - n] = w.I_joint[t - n];
      return;
    }
    const int i = t;
    const S* p = w.p + 3 * i;
    const Vec6<S> c = scaled(shift_motion(get6(w.alpha, i), p), w.qd[i]);
    const Vec6<S> v = shift_motion(get6(w.v, i), p);
    Mat6<S> Ij;
    for (int e = 0; e < 36; ++e) Ij.m[e] = w.I_joint[36 * i + e];
    Vec6<S> pA = cross_force(v, mul(Ij, v));
    if (with_fext) {
      const Vec6<S> fe = shift_force(get6(w.f_ext, i), p);
      for (int k = 0; k < 6; ++k) pA.v[k] -= fe.v[k];
    }
    for (int k = 0; k < 6; ++k) {
      w.aba_c[6 * i + k] = c.v[k];
      w.pA[6 * i + k] = pA.v[k];
    }
  });
  g.sync();

  // leaves first: articulated inertias and bias forces, each level folded into its parents
  for (int level = m.levels - 1; level >= 0; --level) {
    const int first = m.level_start[level], count = m.level_start[level + 1] - first;
    // what each joint of the level passes up: Ia = IA - U U^T / d (36), pa (6); and U = IA S,
    // d, u (1). Every item finds U itself (S has three nonzeros: 18 multiply-adds), which saves a
    // pass and its sync.
    g.for_each(43 * count, [&](int t) {
      const int i = m.level_joints[first + t / 43], e = t % 43;
      const Vec6<S> Sj = joint_point_axis(m, w, i);
      const S* IA = w.IA + 36 * i;
      const int off = m.prismatic[i] ? 3 : 0;
      S Ui[6];
      for (int k = 0; k < 6; ++k)
        Ui[k] = IA[6 * k + off] * Sj.v[off] + IA[6 * k + off + 1] * Sj.v[off + 1] + IA[6 * k + off + 2] * Sj.v[off + 2];
      Vec6<S> U;
      for (int k = 0; k < 6; ++k) U.v[k] = Ui[k];
      const S d = dot(Sj, U);
      const S u = w.u[i] - dot(Sj, get6(w.pA, i));
      const S dinv = S(1) / d;
      if (e < 36) {
        const int r = e / 6, k = e % 6;
        w.to_parent[42 * i + e] = IA[e] - Ui[r] * dinv * Ui[k];
      } else if (e < 42) {
        const int r = e - 36;
        const S Ud = Ui[r] * dinv;
        S s = w.pA[6 * i + r];
        for (int k = 0; k < 6; ++k) s += (IA[6 * r + k] - Ud * Ui[k]) * w.aba_c[6 * i + k];
        w.to_parent[42 * i + e] = s + Ud * u;
      } else {
        w.aba_d[i] = d;
        w.aba_u[i] = u;
        for (int k = 0; k < 6; ++k) w.U[6 * i + k] = Ui[k];
      }
    });
    g.sync();
    if (level == 0) break;
    // each parent (one level up) gathers its children's terms, moved to its joint point
    const int pfirst = m.level_start[level - 1], pcount = first - pfirst;
    g.for_each(42 * pcount, [&](int t) {
      const int par = m.level_joints[pfirst + t / 42], e = t % 42;
      for (int c = par + 1; c < m.subtree_end[par]; c = m.subtree_end[c]) {
        const S dist[3] = {w.p[3 * par] - w.p[3 * c], w.p[3 * par + 1] - w.p[3 * c + 1], w.p[3 * par + 2] - w.p[3 * c + 2]};
        const S* up = w.to_parent + 42 * c;
        if (e < 36) {
          w.IA[36 * par + e] += shifted_inertia_entry(up, dist, e / 6, e % 6);
        } else {
          // shift_force(pa, dist), component r: [n + f x d; f]
          const int r = e - 36;
          const S* pa = up + 36;
          const int r1 = (r + 1) % 3, r2 = (r + 2) % 3;
          w.pA[6 * par + r] += r < 3 ? pa[r] + (pa[3 + r1] * dist[r2] - pa[3 + r2] * dist[r1]) : pa[r];
        }
      }
    });
    g.sync();
  }

  // roots first: accelerations about each joint point, and qdd
  for (int level = 0; level < m.levels; ++level) {
    const int first = m.level_start[level], count = m.level_start[level + 1] - first;
    g.for_each(count, [&](int t) {
      const int i = m.level_joints[first + t], par = m.parent[i];
      Vec6<S> a{{S(0), S(0), S(0), -m.gravity[0], -m.gravity[1], -m.gravity[2]}};
      if (par >= 0) {
        const S dist[3] = {w.p[3 * i] - w.p[3 * par], w.p[3 * i + 1] - w.p[3 * par + 1], w.p[3 * i + 2] - w.p[3 * par + 2]};
        a = shift_motion(get6(w.aba_a, par), dist);
      }
      a = add(a, get6(w.aba_c, i));
      const S x = (w.aba_u[i] - dot(get6(w.U, i), a)) / w.aba_d[i];
      w.qdd[i] = x;
      add_scaled(a, joint_point_axis(m, w, i), x);
      for (int k = 0; k < 6; ++k) w.aba_a[6 * i + k] = a.v[k];
    });
    g.sync();
  }
}

}  // namespace rbdgrad::cuda
