// One state of a batch on a group of threads: the forward-dynamics gradient refactored for the GPU
// as paper 000's Algorithm 4 asks. The per-body work of each pass runs in parallel; the recursions
// over the tree become sums over a joint's ancestors (world-frame velocities and accelerations
// are prefix sums of per-joint terms) or over its subtree (a contiguous index range in
// depth-first order), so they need no serial loop over the bodies either; the columns of dc'/du
// and of M^-1 are found in parallel. Only the factorization of M (and, in f32, the
// articulated-body pass) walks the tree. The working set stays in shared memory.
//
// The math is that of fused_state.hpp (the one-thread kernel): the same passes, algorithms and
// checks, so that both kernels fail a state for the same reason and agree to rounding. It covers
// the gradient request of MPC (outputs among qdd, M^-1, d qdd/d q, d qdd/d qd, from tau or qdd,
// with or without external forces, M^-1 computed here); block_kernel_supports says so, and any
// other request goes to the one-thread kernel.
#pragma once

#include <type_traits>

#include "block_articulated_body.hpp"
#include "fused_state.hpp"

namespace rbdgrad::cuda {

inline constexpr std::uint32_t kBlockOutputs = kOutputQdd | kOutputMinv | kOutputDqddDq | kOutputDqddDqd;

template <class S>
RBDGRAD_HD bool block_kernel_supports(const BatchPointers<S>& b) {
  return (b.outputs & ~kBlockOutputs) == 0 && (b.outputs & (kOutputMinv | kOutputDqddDq | kOutputDqddDqd)) != 0 &&
         b.minv == nullptr && b.qd != nullptr && b.u != nullptr;
}

// The articulated-body pass gives qdd from tau in f32 (fd_derivatives says why).
template <class S>
constexpr RBDGRAD_HD bool block_uses_aba(bool tau_input) {
  return std::is_same_v<S, float> && tau_input;
}

namespace block {

// (A x)_k of a 6x6 A at body i of `base`; (A^T x)_k
template <class S>
RBDGRAD_HD S row_dot(const S* base, int i, int k, const S* x) {
  const S* row = base + 36 * i + 6 * k;
  S s = row[0] * x[0];
  for (int c = 1; c < 6; ++c) s += row[c] * x[c];
  return s;
}
template <class S>
RBDGRAD_HD S col_dot(const S* base, int i, int k, const S* x) {
  const S* col = base + 36 * i + k;
  S s = col[0] * x[0];
  for (int r = 1; r < 6; ++r) s += col[6 * r] * x[r];
  return s;
}
template <class S>
RBDGRAD_HD S dot6(const S* a, const S* b) {
  S s = a[0] * b[0];
  for (int k = 1; k < 6; ++k) s += a[k] * b[k];
  return s;
}

// Solves M x = b in place for column col of a row-major matrix X with `stride` columns
// (x(i) = X[i stride + col]) with the factors M = L^T D L (solve_with_factors of mass_inverse.hpp).
template <class S>
RBDGRAD_HD void solve_column(const ModelView<S>& m, const BlockWorkspace<S>& w, S* X, int stride, int col) {
  const int n = m.nv;
  const S* L = w.M;
  auto x = [&](int i) -> S& { return X[i * stride + col]; };
  for (int k = n - 1; k >= 0; --k)
    for (int i = m.parent[k]; i >= 0; i = m.parent[i]) x(i) -= L[k * n + i] * x(k);
  for (int k = 0; k < n; ++k) x(k) *= w.Dinv[k];
  for (int i = 0; i < n; ++i)
    for (int k = m.parent[i]; k >= 0; k = m.parent[k]) x(i) -= L[i * n + k] * x(k);
}

}  // namespace block

// Computes state k of b (block_kernel_supports(b)) with the group's threads and writes its outputs
// and status; an inactive group (past the end of the batch) runs on state k for the syncs' sake
// and writes nothing.
template <class S>
RBDGRAD_HD void block_evaluate_state(const ModelView<S>& m, const BlockWorkspace<S>& w, const BatchPointers<S>& b,
                                     std::uint64_t k, bool active, const ThreadGroup& g) {
  using block::col_dot;
  using block::dot6;
  using block::row_dot;
  const int n = m.nv;
  const std::uint64_t vec = static_cast<std::uint64_t>(n), mat = vec * vec;
  const S* fext = b.fext ? b.fext + k * 6 * vec : nullptr;
  const S ag[6] = {S(0), S(0), S(0), -m.gravity[0], -m.gravity[1], -m.gravity[2]};

  // inputs
  g.for_each(n, [&](int i) {
    w.q[i] = b.q[k * vec + i];
    w.qd[i] = b.qd[k * vec + i];
    w.u[i] = b.u[k * vec + i];
    if (!b.tau_input) w.qdd[i] = w.u[i];
  });
  if (g.rank == 0) *w.status = *w.not_finite = 0;
  // joint transforms in the parent frames
  g.for_each(n, [&](int i) {
    const S* R0 = m.joint_rotation + 9 * i;
    S* Rl = w.R_local + 9 * i;
    S* pl = w.p_local + 3 * i;
    for (int e = 0; e < 9; ++e) Rl[e] = R0[e];
    for (int r = 0; r < 3; ++r) pl[r] = m.joint_translation[3 * i + r];
    const S qi = b.q[k * vec + i];
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
  // world placements: column col of [R p] of body i through its ancestors' transforms
  g.for_each(4 * n, [&](int t) {
    const int i = t / 4, col = t % 4;
    S x[3];
    for (int r = 0; r < 3; ++r) x[r] = col < 3 ? w.R_local[9 * i + 3 * r + col] : w.p_local[3 * i + r];
    for (int j = m.parent[i]; j >= 0; j = m.parent[j]) {
      const S* Rj = w.R_local + 9 * j;
      S y[3];
      for (int r = 0; r < 3; ++r)
        y[r] = Rj[3 * r] * x[0] + Rj[3 * r + 1] * x[1] + Rj[3 * r + 2] * x[2] + (col == 3 ? w.p_local[3 * j + r] : S(0));
      for (int r = 0; r < 3; ++r) x[r] = y[r];
    }
    for (int r = 0; r < 3; ++r) {
      if (col < 3) w.R[9 * i + 3 * r + col] = x[r];
      else w.p[3 * i + r] = x[r];
    }
  });
  g.sync();
  // axes, inertias at the world origin (and the joint points), external forces in the world
  g.for_each(n, [&](int i) {
    Mat3<S> R;
    for (int e = 0; e < 9; ++e) R.m[e] = w.R[9 * i + e];
    const S* p = w.p + 3 * i;
    const S z[3] = {R.m[2], R.m[5], R.m[8]};
    S* axis = w.axis + 6 * i;
    if (!m.prismatic[i]) {
      for (int r = 0; r < 3; ++r) axis[r] = z[r];
      cross3(p, z, axis + 3);
    } else {
      for (int r = 0; r < 3; ++r) {
        axis[r] = S(0);
        axis[r + 3] = z[r];
      }
    }
    const Vec3<S> c = mul(R, m.com + 3 * i);
    const Mat3<S> Icw = mul_transposed(mul(R, m.mat3(m.inertia_com, i)), R);
    if (w.I_joint) {
      const Mat6<S> Ij = spatial_inertia(m.mass[i], c, Icw);
      for (int e = 0; e < 36; ++e) w.I_joint[36 * i + e] = Ij.m[e];
    }
    const Vec3<S> cw{{c.v[0] + p[0], c.v[1] + p[1], c.v[2] + p[2]}};
    const Mat6<S> I = spatial_inertia(m.mass[i], cw, Icw);
    for (int e = 0; e < 36; ++e) w.I[36 * i + e] = I.m[e];
    if (fext) {
      // [moment about the link origin; force] in the URDF link frame -> world axes, world origin
      const Mat3<S> Rlink = mul(R, m.mat3(m.link_rotation, i));
      const Vec3<S> f = mul(Rlink, fext + 6 * i + 3);
      const Vec3<S> nm = mul(Rlink, fext + 6 * i);
      S* out = w.f_ext + 6 * i;
      for (int r = 0; r < 3; ++r) {
        out[r] = nm.v[r];
        out[r + 3] = f.v[r];
      }
      cross3(p, out + 3, out, true);
    }
  });
  g.sync();
  // velocities: sums of S_j qd_j over the ancestors-or-self
  g.for_each(6 * n, [&](int t) {
    const int i = t / 6, c = t % 6;
    S s = S(0);
    for (int j = i; j >= 0; j = m.parent[j]) s += w.axis[6 * j + c] * w.qd[j];
    w.v[t] = s;
  });
  g.sync();
  // alpha = v_parent x S (v x S qd = v_parent x S qd since S x S = 0)
  g.for_each(6 * n, [&](int t) {
    const int i = t / 6, c = t % 6, par = m.parent[i];
    w.alpha[t] = par < 0 ? S(0) : cross_motion(get6(w.v, par), get6(w.axis, i)).v[c];
  });
  g.sync();
  // accelerations with qdd = 0: gravity plus the sums of alpha_j qd_j
  g.for_each(6 * n, [&](int t) {
    const int i = t / 6, c = t % 6;
    S s = ag[c];
    for (int j = i; j >= 0; j = m.parent[j]) s += w.alpha[6 * j + c] * w.qd[j];
    w.a[t] = s;
  });
  g.sync();
  // h = I v (kept in F until the subtree sums) and I a (in f)
  g.for_each(6 * n, [&](int t) {
    const int i = t / 6, c = t % 6;
    w.F[t] = row_dot(w.I, i, c, w.v + 6 * i);
    w.f[t] = row_dot(w.I, i, c, w.a + 6 * i);
  });
  g.sync();
  // body forces f = I a + v x* h - f_ext, and B = v x* I - I v x + h-bar entry by entry
  g.for_each(42 * n, [&](int t) {
    if (t < 6 * n) {
      const int i = t / 6, c = t % 6;
      w.f[t] += cross_force(get6(w.v, i), get6(w.F, i)).v[c] - (fext ? w.f_ext[t] : S(0));
      return;
    }
    const int e = t - 6 * n, i = e / 36, r = (e % 36) / 6, c = e % 6;
    const Vec6<S> v = get6(w.v, i);
    Vec6<S> col_c, col_r;
    for (int x = 0; x < 6; ++x) {
      col_c.v[x] = w.I[36 * i + 6 * x + c];
      col_r.v[x] = w.I[36 * i + 6 * x + r];
    }
    S value = cross_force(v, col_c).v[r] + cross_force(v, col_r).v[c];
    const S* h = w.F + 6 * i;
    // - hn x in the top-left block, - hf x in the two off-diagonal blocks
    auto skew_entry = [](const S* x, int row, int col) -> S {
      const Mat3<S> X = skew(x);
      return X.m[3 * row + col];
    };
    if (r < 3 && c < 3) value -= skew_entry(h, r, c);
    else if (r < 3) value -= skew_entry(h + 3, r, c - 3);
    else if (c < 3) value -= skew_entry(h + 3, r - 3, c);
    w.B[e] = value;
  });
  g.sync();
  // subtree sums (the subtree of i is [i, subtree_end[i])): Ic, Bc, F
  g.for_each(78 * n, [&](int t) {
    const S* from;
    S* to;
    int per, e;
    if (t < 36 * n) {
      from = w.I, to = w.Ic, per = 36, e = t;
    } else if (t < 72 * n) {
      from = w.B, to = w.Bc, per = 36, e = t - 36 * n;
    } else {
      from = w.f, to = w.F, per = 6, e = t - 72 * n;
    }
    const int i = e / per, x = e % per;
    S s = from[e];
    for (int j = i + 1; j < m.subtree_end[i]; ++j) s += from[per * j + x];
    to[e] = s;
  });
  g.sync();
  // per body: Ic S, Bc^T S, E = 2 Ic alpha + Bc S; c = tau(qdd = 0) = S . F
  g.for_each(7 * n, [&](int t) {
    if (t >= 6 * n) {
      const int i = t - 6 * n;
      w.c[i] = dot6(w.axis + 6 * i, w.F + 6 * i);
      return;
    }
    const int i = t / 6, c = t % 6;
    const S* Si = w.axis + 6 * i;
    w.Ic_S[t] = row_dot(w.Ic, i, c, Si);
    w.Bc_t_S[t] = col_dot(w.Bc, i, c, Si);
    w.E[t] = S(2) * row_dot(w.Ic, i, c, w.alpha + 6 * i) + row_dot(w.Bc, i, c, Si);
  });
  g.sync();
  // M and d tau/d qd entry by entry: (a, b) with a ancestor-or-self of b gives column b's entry
  // in row a and row b's entry in column a; entries of unrelated joints are zero
  g.for_each(n * n, [&](int t) {
    const int a = t / n, bb = t % n;
    if (m.contains(a, bb)) {
      const S* Sa = w.axis + 6 * a;
      const S mass = dot6(Sa, w.Ic_S + 6 * bb);
      w.M[a * n + bb] = mass;
      w.M[bb * n + a] = mass;
      w.dtau_dqd[a * n + bb] = dot6(Sa, w.E + 6 * bb);
      if (a != bb) {
        Vec6<S> u2;
        for (int x = 0; x < 6; ++x) u2.v[x] = S(2) * w.Ic_S[6 * bb + x];
        w.dtau_dqd[bb * n + a] = dot6(u2.v, w.alpha + 6 * a) + dot6(w.Bc_t_S + 6 * bb, Sa);
      }
    } else if (!m.contains(bb, a)) {
      w.M[t] = S(0);
      w.dtau_dqd[t] = S(0);
      w.dtau_dq[t] = S(0);
    }
  });
  g.sync();
  if constexpr (std::is_same_v<S, float>) {
    if (b.tau_input) block_articulated_body(m, w, fext != nullptr, g);
  }

  // M = L^T D L in place, leaves first (factorize_mass_matrix); the scaling of row k + 1 by its
  // pivot runs with step k, which neither reads nor writes that row
  for (int kk = n - 1; kk >= 0; --kk) {
    if (g.rank == 0 && *w.status == 0) {
      const S d = w.M[kk * n + kk];
      if (!is_finite(d)) *w.status = state_status(Reason::kMassNotFinite, Algorithm::kNone, kk);
      else if (!(d > S(0))) *w.status = state_status(Reason::kMassNotPositive, Algorithm::kNone, kk);
    }
    g.for_each(n * n + n, [&](int t) {
      if (t < n * n) {
        const int i = t / n, j = t % n;
        if (i != kk && m.contains(i, kk) && m.contains(j, i)) {
          const S a = w.M[kk * n + i] / w.M[kk * n + kk];
          w.M[i * n + j] -= a * w.M[kk * n + j];
        }
        return;
      }
      const int i = t - n * n, prev = kk + 1;
      if (prev < n && i != prev && m.contains(i, prev)) w.M[prev * n + i] /= w.M[prev * n + prev];
    });
    g.sync();
  }
  g.for_each(n, [&](int i) {
    w.D[i] = w.M[i * n + i];
    w.Dinv[i] = S(1) / w.D[i];
  });
  g.sync();
  if constexpr (std::is_same_v<S, double>) {
    // f64: qdd = M^-1 (tau - c) with the factors
    if (b.tau_input) {
      if (g.rank == 0) {
        for (int i = 0; i < n; ++i) w.qdd[i] = w.u[i] - w.c[i];
        block::solve_column(m, w, w.qdd, 1, 0);
      }
      g.sync();
    }
  }

  // the motion due to qdd (prefix sums of S_j qdd_j), then beta and I a_qdd
  g.for_each(6 * n, [&](int t) {
    const int i = t / 6, c = t % 6;
    S s = S(0);
    for (int j = i; j >= 0; j = m.parent[j]) s += w.axis[6 * j + c] * w.qdd[j];
    w.a_qdd[t] = s;
  });
  g.sync();
  g.for_each(6 * n, [&](int t) {
    const int i = t / 6, c = t % 6, par = m.parent[i];
    Vec6<S> a_par, v_par{};
    for (int x = 0; x < 6; ++x) a_par.v[x] = par < 0 ? ag[x] : w.a[6 * par + x] + w.a_qdd[6 * par + x];
    if (par >= 0) v_par = get6(w.v, par);
    w.beta[t] = add(cross_motion(a_par, get6(w.axis, i)), cross_motion(v_par, get6(w.alpha, i))).v[c];
    w.f_qdd[t] = row_dot(w.I, i, c, w.a_qdd + 6 * i);
  });
  g.sync();
  g.for_each(6 * n, [&](int t) {
    const int i = t / 6, c = t % 6;
    S s = w.F[t] + w.f_qdd[t];
    for (int j = i + 1; j < m.subtree_end[i]; ++j) s += w.f_qdd[6 * j + c];
    w.F_total[t] = s;
  });
  g.sync();
  // Dq = S x* F + Ic beta + Bc alpha, then d tau/d q entry by entry as d tau/d qd above
  g.for_each(6 * n, [&](int t) {
    const int i = t / 6, c = t % 6;
    w.Dq[t] = cross_force(get6(w.axis, i), get6(w.F_total, i)).v[c] + row_dot(w.Ic, i, c, w.beta + 6 * i) +
              row_dot(w.Bc, i, c, w.alpha + 6 * i);
  });
  g.sync();
  g.for_each(n * n, [&](int t) {
    const int a = t / n, bb = t % n;
    if (!m.contains(a, bb)) return;
    w.dtau_dq[a * n + bb] = dot6(w.axis + 6 * a, w.Dq + 6 * bb);
    if (a != bb) w.dtau_dq[bb * n + a] = dot6(w.Ic_S + 6 * bb, w.beta + 6 * a) + dot6(w.Bc_t_S + 6 * bb, w.alpha + 6 * a);
  });
  g.sync();

  // the columns of d qdd/d u = -M^-1 dc'/du and of M^-1 in parallel; each thread writes its own
  // outputs and flags what is not finite
  S* const out_qdd = active ? b.out[output_index(kOutputQdd)] : nullptr;
  S* const out_minv = active ? b.out[output_index(kOutputMinv)] : nullptr;
  S* const out_dq = active ? b.out[output_index(kOutputDqddDq)] : nullptr;
  S* const out_dqd = active ? b.out[output_index(kOutputDqddDqd)] : nullptr;
  const bool want_minv = (b.outputs & kOutputMinv) != 0;
  g.for_each((want_minv ? 3 : 2) * n + 1, [&](int t) {
    bool finite = true;
    if (t == 0) {
      for (int i = 0; i < n; ++i) {
        finite = finite && is_finite(w.qdd[i]);
        if (out_qdd) out_qdd[k * vec + i] = w.qdd[i];
      }
    } else if (t <= 2 * n) {
      const int col = (t - 1) % n;
      S* X = t <= n ? w.dtau_dq : w.dtau_dqd;
      S* out = t <= n ? out_dq : out_dqd;
      block::solve_column(m, w, X, n, col);
      for (int i = 0; i < n; ++i) {
        const S x = -X[i * n + col];
        finite = finite && is_finite(x);
        if (out) out[k * mat + static_cast<std::uint64_t>(i) * vec + col] = x;
      }
    } else {
      const int col = t - 1 - 2 * n;
      for (int i = 0; i < n; ++i) w.Minv[i * n + col] = i == col ? S(1) : S(0);
      block::solve_column(m, w, w.Minv, n, col);
      for (int i = 0; i < n; ++i) {
        const S x = w.Minv[i * n + col];
        finite = finite && is_finite(x);
        if (out_minv) out_minv[k * mat + static_cast<std::uint64_t>(i) * vec + col] = x;
      }
    }
    if (!finite) *w.not_finite = 1;
  });
  g.sync();
  if (g.rank == 0 && active) {
    std::uint32_t s = *w.status;
    if (s == 0 && *w.not_finite) s = not_finite<S>(Algorithm::kFdDerivatives);
    b.status[k] = s;
  }
}

}  // namespace rbdgrad::cuda
