#include "request_batch.hpp"

#include <array>
#include <bit>
#include <cmath>
#include <cstring>
#include <limits>
#include <sstream>
#include <string_view>

#include "common/batch_view.hpp"  // output_pointer: one mapping of output flags to batch fields

namespace rbdgrad::server {
namespace {

namespace v1 = rbdgrad::v1;

// the wire format is little-endian and conversion memcpy()s scalars as they are
static_assert(std::endian::native == std::endian::little, "request_batch assumes a little-endian host");

// largest magnitude accepted for Q16.16: the documented bound, a little inside raw_max / 65536
constexpr double kFixedLimit = 32767.99;
constexpr double kFixedScale = 65536.0;

// the outputs in rbdgrad_output bit order, with their per-state shape
struct OutputSpec {
  v1::Output output;
  uint32_t flag;
  bool matrix;  // nv x nv, else nv
};
constexpr std::array<OutputSpec, 8> kOutputs{{
    {v1::OUTPUT_QDD, RBDGRAD_OUTPUT_QDD, false},
    {v1::OUTPUT_MINV, RBDGRAD_OUTPUT_MINV, true},
    {v1::OUTPUT_DQDD_DQ, RBDGRAD_OUTPUT_DQDD_DQ, true},
    {v1::OUTPUT_DQDD_DQD, RBDGRAD_OUTPUT_DQDD_DQD, true},
    {v1::OUTPUT_TAU, RBDGRAD_OUTPUT_TAU, false},
    {v1::OUTPUT_DTAU_DQ, RBDGRAD_OUTPUT_DTAU_DQ, true},
    {v1::OUTPUT_DTAU_DQD, RBDGRAD_OUTPUT_DTAU_DQD, true},
    {v1::OUTPUT_M, RBDGRAD_OUTPUT_M, true},
}};

size_t scalar_size(rbdgrad_precision p) { return p == RBDGRAD_PRECISION_F64 ? sizeof(double) : 4; }

std::string prefix(const std::string& id) { return id.empty() ? std::string() : "request '" + id + "': "; }

std::string format_value(double v) {
  std::ostringstream os;
  os << v;
  return os.str();
}

// "(num_states 7 x nv 7 x nv 7)": how the expected count was reached
std::string shape_text(uint64_t n, int nv, bool matrix, int extra) {
  std::string s = "(num_states " + std::to_string(n) + " x nv " + std::to_string(nv);
  if (matrix) s += " x nv " + std::to_string(nv);
  if (extra) s += " x " + std::to_string(extra);
  return s + ")";
}

// one input field: its name in messages and its shape per state
struct InputField {
  const char* name;
  const v1::Tensor* tensor;
  bool optional;
  bool matrix;   // nv x nv per state
  int extra;     // nv x extra per state when non-zero
};

// Checks one tensor's type and size and converts it into `dst` in `precision`. `present` is
// false for an empty optional field (dst stays empty).
Status convert_field(const std::string& pre, const InputField& f, uint64_t n, int nv, rbdgrad_precision precision,
                     std::vector<std::byte>& dst, bool& present) {
  const std::string& data = f.tensor->data();
  present = false;
  if (f.optional && data.empty()) return Status::ok();
  const uint64_t per_state = static_cast<uint64_t>(nv) * (f.matrix ? nv : f.extra ? f.extra : 1);
  const uint64_t expected = n * per_state;
  const std::string field = std::string("field '") + f.name + "'";
  const auto count_error = [&](uint64_t got) {
    return invalid_argument(pre + field + " has " + std::to_string(got) + " values, expected " +
                            std::to_string(expected) + " " + shape_text(n, nv, f.matrix, f.extra));
  };

  size_t src_size = 0;
  switch (f.tensor->type()) {
    case v1::SCALAR_TYPE_F64: src_size = sizeof(double); break;
    case v1::SCALAR_TYPE_F32: src_size = sizeof(float); break;
    case v1::SCALAR_TYPE_UNSPECIFIED:
      // an empty required field is a size problem, not a type one
      if (data.empty()) return count_error(0);
      return invalid_argument(pre + field + " has type SCALAR_TYPE_UNSPECIFIED");
    default:
      return invalid_argument(pre + field + " has unknown type " + std::to_string(f.tensor->type()));
  }
  if (data.size() % src_size != 0)
    return invalid_argument(pre + field + " has " + std::to_string(data.size()) + " bytes, not a multiple of " +
                            std::to_string(src_size) + " (" + v1::ScalarType_Name(f.tensor->type()) + ")");
  if (data.size() / src_size != expected) return count_error(data.size() / src_size);

  const size_t dst_size = scalar_size(precision);
  dst.resize(expected * dst_size);
  const char* src = data.data();
  std::byte* out = dst.data();
  for (uint64_t i = 0; i < expected; ++i) {
    // memcpy: protobuf bytes carry no alignment guarantee
    double v;
    if (src_size == sizeof(double)) {
      std::memcpy(&v, src + i * sizeof(double), sizeof(double));
    } else {
      float fv;
      std::memcpy(&fv, src + i * sizeof(float), sizeof(float));
      v = fv;
    }
    const auto where = [&] {
      return pre + "state " + std::to_string(i / per_state) + ": " + field + " element " +
             std::to_string(i % per_state);
    };
    if (!std::isfinite(v)) return invalid_argument(where() + " is not finite (" + format_value(v) + ")");
    switch (precision) {
      case RBDGRAD_PRECISION_F64:
        std::memcpy(out + i * sizeof(double), &v, sizeof(double));
        break;
      case RBDGRAD_PRECISION_F32: {
        // a finite double beyond float's range would become inf silently
        if (std::fabs(v) > std::numeric_limits<float>::max())
          return invalid_argument(where() + " value " + format_value(v) + " is outside the range of f32");
        const float fv = static_cast<float>(v);
        std::memcpy(out + i * sizeof(float), &fv, sizeof(float));
        break;
      }
      case RBDGRAD_PRECISION_FIXED_Q16_16: {
        // overflow is an error, never a silent saturation
        if (std::fabs(v) > kFixedLimit)
          return invalid_argument(where() + " value " + format_value(v) +
                                  " is outside the range of Q16.16 (+-32767.99)");
        // round to nearest, ties away from zero, as rbdgrad::Fixed does
        const auto raw = static_cast<int32_t>(std::llround(v * kFixedScale));
        std::memcpy(out + i * sizeof(int32_t), &raw, sizeof(int32_t));
        break;
      }
    }
  }
  present = true;
  return Status::ok();
}

v1::Precision proto_precision(uint32_t p) {
  switch (p) {
    case RBDGRAD_PRECISION_F64: return v1::PRECISION_F64;
    case RBDGRAD_PRECISION_F32: return v1::PRECISION_F32;
    default: return v1::PRECISION_FIXED;
  }
}

}  // namespace

uint32_t output_flag(v1::Output output) noexcept {
  for (const OutputSpec& s : kOutputs)
    if (s.output == output) return s.flag;
  return 0;
}

v1::Output output_enum(uint32_t flag) noexcept {
  for (const OutputSpec& s : kOutputs)
    if (s.flag == flag) return s.output;
  return v1::OUTPUT_UNSPECIFIED;
}

bool is_matrix_output(v1::Output output) noexcept {
  for (const OutputSpec& s : kOutputs)
    if (s.output == output) return s.matrix;
  return false;
}

v1::Tensor* response_tensor(v1::ComputeResponse& r, v1::Output o) {
  switch (o) {
    case v1::OUTPUT_QDD: return r.mutable_qdd();
    case v1::OUTPUT_MINV: return r.mutable_minv();
    case v1::OUTPUT_DQDD_DQ: return r.mutable_dqdd_dq();
    case v1::OUTPUT_DQDD_DQD: return r.mutable_dqdd_dqd();
    case v1::OUTPUT_TAU: return r.mutable_tau();
    case v1::OUTPUT_DTAU_DQ: return r.mutable_dtau_dq();
    case v1::OUTPUT_DTAU_DQD: return r.mutable_dtau_dqd();
    case v1::OUTPUT_M: return r.mutable_m();
    default: return nullptr;
  }
}

Status RequestBatch::from_request(const v1::ComputeRequest& req, int nv, rbdgrad_precision precision,
                                  uint32_t max_states, RequestBatch& out, v1::ComputeResponse* direct) {
  const std::string pre = prefix(req.request_id());
  const uint64_t n = req.num_states();

  // request-wide checks first, so value errors only come from well-formed requests
  if (nv < 1) return invalid_argument(pre + "model nv " + std::to_string(nv) + " is not positive");
  if (precision != RBDGRAD_PRECISION_F64 && precision != RBDGRAD_PRECISION_F32 &&
      precision != RBDGRAD_PRECISION_FIXED_Q16_16)
    return invalid_argument(pre + "compute precision " + std::to_string(static_cast<int>(precision)) +
                            " is not F64, F32 or FIXED_Q16_16 (AUTO must be resolved before conversion)");
  if (n == 0) return invalid_argument(pre + "num_states is 0");
  if (n > max_states)
    return invalid_argument(pre + "num_states " + std::to_string(n) + " exceeds the limit max_states_per_request = " +
                            std::to_string(max_states));
  if (req.input_kind() != v1::INPUT_KIND_TAU && req.input_kind() != v1::INPUT_KIND_QDD) {
    if (req.input_kind() == v1::INPUT_KIND_UNSPECIFIED)
      return invalid_argument(pre + "input_kind is INPUT_KIND_UNSPECIFIED");
    return invalid_argument(pre + "input_kind has unknown value " + std::to_string(req.input_kind()));
  }
  if (req.output_type() != v1::SCALAR_TYPE_UNSPECIFIED && req.output_type() != v1::SCALAR_TYPE_F64 &&
      req.output_type() != v1::SCALAR_TYPE_F32)
    return invalid_argument(pre + "output_type has unknown value " + std::to_string(req.output_type()));
  if (req.outputs_size() == 0) return invalid_argument(pre + "no outputs requested");
  uint32_t flags = 0;
  for (int i = 0; i < req.outputs_size(); ++i) {
    const auto o = static_cast<v1::Output>(req.outputs(i));
    if (o == v1::OUTPUT_UNSPECIFIED)
      return invalid_argument(pre + "outputs[" + std::to_string(i) + "] is OUTPUT_UNSPECIFIED");
    const uint32_t flag = output_flag(o);
    if (flag == 0)
      return invalid_argument(pre + "outputs[" + std::to_string(i) + "] has unknown value " +
                              std::to_string(req.outputs(i)));
    if (flags & flag)
      return invalid_argument(pre + "output " + v1::Output_Name(o) + " is requested more than once");
    flags |= flag;
  }

  // build into a local so that `out` is untouched on error
  RequestBatch rb;
  rb.nv_ = nv;
  rb.request_id_ = req.request_id();
  // u is named after what it holds: a client reads "field 'tau'" more easily than "field 'u'"
  const char* u_name = req.input_kind() == v1::INPUT_KIND_TAU ? "tau" : "qdd";
  const std::array<InputField, 5> fields{{
      {"q", &req.q(), false, false, 0},
      {"qd", &req.qd(), false, false, 0},
      {u_name, &req.u(), false, false, 0},
      {"minv", &req.minv(), true, true, 0},
      {"fext", &req.fext(), true, false, 6},
  }};
  const std::array<Buffer*, 5> buffers{&rb.q_, &rb.qd_, &rb.u_, &rb.minv_, &rb.fext_};
  std::array<bool, 5> present{};
  for (size_t i = 0; i < fields.size(); ++i) {
    bool p = false;
    if (Status s = convert_field(pre, fields[i], n, nv, precision, *buffers[i], p); !s) return s;
    present[i] = p;
  }

  // outputs: allocate only what was asked for
  const size_t ss = scalar_size(precision);
  const uint64_t vec_bytes = n * static_cast<uint64_t>(nv) * ss;
  const uint64_t mat_bytes = vec_bytes * static_cast<uint64_t>(nv);
  const std::array<Buffer*, 8> out_buffers{&rb.qdd_,     &rb.minv_out_, &rb.dqdd_dq_,  &rb.dqdd_dqd_,
                                           &rb.tau_,     &rb.dtau_dq_,  &rb.dtau_dqd_, &rb.m_};
  // F64 in and out: the response's own tensors are the output arrays (no copy afterwards)
  const bool write_direct = direct != nullptr && precision == RBDGRAD_PRECISION_F64 &&
                            req.output_type() != v1::SCALAR_TYPE_F32;
  std::array<void*, 8> direct_ptr{};
  for (size_t i = 0; i < kOutputs.size(); ++i) {
    if (!(flags & kOutputs[i].flag)) continue;
    const uint64_t bytes = kOutputs[i].matrix ? mat_bytes : vec_bytes;
    if (write_direct) {
      v1::Tensor* t = response_tensor(*direct, kOutputs[i].output);
      t->set_type(v1::SCALAR_TYPE_F64);
      t->mutable_data()->resize(bytes);
      direct_ptr[i] = t->mutable_data()->data();
      rb.direct_outputs_ |= kOutputs[i].flag;
    } else {
      out_buffers[i]->resize(bytes);
    }
  }
  rb.state_status_.assign(n, 0);

  rbdgrad_batch& b = rb.batch_;
  b = rbdgrad_batch{};
  b.struct_size = sizeof(rbdgrad_batch);
  b.n = n;
  b.precision = precision;
  b.input_kind = req.input_kind() == v1::INPUT_KIND_TAU ? RBDGRAD_INPUT_TAU : RBDGRAD_INPUT_QDD;
  b.outputs = flags;
  b.q = rb.q_.data();
  b.qd = rb.qd_.data();
  b.u = rb.u_.data();
  b.minv = present[3] ? rb.minv_.data() : nullptr;
  b.fext = present[4] ? rb.fext_.data() : nullptr;
  const auto ptr = [](Buffer& buf) -> void* { return buf.empty() ? nullptr : buf.data(); };
  const auto out_ptr = [&](size_t i) { return direct_ptr[i] != nullptr ? direct_ptr[i] : ptr(*out_buffers[i]); };
  b.qdd = out_ptr(0);
  b.minv_out = out_ptr(1);
  b.dqdd_dq = out_ptr(2);
  b.dqdd_dqd = out_ptr(3);
  b.tau = out_ptr(4);
  b.dtau_dq = out_ptr(5);
  b.dtau_dqd = out_ptr(6);
  b.m = out_ptr(7);
  b.state_status = rb.state_status_.data();

  out = std::move(rb);
  return Status::ok();
}

void RequestBatch::to_response(v1::ComputeResponse& resp, v1::ScalarType output_type) const {
  resp.set_request_id(request_id_);
  resp.set_num_states(static_cast<uint32_t>(batch_.n));
  resp.set_precision(proto_precision(batch_.precision));
  const bool f32 = output_type == v1::SCALAR_TYPE_F32;  // anything else is F64 (the default)
  const size_t out_size = f32 ? sizeof(float) : sizeof(double);
  const auto precision = static_cast<rbdgrad_precision>(batch_.precision);
  const size_t in_size = scalar_size(precision);
  const uint64_t vec = batch_.n * static_cast<uint64_t>(nv_);

  for (const OutputSpec& spec : kOutputs) {
    if (!(batch_.outputs & spec.flag) || (direct_outputs_ & spec.flag)) continue;
    const auto* src = static_cast<const std::byte*>(plugin::output_pointer(batch_, spec.flag));
    const uint64_t count = spec.matrix ? vec * static_cast<uint64_t>(nv_) : vec;
    v1::Tensor* t = response_tensor(resp, spec.output);
    t->set_type(f32 ? v1::SCALAR_TYPE_F32 : v1::SCALAR_TYPE_F64);
    std::string* data = t->mutable_data();
    data->resize(count * out_size);
    char* dst = data->data();
    if (precision == RBDGRAD_PRECISION_F64 && !f32) {
      std::memcpy(dst, src, count * sizeof(double));  // same encoding: one block
      continue;
    }
    for (uint64_t i = 0; i < count; ++i) {
      // read in the compute precision, widen to double, then narrow to the wire type
      double v;
      switch (precision) {
        case RBDGRAD_PRECISION_F64:
          std::memcpy(&v, src + i * in_size, sizeof(double));
          break;
        case RBDGRAD_PRECISION_F32: {
          float fv;
          std::memcpy(&fv, src + i * in_size, sizeof(float));
          v = fv;
          break;
        }
        default: {
          int32_t raw;
          std::memcpy(&raw, src + i * in_size, sizeof(int32_t));
          v = raw / kFixedScale;
          break;
        }
      }
      if (f32) {
        const float fv = static_cast<float>(v);
        std::memcpy(dst + i * sizeof(float), &fv, sizeof(float));
      } else {
        std::memcpy(dst + i * sizeof(double), &v, sizeof(double));
      }
    }
  }
}

}  // namespace rbdgrad::server
