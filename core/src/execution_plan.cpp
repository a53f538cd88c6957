#include "rbdgrad/execution_plan.hpp"

#include <string>

#include "rbdgrad/algorithm/evaluate.hpp"
#include "rbdgrad/scalar_types.hpp"

namespace rbdgrad {

bool BodyMask::set(int body) {
  if (body < 0 || body >= kCapacity) return false;
  words_[static_cast<std::size_t>(body / 64)] |= std::uint64_t{1} << (body % 64);
  return true;
}

bool BodyMask::test(int body) const {
  if (body < 0 || body >= kCapacity) return false;
  return (words_[static_cast<std::size_t>(body / 64)] >> (body % 64)) & 1;
}

bool BodyMask::empty() const {
  for (std::uint64_t w : words_)
    if (w != 0) return false;
  return true;
}

int BodyMask::count() const {
  int n = 0;
  for (std::uint64_t w : words_) n += std::popcount(w);
  return n;
}

int BodyMask::first_at_or_above(int nv) const {
  const int from = nv < 0 ? 0 : nv;
  for (int w = from / 64; w < kWords; ++w) {
    std::uint64_t bits = words_[static_cast<std::size_t>(w)];
    if (w == from / 64) bits &= ~std::uint64_t{0} << (from % 64);
    if (bits != 0) return w * 64 + std::countr_zero(bits);
  }
  return -1;
}

template <class S>
ExecutionPlan plan_request(const ModelTpl<S>& model, std::uint32_t outputs, const void* fext,
                           const void* supplied_minv) {
  ExecutionPlan plan;
  plan.dqdd_dq = (outputs & kOutputDqddDq) != 0;
  plan.dqdd_dqd = (outputs & kOutputDqddDqd) != 0;
  plan.gravity = !(model.gravity.array() == S(0)).all();
  plan.external_forces = fext != nullptr ? ExternalForces::kAllBodies : ExternalForces::kNone;
  plan.minv_supplied = supplied_minv != nullptr;
  return plan;
}

Status check_plan(int nv, const ExecutionPlan& plan, bool has_fext, bool has_minv) {
  if (plan.external_forces != ExternalForces::kNone && !has_fext)
    return invalid_argument("the execution plan has external forces but the request gives none (fext is null)");
  if (plan.external_forces == ExternalForces::kSomeBodies) {
    if (const int b = plan.fext_bodies.first_at_or_above(nv); b >= 0)
      return invalid_argument("the execution plan puts external forces on body " + std::to_string(b) +
                              " but the model has " + std::to_string(nv) + " bodies");
  }
  if (plan.minv_supplied && !has_minv)
    return invalid_argument("the execution plan takes M^-1 from the caller but the request gives none");
  return Status::ok();
}

#define RBDGRAD_INSTANTIATE(S) \
  template ExecutionPlan plan_request<S>(const ModelTpl<S>&, std::uint32_t, const void*, const void*);
RBDGRAD_FOR_EACH_SCALAR(RBDGRAD_INSTANTIATE)
RBDGRAD_FOR_EACH_REFERENCE_SCALAR(RBDGRAD_INSTANTIATE)

}  // namespace rbdgrad
