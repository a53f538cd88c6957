#include "rbdgrad/algorithm/crba.hpp"

#include "numeric_guard.hpp"
#include "rbdgrad/scalar_types.hpp"
#include "world_passes.hpp"

namespace rbdgrad {

template <class S>
Status crba(const ModelTpl<S>& model, WorkspaceTpl<S>& ws, const ConstVectorRef<S>& q) {
  detail::NumericGuard<S> guard("crba");
  // forward pass: placements and body inertias; backward pass: composite inertias, M(r, i) = S_r . Ic_i S_i
  detail::forward_pass<S, detail::Level::kInertia>(model, ws, q.data(), nullptr, nullptr);
  detail::backward_pass<S, detail::Level::kInertia>(model, ws, nullptr, /*with_mass=*/true);
  return guard.finish(ws.M);
}

#define RBDGRAD_INSTANTIATE(S) \
  template Status crba<S>(const ModelTpl<S>&, WorkspaceTpl<S>&, const ConstVectorRef<S>&);
RBDGRAD_FOR_EACH_SCALAR(RBDGRAD_INSTANTIATE)
RBDGRAD_FOR_EACH_REFERENCE_SCALAR(RBDGRAD_INSTANTIATE)

}  // namespace rbdgrad
