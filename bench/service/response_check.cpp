// Response checks of service_load (see response_check.hpp).
#include "response_check.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <sstream>
#include <string>

namespace rbdgrad::bench {
namespace {

struct OutputField {
  v1::Output output;
  const char* name;  // the proto field name
  bool matrix;
  const v1::Tensor& (v1::ComputeResponse::*get)() const;
};
constexpr std::array<OutputField, 8> kFields{{
    {v1::OUTPUT_QDD, "qdd", false, &v1::ComputeResponse::qdd},
    {v1::OUTPUT_MINV, "minv", true, &v1::ComputeResponse::minv},
    {v1::OUTPUT_DQDD_DQ, "dqdd_dq", true, &v1::ComputeResponse::dqdd_dq},
    {v1::OUTPUT_DQDD_DQD, "dqdd_dqd", true, &v1::ComputeResponse::dqdd_dqd},
    {v1::OUTPUT_TAU, "tau", false, &v1::ComputeResponse::tau},
    {v1::OUTPUT_DTAU_DQ, "dtau_dq", true, &v1::ComputeResponse::dtau_dq},
    {v1::OUTPUT_DTAU_DQD, "dtau_dqd", true, &v1::ComputeResponse::dtau_dqd},
    {v1::OUTPUT_M, "m", true, &v1::ComputeResponse::m},
}};

double value_at(const std::string& data, std::size_t i) {
  double v;
  std::memcpy(&v, data.data() + i * sizeof(double), sizeof(double));  // bytes carry no alignment
  return v;
}

std::string text(double v) {
  std::ostringstream os;
  os.precision(17);
  os << v;
  return os.str();
}

}  // namespace

Status check_compute_response(const v1::ComputeRequest& request, int nv, const v1::ComputeResponse& response,
                              const v1::ComputeResponse* reference, double tolerance) {
  const std::uint64_t n = request.num_states();
  const std::string pre = "N=" + std::to_string(n) + ": response ";
  if (response.num_states() != n)
    return invalid_argument(pre + "num_states is " + std::to_string(response.num_states()));
  for (const OutputField& f : kFields) {
    const bool wanted = std::find(request.outputs().begin(), request.outputs().end(), f.output) != request.outputs().end();
    const v1::Tensor& t = (response.*f.get)();
    const std::string field = pre + "field '" + f.name + "'";
    if (!wanted) {
      if (!t.data().empty()) return invalid_argument(field + " is present but was not requested");
      continue;
    }
    const std::size_t per_state = static_cast<std::size_t>(nv) * (f.matrix ? nv : 1);
    const std::size_t expected = n * per_state;
    if (t.type() != v1::SCALAR_TYPE_F64)
      return invalid_argument(field + " has type " + v1::ScalarType_Name(t.type()) + ", expected SCALAR_TYPE_F64");
    if (t.data().size() != expected * sizeof(double))
      return invalid_argument(field + " has " + std::to_string(t.data().size()) + " bytes, expected " +
                              std::to_string(expected * sizeof(double)) + " (" + std::to_string(expected) + " f64)");
    const std::string* ref = reference ? &(reference->*f.get)().data() : nullptr;
    if (ref && ref->size() != t.data().size())
      return invalid_argument(field + ": the in-process reference has another size (" + std::to_string(ref->size()) +
                              " bytes)");
    double scale = 1;  // of the current state's block: the largest |reference| in it, at least 1
    for (std::size_t i = 0; i < expected; ++i) {
      if (ref && i % per_state == 0) {
        scale = 1;
        for (std::size_t j = i; j < i + per_state; ++j) scale = std::max(scale, std::fabs(value_at(*ref, j)));
      }
      const double v = value_at(t.data(), i);
      const auto where = [&] {
        return field + " state " + std::to_string(i / per_state) + " element " + std::to_string(i % per_state);
      };
      if (!std::isfinite(v)) return invalid_argument(where() + " is not finite (" + text(v) + ")");
      if (ref) {
        const double r = value_at(*ref, i);
        if (!(std::fabs(v - r) <= tolerance * scale))
          return invalid_argument(where() + " is " + text(v) + ", in-process " + text(r) + " (tolerance " +
                                  text(tolerance) + ")");
      }
    }
  }
  return Status::ok();
}

Status check_echo_response(const EchoRequest& request, const EchoResponse& response) {
  if (response.payload().size() != request.response_bytes())
    return invalid_argument("echo response has " + std::to_string(response.payload().size()) + " payload bytes, expected " +
                            std::to_string(request.response_bytes()));
  return Status::ok();
}

}  // namespace rbdgrad::bench
