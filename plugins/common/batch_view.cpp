#include "batch_view.hpp"

#include <cstddef>
#include <cstdio>
#include <limits>
#include <string>

namespace rbdgrad::plugin {

namespace {

constexpr std::uint32_t kFlags[] = {RBDGRAD_OUTPUT_QDD,      RBDGRAD_OUTPUT_MINV,     RBDGRAD_OUTPUT_DQDD_DQ,
                                    RBDGRAD_OUTPUT_DQDD_DQD, RBDGRAD_OUTPUT_TAU,      RBDGRAD_OUTPUT_DTAU_DQ,
                                    RBDGRAD_OUTPUT_DTAU_DQD, RBDGRAD_OUTPUT_M};

const char* flag_name(std::uint32_t output) {
  switch (output) {
    case RBDGRAD_OUTPUT_QDD: return "RBDGRAD_OUTPUT_QDD";
    case RBDGRAD_OUTPUT_MINV: return "RBDGRAD_OUTPUT_MINV";
    case RBDGRAD_OUTPUT_DQDD_DQ: return "RBDGRAD_OUTPUT_DQDD_DQ";
    case RBDGRAD_OUTPUT_DQDD_DQD: return "RBDGRAD_OUTPUT_DQDD_DQD";
    case RBDGRAD_OUTPUT_TAU: return "RBDGRAD_OUTPUT_TAU";
    case RBDGRAD_OUTPUT_DTAU_DQ: return "RBDGRAD_OUTPUT_DTAU_DQ";
    case RBDGRAD_OUTPUT_DTAU_DQD: return "RBDGRAD_OUTPUT_DTAU_DQD";
    case RBDGRAD_OUTPUT_M: return "RBDGRAD_OUTPUT_M";
  }
  return "unknown output";
}

std::size_t slot_size(std::uint32_t precision) {
  return precision == RBDGRAD_PRECISION_F64 ? sizeof(double) : 4;  // float and int32_t
}

bool is_one_known_precision(std::uint32_t p) {
  return p == RBDGRAD_PRECISION_F64 || p == RBDGRAD_PRECISION_F32 || p == RBDGRAD_PRECISION_FIXED_Q16_16;
}

std::string hex(std::uint32_t v) {
  char buf[16];
  std::snprintf(buf, sizeof buf, "0x%x", v);
  return buf;
}

}  // namespace

const char* precision_name(std::uint32_t precision) noexcept {
  switch (precision) {
    case RBDGRAD_PRECISION_F64: return "f64";
    case RBDGRAD_PRECISION_F32: return "f32";
    case RBDGRAD_PRECISION_FIXED_Q16_16: return "fixed_q16_16";
  }
  return "unknown";
}

const char* output_name(std::uint32_t output) noexcept {
  switch (output) {
    case RBDGRAD_OUTPUT_QDD: return "qdd";
    case RBDGRAD_OUTPUT_MINV: return "minv_out";
    case RBDGRAD_OUTPUT_DQDD_DQ: return "dqdd_dq";
    case RBDGRAD_OUTPUT_DQDD_DQD: return "dqdd_dqd";
    case RBDGRAD_OUTPUT_TAU: return "tau";
    case RBDGRAD_OUTPUT_DTAU_DQ: return "dtau_dq";
    case RBDGRAD_OUTPUT_DTAU_DQD: return "dtau_dqd";
    case RBDGRAD_OUTPUT_M: return "m";
  }
  return "unknown";
}

void* output_pointer(const rbdgrad_batch& b, std::uint32_t output) noexcept {
  switch (output) {
    case RBDGRAD_OUTPUT_QDD: return b.qdd;
    case RBDGRAD_OUTPUT_MINV: return b.minv_out;
    case RBDGRAD_OUTPUT_DQDD_DQ: return b.dqdd_dq;
    case RBDGRAD_OUTPUT_DQDD_DQD: return b.dqdd_dqd;
    case RBDGRAD_OUTPUT_TAU: return b.tau;
    case RBDGRAD_OUTPUT_DTAU_DQ: return b.dtau_dq;
    case RBDGRAD_OUTPUT_DTAU_DQD: return b.dtau_dqd;
    case RBDGRAD_OUTPUT_M: return b.m;
  }
  return nullptr;
}

rbdgrad_batch states_of(const rbdgrad_batch& b, int nv, std::uint64_t first, std::uint64_t n) noexcept {
  const std::size_t scalar = scalar_bytes(b.precision);
  const std::size_t vec = static_cast<std::size_t>(nv) * scalar;
  const std::size_t mat = vec * static_cast<std::size_t>(nv);
  const auto in = [first](const void* p, std::size_t per_state) -> const void* {
    return p == nullptr ? nullptr : static_cast<const std::byte*>(p) + first * per_state;
  };
  const auto out = [first](void* p, std::size_t per_state) -> void* {
    return p == nullptr ? nullptr : static_cast<std::byte*>(p) + first * per_state;
  };
  rbdgrad_batch s = b;
  s.n = n;
  s.q = in(b.q, vec);
  s.qd = in(b.qd, vec);
  s.u = in(b.u, vec);
  s.minv = in(b.minv, mat);
  s.fext = in(b.fext, 6 * vec);
  s.qdd = out(b.qdd, vec);
  s.minv_out = out(b.minv_out, mat);
  s.dqdd_dq = out(b.dqdd_dq, mat);
  s.dqdd_dqd = out(b.dqdd_dqd, mat);
  s.tau = out(b.tau, vec);
  s.dtau_dq = out(b.dtau_dq, mat);
  s.dtau_dqd = out(b.dtau_dqd, mat);
  s.m = out(b.m, mat);
  s.state_status = b.state_status == nullptr ? nullptr : b.state_status + first;
  return s;
}

Status check_request(std::uint32_t precision, std::uint32_t outputs, std::uint32_t supported_precisions,
                     std::uint32_t supported_outputs) {
  if (!is_one_known_precision(precision))
    return invalid_argument("precision is " + std::to_string(precision) +
                            ": must be one of RBDGRAD_PRECISION_F64 (1), _F32 (2), _FIXED_Q16_16 (4)");
  if ((precision & supported_precisions) == 0)
    return unimplemented(std::string("precision ") + precision_name(precision) + " is not supported by this backend");
  if (outputs == 0) return invalid_argument("outputs is 0: ask for at least one rbdgrad_output");
  if ((outputs & ~kAllOutputs) != 0)
    return invalid_argument("outputs " + hex(outputs) + " holds unknown bits " + hex(outputs & ~kAllOutputs));
  for (std::uint32_t flag : kFlags)
    if ((outputs & flag) && !(supported_outputs & flag))
      return unimplemented(std::string("output ") + flag_name(flag) + " is not supported by this backend");
  return Status::ok();
}

Status validate_batch(const rbdgrad_batch* batch, int nv, std::uint32_t supported_precisions,
                      std::uint32_t supported_outputs) {
  if (batch == nullptr) return invalid_argument("batch is NULL");
  const rbdgrad_batch& b = *batch;
  if (b.struct_size < sizeof(rbdgrad_batch))
    return invalid_argument("batch.struct_size is " + std::to_string(b.struct_size) + ", expected at least " +
                            std::to_string(sizeof(rbdgrad_batch)));
  if (b.n < 1) return invalid_argument("batch.n is 0: a batch holds at least one state");
  if (Status s = check_request(b.precision, b.outputs, supported_precisions, supported_outputs); !s)
    return Status(s.code(), "batch." + s.message());
  if (b.input_kind != RBDGRAD_INPUT_TAU && b.input_kind != RBDGRAD_INPUT_QDD)
    return invalid_argument("batch.input_kind is " + std::to_string(b.input_kind) +
                            ": must be RBDGRAD_INPUT_TAU (0) or RBDGRAD_INPUT_QDD (1)");
  // the largest array must be addressable: n * nv * nv * slot (and n * nv * 6 * slot for fext)
  const std::size_t slot = slot_size(b.precision);
  const auto unv = static_cast<std::size_t>(nv);
  const std::size_t per_state = slot * unv * (unv > 6 ? unv : 6);
  if (b.n > std::numeric_limits<std::size_t>::max() / per_state)
    return invalid_argument("batch.n is " + std::to_string(b.n) + ": the batch arrays would not fit in memory");

  // inputs: M(q) needs q only; everything else reads qd and u too
  const bool m_only = b.outputs == RBDGRAD_OUTPUT_M;
  struct Field {
    const void* pointer;
    const char* name;
    bool required;
    const char* why;
  };
  const Field inputs[] = {{b.q, "q", true, "it is always read"},
                          {b.qd, "qd", !m_only, "the requested outputs read it"},
                          {b.u, "u", !m_only, "the requested outputs read it"},
                          {b.minv, "minv", false, ""},
                          {b.fext, "fext", false, ""},
                          {b.state_status, "state_status", false, ""}};
  for (const Field& f : inputs) {
    if (f.pointer == nullptr) {
      if (f.required) return invalid_argument(std::string("batch.") + f.name + " is NULL but " + f.why);
      continue;
    }
    const std::size_t align = f.pointer == b.state_status ? alignof(std::int32_t) : slot;
    if (reinterpret_cast<std::uintptr_t>(f.pointer) % align != 0)
      return invalid_argument(std::string("batch.") + f.name + " is not aligned to " + std::to_string(align) + " bytes");
  }
  // one output array per requested output
  for (std::uint32_t flag : kFlags) {
    if (!(b.outputs & flag)) continue;
    const void* out = output_pointer(b, flag);
    if (out == nullptr)
      return invalid_argument(std::string("batch.") + output_name(flag) + " is NULL but " + flag_name(flag) +
                              " is requested");
    if (reinterpret_cast<std::uintptr_t>(out) % slot != 0)
      return invalid_argument(std::string("batch.") + output_name(flag) + " is not aligned to " +
                              std::to_string(slot) + " bytes");
  }
  return Status::ok();
}

}  // namespace rbdgrad::plugin
