// The derived default of limits.max_message_bytes.
#include "message_size.hpp"

#include <algorithm>
#include <climits>
#include <sstream>

namespace rbdgrad::server {
namespace {

std::string mib(std::uint64_t bytes) {
  std::ostringstream os;
  os.precision(1);
  os << std::fixed << static_cast<double>(bytes) / (1 << 20) << " MiB";
  return os.str();
}

}  // namespace

std::uint64_t largest_compute_message_bytes(std::uint64_t states, std::uint64_t nv) {
  // per state, in f64: q, qd, u (3 nv), M^-1 (nv^2), fext (6 per body, at most nv bodies)
  const std::uint64_t request = 8 * (3 * nv + nv * nv + 6 * nv);
  // qdd, tau (2 nv) and six nv x nv matrices, plus a fallback state index (a varint, <= 5 bytes)
  const std::uint64_t response = 8 * (2 * nv + 6 * nv * nv) + 5;
  return states * std::max(request, response) + kMessageMarginBytes;
}

std::int64_t derived_max_message_bytes(const ModelRegistry& models, std::int64_t max_states_per_request,
                                       std::string& how) {
  const ServedModel* largest = nullptr;
  for (const auto& m : models.models())
    if (largest == nullptr || m->model.nv > largest->model.nv) largest = m.get();
  const std::uint64_t nv = largest == nullptr ? 0 : static_cast<std::uint64_t>(largest->model.nv);
  const std::uint64_t states = static_cast<std::uint64_t>(std::max<std::int64_t>(max_states_per_request, 1));
  const std::uint64_t bytes = largest_compute_message_bytes(states, nv);
  std::ostringstream os;
  os << "derived: the largest request or response of limits.max_states_per_request = " << states << " states of "
     << (largest == nullptr ? std::string("no model") : (largest->scene ? "scene '" : "model '") + largest->name + "'")
     << " (nv " << nv << "; every input and output in f64) plus " << mib(kMessageMarginBytes);
  if (bytes > static_cast<std::uint64_t>(INT_MAX)) {
    os << " is " << mib(bytes) << ", above gRPC's largest message: the limit is 2^31-1 bytes, and fewer states per "
       << "request fit";
    how = os.str();
    return INT_MAX;
  }
  how = os.str();
  return static_cast<std::int64_t>(bytes);
}

}  // namespace rbdgrad::server
