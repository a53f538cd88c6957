#include "rbdgrad/workspace.hpp"

#include "rbdgrad/scalar_types.hpp"

namespace rbdgrad {

template <class S>
WorkspaceTpl<S>::WorkspaceTpl(const ModelTpl<S>& model) : nv(model.nv) {
  const int n = model.nv;
  for (VectorX<S>* x : {&tau, &qdd, &D, &Dinv, &aba_d, &aba_u}) x->setZero(n);
  for (MatrixX<S>* x : {&M, &Minv, &dtau_dq, &dtau_dqd, &dqdd_dq, &dqdd_dqd, &L, &Linv}) x->setZero(n, n);
  R.assign(n, Mat3<S>::Zero());
  p.assign(n, Vec3<S>::Zero());
  for (auto* x : {&axis, &v, &a, &a_qdd, &h, &f_qdd, &f, &alpha, &beta, &u, &w, &pA, &U, &aba_a, &aba_axis, &aba_c}) x->assign(n, Vec6<S>::Zero());
  for (auto* x : {&I, &I_joint, &Ic, &Bc, &IA}) x->assign(n, Mat6<S>::Zero());
}

#define RBDGRAD_INSTANTIATE(S) template struct WorkspaceTpl<S>;
RBDGRAD_FOR_EACH_SCALAR(RBDGRAD_INSTANTIATE)
RBDGRAD_FOR_EACH_REFERENCE_SCALAR(RBDGRAD_INSTANTIATE)

}  // namespace rbdgrad
