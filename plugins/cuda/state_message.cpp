#include "state_message.hpp"

#include <string>

#include "device/state_status.hpp"

namespace rbdgrad::cuda {

namespace {

const char* algorithm_name(Algorithm a) {
  switch (a) {
    case Algorithm::kFdDerivatives: return "fd_derivatives";
    case Algorithm::kMinverse: return "minverse";
    case Algorithm::kForwardDynamics: return "forward_dynamics";
    case Algorithm::kRneaDerivatives: return "rnea_derivatives";
    case Algorithm::kRnea: return "rnea";
    case Algorithm::kCrba: return "crba";
    case Algorithm::kNone: break;
  }
  return "unknown algorithm";
}

}  // namespace

Status state_failure(std::uint32_t status, const Model& model) {
  if (status == 0) return Status::ok();
  const int k = status_joint(status);
  const std::string joint = "joint " + std::to_string(k) + " ('" +
                            (k < model.nv ? model.joints[static_cast<std::size_t>(k)].name : std::string("?")) + "')";
  // the wording of core/src/algorithm/numeric_guard.hpp and minverse.cpp
  switch (status_reason(status)) {
    case Reason::kNotFinite:
      return out_of_range(std::string(algorithm_name(status_algorithm(status))) + ": result is not finite (NaN or Inf)");
    case Reason::kMassNotFinite:
      return out_of_range("mass matrix is not finite at " + joint + ": non-finite input or overflow");
    case Reason::kMassNotPositive:
      return failed_precondition("mass matrix is not positive definite at " + joint +
                                 ": it moves no inertia in this configuration");
    case Reason::kOk: break;
  }
  return Status(StatusCode::kInternal, "unknown state status " + std::to_string(status) + " from the fused kernel");
}

}  // namespace rbdgrad::cuda
