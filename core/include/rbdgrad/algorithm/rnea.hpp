// Recursive Newton-Euler: inverse dynamics (paper 000, Algorithm 1).
#pragma once

#include <Eigen/Core>

#include "rbdgrad/execution_plan.hpp"
#include "rbdgrad/model.hpp"
#include "rbdgrad/spatial.hpp"
#include "rbdgrad/status.hpp"
#include "rbdgrad/workspace.hpp"

namespace rbdgrad {

/// tau = ID(q, qd, qdd, fext): the joint forces that produce qdd.
/// \param[in] q    joint positions (dim model.nv)
/// \param[in] qd   joint velocities (dim model.nv)
/// \param[in] qdd  joint accelerations (dim model.nv)
/// \param[in] fext optional external forces, 6 x nv column-major: column i is the spatial force on
///                 body i in its URDF link frame, [moment about the link origin; force]; null for none.
/// \param[out] ws.tau (dim model.nv)
/// Sizes are the caller's duty (check_state); returns an error on NaN/Inf results or fixed-point overflow.
template <class S>
Status rnea(const ModelTpl<S>& model, WorkspaceTpl<S>& ws, const ConstVectorRef<S>& q,
            const ConstVectorRef<S>& qd, const ConstVectorRef<S>& qdd,
            std::type_identity_t<const S*> fext = nullptr);

/// The same under an execution plan: its gravity, and its external forces (none, or on the plan's
/// bodies only: the others' fext is never read). Errors: invalid_argument when the plan does not fit
/// the model or has forces and fext is null.
template <class S>
Status rnea(const ModelTpl<S>& model, WorkspaceTpl<S>& ws, const ConstVectorRef<S>& q,
            const ConstVectorRef<S>& qd, const ConstVectorRef<S>& qdd, const ExecutionPlan& plan,
            std::type_identity_t<const S*> fext);

}  // namespace rbdgrad
