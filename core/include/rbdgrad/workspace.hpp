// Scratch and outputs of the algorithms for one model and one thread. Sized once when created:
// no algorithm allocates. Fields say their shape and which algorithm fills them.
#pragma once

#include <vector>

#include "rbdgrad/model.hpp"
#include "rbdgrad/spatial.hpp"

namespace rbdgrad {

template <class S>
struct WorkspaceTpl {
  explicit WorkspaceTpl(const ModelTpl<S>& model);

  int nv = 0;

  // outputs
  VectorX<S> tau;        // (nv) rnea, rnea_derivatives, fd_derivatives (= c' = RNEA(q, qd, qdd))
  VectorX<S> qdd;        // (nv) forward_dynamics, fd_derivatives
  MatrixX<S> M;          // (nv x nv) crba and everything that calls it; full symmetric
  MatrixX<S> Minv;       // (nv x nv) minverse, fd_derivatives; full symmetric
  MatrixX<S> dtau_dq;    // (nv x nv) rnea_derivatives, fd_derivatives
  MatrixX<S> dtau_dqd;   // (nv x nv) rnea_derivatives, fd_derivatives
  MatrixX<S> dqdd_dq;    // (nv x nv) fd_derivatives
  MatrixX<S> dqdd_dqd;   // (nv x nv) fd_derivatives

  // M = L^T D L with L unit lower triangular, nonzero only at (i, ancestor of i): factorize_mass_matrix
  MatrixX<S> L;          // (nv x nv) strict lower part used
  VectorX<S> D;          // (nv)
  VectorX<S> Dinv;       // (nv)
  MatrixX<S> Linv;       // (nv x nv) L^-1, same sparsity as L

  // per body, world frame at the world origin
  std::vector<Mat3<S>> R;      // body rotation
  std::vector<Vec3<S>> p;      // body origin
  std::vector<Vec6<S>> axis;   // joint motion subspace S
  std::vector<Vec6<S>> v;      // velocity
  std::vector<Vec6<S>> a;      // acceleration including -gravity
  std::vector<Vec6<S>> a_qdd;  // part of a due to qdd (fd_derivatives with tau input)
  std::vector<Mat6<S>> I;      // body spatial inertia
  std::vector<Mat6<S>> I_joint;  // body spatial inertia about its joint point (world axes)
  std::vector<Mat6<S>> Ic;     // composite inertia of the subtree
  std::vector<Mat6<S>> Bc;     // composite d(force)/d(velocity-like term) operator of the subtree
  std::vector<Vec6<S>> h;      // body momentum I v
  std::vector<Vec6<S>> f_qdd;  // I a_qdd, then summed over the subtree (fd_derivatives, tau input, f64)
  std::vector<Vec6<S>> f;      // body force I a + v x* I v - fext, then subtree force after the backward pass
  std::vector<Vec6<S>> alpha;  // v_parent x S: velocity change per unit of q_i not due to rigid motion
  std::vector<Vec6<S>> beta;   // a_parent x S + v_parent x alpha: same for acceleration
  std::vector<Vec6<S>> u;      // Ic S
  std::vector<Vec6<S>> w;      // Bc^T S

  // articulated-body recursion (forward_dynamics, fd_derivatives with tau input); vectors about
  // each body's joint point, in world axes
  std::vector<Vec6<S>> aba_axis;  // S
  std::vector<Vec6<S>> aba_c;     // velocity-product acceleration (v_parent x S) qd
  std::vector<Mat6<S>> IA;     // articulated inertia of the subtree
  std::vector<Vec6<S>> pA;     // articulated bias force of the subtree
  std::vector<Vec6<S>> U;      // IA S
  std::vector<Vec6<S>> aba_a;  // body acceleration
  VectorX<S> aba_d;            // (nv) S^T IA S
  VectorX<S> aba_u;            // (nv) tau - S^T pA
};

using Workspace = WorkspaceTpl<double>;

}  // namespace rbdgrad
