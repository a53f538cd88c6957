// The recursions shared by every algorithm (private header). All spatial quantities are in the
// world frame at the world origin, which turns the derivatives of Algorithm 2 into O(n d) form:
// moving q_j moves the subtree of j rigidly, so d/dq_j of a subtree sum is the rigid-motion term
// S_j x* F plus terms that depend on j only (alpha_j, beta_j) through subtree composites (Ic, Bc).
#pragma once

#include <cmath>

#include "rbdgrad/execution_plan.hpp"
#include "rbdgrad/model.hpp"
#include "rbdgrad/spatial.hpp"
#include "rbdgrad/workspace.hpp"

namespace rbdgrad::detail {

// The passes inline everything they call: each stage set is its own instantiation, and GCC's
// inliner otherwise leaves Eigen's small fixed-size assignments out of line in some of them.
#if defined(__GNUC__) && !defined(__clang__)
#define RBDGRAD_FLATTEN __attribute__((flatten))
#else
#define RBDGRAD_FLATTEN
#endif

// What a pass computes, cumulative.
enum class Level {
  kInertia,      // placements, axes, body inertias (CRBA, M^-1)
  kDynamics,     // + velocities, accelerations, body forces (RNEA)
  kDerivatives,  // + alpha, beta and the Bc operators (derivatives)
};

// (m x*) as a product with a matrix, column by column: out = m x* A
template <class S>
inline void cross_force_columns(const Vec6<S>& m, const Mat6<S>& A, Mat6<S>& out) {
  for (int k = 0; k < 6; ++k) out.col(k) = cross_force<S>(m, A.col(k));
}

// body i placement and joint axis in the world
template <class S>
inline void place_body(const ModelTpl<S>& m, WorkspaceTpl<S>& ws, int i, const S& qi, bool joint_inertia) {
  const int par = m.parent[i];
  const Mat3<S>& R0 = m.joint_rotation[i];
  Mat3<S> Rl;
  Vec3<S> pl = m.joint_translation[i];
  if (m.type[i] == JointType::kRevolute) {
    using std::cos;
    using std::sin;
    const S s = sin(qi), c = cos(qi);
    // R0 * Rz(q): only the first two columns mix
    Rl.col(0) = c * R0.col(0) + s * R0.col(1);
    Rl.col(1) = c * R0.col(1) - s * R0.col(0);
    Rl.col(2) = R0.col(2);
  } else {
    Rl = R0;
    pl += qi * R0.col(2);
  }
  if (par < 0) {
    ws.R[i] = Rl;
    ws.p[i] = pl;
  } else {
    ws.R[i].noalias() = ws.R[par] * Rl;
    ws.p[i] = ws.p[par];
    ws.p[i].noalias() += ws.R[par] * pl;
  }
  const Vec3<S> z = ws.R[i].col(2);
  if (m.type[i] == JointType::kRevolute) {
    ws.axis[i].template head<3>() = z;
    cross3<S>(ws.p[i], z, ws.axis[i].template tail<3>());
  } else {
    ws.axis[i].template head<3>().setZero();
    ws.axis[i].template tail<3>() = z;
  }
  // body inertia in world axes about the world origin, and about the joint point when the
  // articulated-body pass follows
  const Mat3<S>& R = ws.R[i];
  const Vec3<S> c = R * m.com[i];
  const Mat3<S> Icw = R * m.inertia_com[i] * R.transpose();
  if (joint_inertia) spatial_inertia<S>(m.mass[i], c, Icw, ws.I_joint[i]);
  spatial_inertia<S>(m.mass[i], Vec3<S>(c + ws.p[i]), Icw, ws.I[i]);
}

// External force on body i given in its URDF link frame ([moment about the link origin; force]),
// moved to world axes at the world origin.
template <class S>
inline Vec6<S> world_force(const ModelTpl<S>& m, const WorkspaceTpl<S>& ws, int i, const S* fext_link) {
  const Mat3<S> R = ws.R[i] * m.link_rotation[i];
  const Eigen::Map<const Vec3<S>> n(fext_link), fl(fext_link + 3);
  Vec6<S> out;
  out.template tail<3>() = R * fl;
  out.template head<3>() = R * n;
  cross3<S>(ws.p[i], out.template tail<3>(), out.template head<3>(), true);
  return out;
}

// The acceleration the roots' parents (the world) stand at: -g, the fictitious upward
// acceleration that stands for gravity, or zero when the plan turns gravity off. A uniform field
// is one spatial vector for every body in the world frame, so gravity enters only here.
template <class S>
inline Vec6<S> root_acceleration(const ModelTpl<S>& m, bool gravity) {
  Vec6<S> a = Vec6<S>::Zero();
  if (gravity) a.template tail<3>() = -m.gravity;
  return a;
}

// Forward pass over bodies: placement and inertia; at kDynamics also velocity, acceleration
// (qdd = 0 when qdd is null) and body force without external forces (subtract_external_forces);
// at kDerivatives also alpha, B, and beta when kBeta (the d/dq columns need it).
// Initialises the composites (Ic, Bc) with the body's own terms for the backward pass.
// kForAba: also the inertias about the joint points that articulated_body_pass needs.
template <class S, Level kLevel, bool kBeta = true, bool kForAba = false>
RBDGRAD_FLATTEN void forward_pass(const ModelTpl<S>& m, WorkspaceTpl<S>& ws, const S* q, const S* qd, const S* qdd,
                  bool gravity = true) {
  const Vec6<S> a_gravity = root_acceleration(m, gravity);
  for (int i = 0; i < m.nv; ++i) {
    place_body(m, ws, i, q[i], kForAba);
    ws.Ic[i] = ws.I[i];
    if constexpr (kLevel == Level::kInertia) continue;
    else {
      const int par = m.parent[i];
      const Vec6<S>& Si = ws.axis[i];
      const Vec6<S> v_par = par < 0 ? Vec6<S>::Zero() : ws.v[par];
      const Vec6<S>& a_par = par < 0 ? a_gravity : ws.a[par];
      // v x S qd equals v_parent x S qd since S x S = 0
      const Vec6<S> alpha = cross_motion<S>(v_par, Si);
      ws.v[i] = v_par + Si * qd[i];
      ws.a[i] = a_par + alpha * qd[i];
      if (qdd) ws.a[i] += Si * qdd[i];
      ws.alpha[i] = alpha;
      ws.h[i].noalias() = ws.I[i] * ws.v[i];
      ws.f[i].noalias() = ws.I[i] * ws.a[i];
      ws.f[i] += cross_force<S>(ws.v[i], ws.h[i]);
      if constexpr (kLevel == Level::kDerivatives) {
        // beta needs the final accelerations: without qdd, add_acceleration_pass sets it
        if constexpr (kBeta) {
          if (qdd) ws.beta[i] = cross_motion<S>(a_par, Si) + cross_motion<S>(v_par, alpha);
        }
        // B = v x* I - I v x + h-bar with (v x* I)^T = -I v x
        Mat6<S> C;
        cross_force_columns<S>(ws.v[i], ws.I[i], C);
        ws.Bc[i] = C + C.transpose();
        const Mat3<S> hn = skew<S>(ws.h[i].template head<3>());
        const Mat3<S> hf = skew<S>(ws.h[i].template tail<3>());
        ws.Bc[i].template topLeftCorner<3, 3>() -= hn;
        ws.Bc[i].template topRightCorner<3, 3>() -= hf;
        ws.Bc[i].template bottomLeftCorner<3, 3>() -= hf;
      }
    }
  }
}

// The external forces, after the forward pass, off the body forces (f = I a + v x* I v - fext):
// every body, or only those of `bodies` when it is not null (the others' fext is never read).
// Its own loop, so that a call without forces runs none of it.
template <class S>
RBDGRAD_FLATTEN void subtract_external_forces(const ModelTpl<S>& m, WorkspaceTpl<S>& ws, const S* fext,
                                              const BodyMask* bodies) {
  const auto one = [&](int i) { ws.f[i] -= world_force(m, ws, i, fext + 6 * i); };
  if (bodies != nullptr) bodies->for_each(m.nv, one);
  else
    for (int i = 0; i < m.nv; ++i) one(i);
}

// Mass matrix entries of column i and its ancestors: M(r, i) = S_r . (Ic_i S_i) for r ancestor-or-self.
template <class S>
inline void mass_matrix_column(const ModelTpl<S>& m, WorkspaceTpl<S>& ws, int i) {
  ws.u[i].noalias() = ws.Ic[i] * ws.axis[i];
  for (int r = i; r >= 0; r = m.parent[r]) {
    const S value = dot<S>(ws.axis[r], ws.u[i]);
    ws.M(r, i) = value;
    ws.M(i, r) = value;
  }
}

// Backward pass over bodies. Accumulates the subtree force f into the parents and fills
// tau = S . f when kLevel >= kDynamics; with_mass: composite inertias Ic and M (always at
// kDerivatives, which needs Ic). At kDerivatives also Bc, u = Ic S and w = Bc^T S, and the columns
// asked for: dtau_dqd (kDqd), and dtau_dq (kDq; it needs beta, i.e. the final accelerations).
template <class S, Level kLevel, bool kDq = true, bool kDqd = true>
RBDGRAD_FLATTEN void backward_pass(const ModelTpl<S>& m, WorkspaceTpl<S>& ws, VectorX<S>* tau_out, bool with_mass) {
  with_mass = with_mass || kLevel != Level::kDynamics;
  // the composites times [S alpha beta] (Ic) and [S alpha] (Bc), only the columns the stages
  // need, in two small matrix products (they vectorize better than matrix-vector products)
  constexpr int kIcCols = 1 + (kDqd ? 1 : 0) + (kDq ? 1 : 0);  // S, alpha, beta
  constexpr int kBcCols = (kDqd ? 1 : 0) + (kDq ? 1 : 0);      // S, alpha
  constexpr int kIcBeta = kIcCols - 1, kBcAlpha = kBcCols - 1;
  for (int i = m.nv - 1; i >= 0; --i) {
    const int par = m.parent[i];
    const Vec6<S>& Si = ws.axis[i];
    if constexpr (kLevel != Level::kInertia) (*tau_out)(i) = dot<S>(Si, ws.f[i]);
    if constexpr (kLevel != Level::kDerivatives) {
      if (with_mass) mass_matrix_column(m, ws, i);
    } else {
      Eigen::Matrix<S, 6, kIcCols> X;
      X.col(0) = Si;
      if constexpr (kDqd) X.col(1) = ws.alpha[i];
      if constexpr (kDq) X.col(kIcBeta) = ws.beta[i];
      Eigen::Matrix<S, 6, kIcCols> IcX;
      IcX.noalias() = ws.Ic[i] * X;
      ws.u[i] = IcX.col(0);
      ws.w[i].noalias() = ws.Bc[i].transpose() * Si;
      for (int r = i; r >= 0; r = m.parent[r]) {
        const S value = dot<S>(ws.axis[r], ws.u[i]);
        ws.M(r, i) = value;
        ws.M(i, r) = value;
      }
      if constexpr (kBcCols > 0) {
        Eigen::Matrix<S, 6, kBcCols> Y;
        if constexpr (kDqd) Y.col(0) = Si;
        if constexpr (kDq) Y.col(kBcAlpha) = ws.alpha[i];
        Eigen::Matrix<S, 6, kBcCols> BcY;
        BcY.noalias() = ws.Bc[i] * Y;
        // column i, rows r ancestor-or-self of i: d tau_r / d qd_i = S_r . (2 Ic alpha + Bc S),
        // d tau_r / d q_i = S_r . (S x* f + Ic beta + Bc alpha)
        Vec6<S> E, Dq;
        if constexpr (kDqd) E = S(2) * IcX.col(1) + BcY.col(0);
        if constexpr (kDq) Dq = cross_force<S>(Si, ws.f[i]) + IcX.col(kIcBeta) + BcY.col(kBcAlpha);
        for (int r = i; r >= 0; r = m.parent[r]) {
          if constexpr (kDqd) ws.dtau_dqd(r, i) = dot<S>(ws.axis[r], E);
          if constexpr (kDq) ws.dtau_dq(r, i) = dot<S>(ws.axis[r], Dq);
        }
        // row i, columns j strict ancestors of i
        const Vec6<S> u2 = S(2) * ws.u[i];
        for (int j = par; j >= 0; j = m.parent[j]) {
          if constexpr (kDqd) ws.dtau_dqd(i, j) = dot<S>(u2, ws.alpha[j]) + dot<S>(ws.w[i], ws.axis[j]);
          if constexpr (kDq) ws.dtau_dq(i, j) = dot<S>(ws.u[i], ws.beta[j]) + dot<S>(ws.w[i], ws.alpha[j]);
        }
      }
    }
    if (par >= 0) {
      if (with_mass) ws.Ic[par] += ws.Ic[i];
      if constexpr (kLevel != Level::kInertia) ws.f[par] += ws.f[i];
      if constexpr (kLevel == Level::kDerivatives) ws.Bc[par] += ws.Bc[i];
    }
  }
}

// With tau as input, the forward pass ran with qdd = 0 and qdd was found afterwards. Adds the
// motion due to qdd: a += a_qdd, beta from the final accelerations, and I a_qdd either into the
// body forces (kIntoBodyForce, before the backward pass) or into f_qdd (after it, for
// derivative_dq_pass). `gravity` as in forward_pass.
template <class S, bool kIntoBodyForce>
RBDGRAD_FLATTEN void add_acceleration_pass(const ModelTpl<S>& m, WorkspaceTpl<S>& ws, const S* qdd, bool gravity) {
  const Vec6<S> a_gravity = root_acceleration(m, gravity);
  for (int i = 0; i < m.nv; ++i) {
    const int par = m.parent[i];
    const Vec6<S>& Si = ws.axis[i];
    ws.a_qdd[i] = Si * qdd[i];
    if (par >= 0) ws.a_qdd[i] += ws.a_qdd[par];
    // a[par] is already final (parents first)
    const Vec6<S> v_par = par < 0 ? Vec6<S>::Zero() : ws.v[par];
    const Vec6<S>& a_par = par < 0 ? a_gravity : ws.a[par];
    ws.beta[i] = cross_motion<S>(a_par, Si) + cross_motion<S>(v_par, ws.alpha[i]);
    ws.a[i] += ws.a_qdd[i];
    if constexpr (kIntoBodyForce) ws.f[i].noalias() += ws.I[i] * ws.a_qdd[i];
    else ws.f_qdd[i].noalias() = ws.I[i] * ws.a_qdd[i];
  }
}

// Second backward pass, after backward_pass ran with qdd = 0 and add_acceleration_pass put the qdd
// part of the forces in f_qdd: subtree force F = F(qdd = 0) + sum of I a_qdd, then dtau_dq.
template <class S>
RBDGRAD_FLATTEN void derivative_dq_pass(const ModelTpl<S>& m, WorkspaceTpl<S>& ws) {
  for (int i = m.nv - 1; i >= 0; --i) {
    const int par = m.parent[i];
    const Vec6<S>& Si = ws.axis[i];
    const Vec6<S> F = ws.f[i] + ws.f_qdd[i];
    Vec6<S> Dq = cross_force<S>(Si, F);
    Dq.noalias() += ws.Ic[i] * ws.beta[i];
    Dq.noalias() += ws.Bc[i] * ws.alpha[i];
    for (int r = i; r >= 0; r = m.parent[r]) ws.dtau_dq(r, i) = dot<S>(ws.axis[r], Dq);
    for (int j = par; j >= 0; j = m.parent[j])
      ws.dtau_dq(i, j) = dot<S>(ws.u[i], ws.beta[j]) + dot<S>(ws.w[i], ws.alpha[j]);
    if (par >= 0) ws.f_qdd[par] += ws.f_qdd[i];
  }
}

}  // namespace rbdgrad::detail
