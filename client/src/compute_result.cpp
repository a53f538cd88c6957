// ComputeResult: checks a received response against its request once, then hands out views
// onto the message's bytes.
#include "compute_result_impl.hpp"

#include <stdexcept>
#include <string>

namespace rbdgrad {

namespace {

int bit_index(Output o) noexcept {
  int i = 0;
  for (std::uint32_t m = mask(o); m > 1; m >>= 1) ++i;
  return i;
}

std::size_t scalar_size(ScalarType t) noexcept { return t == ScalarType::kF32 ? sizeof(float) : sizeof(double); }

const v1::Tensor& tensor_of(const v1::ComputeResponse& r, Output o) {
  switch (o) {
    case Output::kQdd: return r.qdd();
    case Output::kMinv: return r.minv();
    case Output::kDqddDq: return r.dqdd_dq();
    case Output::kDqddDqd: return r.dqdd_dqd();
    case Output::kTau: return r.tau();
    case Output::kDtauDq: return r.dtau_dq();
    case Output::kDtauDqd: return r.dtau_dqd();
    case Output::kM: return r.m();
  }
  return v1::Tensor::default_instance();
}

RpcStatus malformed(const std::string& what) { return {RpcCode::kInternal, "client: malformed response: " + what}; }

}  // namespace

namespace detail {

ComputeResult::Impl& ResultAccess::reset_for_call(ComputeResult& r) {
  if (!r.impl_) r.impl_ = std::make_unique<ComputeResult::Impl>();
  r.impl_->valid = false;
  return *r.impl_;
}

void ResultAccess::invalidate(ComputeResult& r) noexcept {
  if (r.impl_) r.impl_->valid = false;
}

RpcStatus adopt_response(const ExpectedResult& expected, ComputeResult::Impl& impl, double round_trip_us) {
  const v1::ComputeResponse& r = impl.response;
  if (r.num_states() != expected.num_states)
    return malformed(std::to_string(r.num_states()) + " states for a request of " +
                     std::to_string(expected.num_states));
  if (expected.nv < 0) return malformed("the server accepted q of a size that is not a multiple of num_states");
  const auto n = static_cast<std::size_t>(expected.num_states);
  const auto nv = static_cast<std::size_t>(expected.nv);
  impl.data.fill(nullptr);
  // a scene's request may leave the outputs to the scene: then they are what the response holds
  std::uint32_t outputs = expected.outputs;
  if (outputs == 0)
    for (Output o : kEveryOutput)
      if (!tensor_of(r, o).data().empty()) outputs |= mask(o);
  for (Output o : kEveryOutput) {
    if (!(outputs & mask(o))) continue;
    const v1::Tensor& t = tensor_of(r, o);
    // the proto reads an unspecified type as f64
    const bool type_ok = expected.type == ScalarType::kF32 ? t.type() == v1::SCALAR_TYPE_F32
                                                            : t.type() != v1::SCALAR_TYPE_F32;
    if (!type_ok)
      return malformed(std::string("output '") + output_name(o) + "' is not " + scalar_type_name(expected.type));
    const std::size_t want = n * (is_vector_output(o) ? nv : nv * nv) * scalar_size(expected.type);
    if (t.data().size() != want)
      return malformed(std::string("output '") + output_name(o) + "' has " + std::to_string(t.data().size()) +
                       " bytes, expected " + std::to_string(want) + " (N " + std::to_string(n) + ", nv " +
                       std::to_string(nv) + ", " + scalar_type_name(expected.type) + ")");
    impl.data[static_cast<std::size_t>(bit_index(o))] = reinterpret_cast<const unsigned char*>(t.data().data());
  }
  impl.nv = expected.nv;
  impl.outputs = outputs;
  impl.type = expected.type;
  impl.backend = from_proto(r.backend());
  impl.precision = from_proto(r.precision());
  impl.timings = {r.timings().queue_us(), r.timings().compute_us(), r.timings().total_us(), round_trip_us, 1};
  impl.valid = true;
  return RpcStatus::ok();
}

}  // namespace detail

ComputeResult::ComputeResult() = default;
ComputeResult::~ComputeResult() = default;
ComputeResult::ComputeResult(ComputeResult&&) noexcept = default;
ComputeResult& ComputeResult::operator=(ComputeResult&&) noexcept = default;

bool ComputeResult::valid() const noexcept { return impl_ && impl_->valid; }

const std::string& ComputeResult::request_id() const noexcept {
  static const std::string kEmpty;
  return valid() ? impl_->response.request_id() : kEmpty;
}

std::uint32_t ComputeResult::num_states() const noexcept { return valid() ? impl_->response.num_states() : 0; }
int ComputeResult::nv() const noexcept { return valid() ? impl_->nv : 0; }
Backend ComputeResult::backend() const noexcept { return valid() ? impl_->backend : Backend::kAuto; }
const std::string& ComputeResult::backend_mode() const noexcept {
  static const std::string kEmpty;
  return valid() ? impl_->response.backend_mode() : kEmpty;
}
std::span<const std::uint32_t> ComputeResult::fallback_states() const noexcept {
  if (!valid()) return {};
  const auto& states = impl_->response.fallback_states();
  return {states.data(), static_cast<std::size_t>(states.size())};
}
Backend ComputeResult::fallback_backend() const noexcept {
  return valid() && impl_->response.fallback_states_size() > 0 ? detail::from_proto(impl_->response.fallback_backend())
                                                                : Backend::kAuto;
}
Precision ComputeResult::fallback_precision() const noexcept {
  return valid() && impl_->response.fallback_states_size() > 0 ? detail::from_proto(impl_->response.fallback_precision())
                                                                : Precision::kAuto;
}
std::vector<std::string> ComputeResult::failovers() const {
  if (!valid()) return {};
  return {impl_->response.failovers().begin(), impl_->response.failovers().end()};
}
std::vector<ComputePart> ComputeResult::parts() const {
  std::vector<ComputePart> out;
  if (!valid()) return out;
  for (const auto& p : impl_->response.parts())
    out.push_back({detail::from_proto(p.backend()), p.first_state(), p.num_states(), p.compute_us()});
  return out;
}
Precision ComputeResult::precision() const noexcept { return valid() ? impl_->precision : Precision::kAuto; }
ScalarType ComputeResult::output_type() const noexcept { return valid() ? impl_->type : ScalarType::kF64; }
std::uint32_t ComputeResult::outputs() const noexcept { return valid() ? impl_->outputs : 0; }
bool ComputeResult::has(Output o) const noexcept { return (outputs() & mask(o)) != 0; }

const ComputeTimings& ComputeResult::timings() const noexcept {
  static const ComputeTimings kNone;
  return valid() ? impl_->timings : kNone;
}

const unsigned char* ComputeResult::checked_data(Output o, ScalarType type, View view, std::uint32_t k) const {
  // messages are built only on the error paths: a view in a hot loop does not allocate
  auto name = [o] { return std::string("ComputeResult: output '") + output_name(o) + "'"; };
  if (!valid()) throw std::invalid_argument(name() + ": the result is empty (no successful call filled it)");
  if (!has(o)) {
    std::string present;
    for (Output p : kEveryOutput)
      if (has(p)) present += (present.empty() ? "" : ", ") + std::string(output_name(p));
    throw std::invalid_argument(name() + " was not requested (the result holds " + present + ")");
  }
  if (type != impl_->type)
    throw std::invalid_argument(name() + " holds " + scalar_type_name(impl_->type) + " values (the request's output_type): use the " +
                                (impl_->type == ScalarType::kF32 ? "_f32 views" : "f64 views"));
  if (view == View::kVector && !is_vector_output(o)) throw std::invalid_argument(name() + " is a matrix: use matrix()");
  if (view == View::kMatrix && is_vector_output(o)) throw std::invalid_argument(name() + " is a vector: use vector()");
  const unsigned char* data = impl_->data[static_cast<std::size_t>(bit_index(o))];
  if (view == View::kBlock) return data;
  if (k >= num_states())
    throw std::out_of_range(name() + ": state " + std::to_string(k) + " of a result of " +
                            std::to_string(num_states()) + " states");
  const auto nv = static_cast<std::size_t>(impl_->nv);
  return data + k * (is_vector_output(o) ? nv : nv * nv) * scalar_size(type);
}

std::span<const double> ComputeResult::block(Output o) const {
  const auto* p = reinterpret_cast<const double*>(checked_data(o, ScalarType::kF64, View::kBlock, 0));
  return {p, tensor_of(impl_->response, o).data().size() / sizeof(double)};
}

std::span<const float> ComputeResult::block_f32(Output o) const {
  const auto* p = reinterpret_cast<const float*>(checked_data(o, ScalarType::kF32, View::kBlock, 0));
  return {p, tensor_of(impl_->response, o).data().size() / sizeof(float)};
}

Eigen::Map<const Eigen::VectorXd> ComputeResult::vector(Output o, std::uint32_t k) const {
  return {reinterpret_cast<const double*>(checked_data(o, ScalarType::kF64, View::kVector, k)), impl_->nv};
}

Eigen::Map<const Eigen::VectorXf> ComputeResult::vector_f32(Output o, std::uint32_t k) const {
  return {reinterpret_cast<const float*>(checked_data(o, ScalarType::kF32, View::kVector, k)), impl_->nv};
}

Eigen::Map<const RowMajorMatrixXd> ComputeResult::matrix(Output o, std::uint32_t k) const {
  return {reinterpret_cast<const double*>(checked_data(o, ScalarType::kF64, View::kMatrix, k)), impl_->nv, impl_->nv};
}

Eigen::Map<const RowMajorMatrixXf> ComputeResult::matrix_f32(Output o, std::uint32_t k) const {
  return {reinterpret_cast<const float*>(checked_data(o, ScalarType::kF32, View::kMatrix, k)), impl_->nv, impl_->nv};
}

}  // namespace rbdgrad
