// Random states and the request messages of service_load (see workload.hpp).
#include "workload.hpp"

#include <cmath>
#include <numbers>
#include <string>

#include "request_batch.hpp"

namespace rbdgrad::bench {
namespace {

void set_tensor(v1::Tensor& t, const double* values, std::size_t count) {
  t.set_type(v1::SCALAR_TYPE_F64);
  // the host is little-endian (as the wire format), so the doubles' bytes go as they are
  t.set_data(reinterpret_cast<const char*>(values), count * sizeof(double));
}

// the value in [target - 24, target] (or 0..target) whose `size_of` is closest to target, preferring exact
template <class SizeOf>
std::size_t best_fit(std::size_t target, SizeOf size_of) {
  std::size_t best = 0, best_error = SIZE_MAX;
  for (std::size_t v = target > 24 ? target - 24 : 0; v <= target; ++v) {
    const std::size_t s = size_of(v);
    const std::size_t error = s > target ? s - target : target - s;
    if (error < best_error) best = v, best_error = error;
  }
  return best;
}

}  // namespace

StatePool make_state_pool(const Model& model, std::size_t count, v1::InputKind input_kind, std::uint32_t seed) {
  StatePool pool;
  pool.nv = model.nv;
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  const std::size_t nv = static_cast<std::size_t>(model.nv);
  pool.q.resize(count * nv);
  pool.qd.resize(count * nv);
  pool.u.resize(count * nv);
  for (std::size_t k = 0; k < count; ++k) {
    for (std::size_t j = 0; j < nv; ++j) {
      const JointInfo& joint = model.joints[j];
      const bool limited = joint.upper_limit > joint.lower_limit;
      const double mid = limited ? 0.5 * (joint.upper_limit + joint.lower_limit) : 0.0;
      const double half = limited ? 0.5 * (joint.upper_limit - joint.lower_limit) : std::numbers::pi;
      pool.q[k * nv + j] = mid + half * unit(rng);
      pool.qd[k * nv + j] = 2.0 * unit(rng);
      const double u_range = input_kind == v1::INPUT_KIND_QDD ? 5.0 : joint.effort_limit > 0 ? joint.effort_limit : 10.0;
      pool.u[k * nv + j] = u_range * unit(rng);
    }
  }
  return pool;
}

v1::ComputeRequest make_compute_request(const StatePool& pool, std::uint32_t n, const LoadOptions& options) {
  v1::ComputeRequest req;
  req.set_model(options.model);
  req.set_num_states(n);
  req.set_precision(options.precision);
  req.set_input_kind(options.input_kind);
  for (v1::Output o : options.outputs) req.add_outputs(o);
  const std::size_t count = static_cast<std::size_t>(n) * pool.nv;
  set_tensor(*req.mutable_q(), pool.q.data(), count);
  set_tensor(*req.mutable_qd(), pool.qd.data(), count);
  set_tensor(*req.mutable_u(), pool.u.data(), count);
  req.set_backend(v1::BACKEND_AUTO);
  req.set_output_type(v1::SCALAR_TYPE_F64);
  return req;
}

std::size_t expected_response_bytes(const v1::ComputeRequest& request, int nv) {
  v1::ComputeResponse resp;
  resp.set_request_id(request.request_id());
  resp.set_num_states(request.num_states());
  const std::size_t per_vector = static_cast<std::size_t>(request.num_states()) * nv;
  for (int o : request.outputs()) {
    const auto output = static_cast<v1::Output>(o);
    v1::Tensor* t = server::response_tensor(resp, output);
    if (!t) continue;
    t->set_type(v1::SCALAR_TYPE_F64);
    t->mutable_data()->resize((server::is_matrix_output(output) ? per_vector * nv : per_vector) * sizeof(double));
  }
  resp.set_backend(v1::BACKEND_CPU);
  resp.set_precision(request.precision() == v1::PRECISION_AUTO ? v1::PRECISION_F64 : request.precision());
  // typical magnitudes: tens of µs queued, hundreds of µs computing
  resp.mutable_timings()->set_queue_us(20);
  resp.mutable_timings()->set_compute_us(500);
  resp.mutable_timings()->set_total_us(600);
  return resp.ByteSizeLong();
}

EchoRequest make_echo_request(std::size_t request_bytes, std::size_t response_bytes) {
  EchoRequest req;
  EchoResponse probe;
  const std::size_t payload_out = best_fit(response_bytes, [&](std::size_t v) {
    probe.mutable_payload()->resize(v);
    return probe.ByteSizeLong();
  });
  req.set_response_bytes(payload_out);
  const std::size_t payload_in = best_fit(request_bytes, [&](std::size_t v) {
    req.mutable_payload()->resize(v);
    return req.ByteSizeLong();
  });
  req.mutable_payload()->assign(payload_in, '\x5a');
  return req;
}

}  // namespace rbdgrad::bench
