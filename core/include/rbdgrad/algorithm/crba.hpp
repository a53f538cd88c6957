// Composite rigid body algorithm: the joint-space mass matrix.
#pragma once

#include "rbdgrad/algorithm/rnea.hpp"

namespace rbdgrad {

/// M(q), full symmetric.
/// \param[in] q joint positions (dim model.nv)
/// \param[out] ws.M (nv x nv)
template <class S>
Status crba(const ModelTpl<S>& model, WorkspaceTpl<S>& ws, const ConstVectorRef<S>& q);

}  // namespace rbdgrad
