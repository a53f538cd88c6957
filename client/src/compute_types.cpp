// Names of the compute vocabulary (rbdgrad/compute_types.hpp), for the CLI, logs and messages.
#include "rbdgrad/compute_types.hpp"

#include <cstddef>

namespace rbdgrad {

namespace {

// the name -> value direction of the tables below
template <class E, std::size_t N>
bool parse_name(std::string_view text, const E (&values)[N], const char* (*name)(E) noexcept, E& out) noexcept {
  for (E v : values) {
    if (text == name(v)) {
      out = v;
      return true;
    }
  }
  return false;
}

}  // namespace

const char* precision_name(Precision p) noexcept {
  switch (p) {
    case Precision::kAuto: return "auto";
    case Precision::kF64: return "f64";
    case Precision::kF32: return "f32";
    case Precision::kFixed: return "fixed";
  }
  return "unknown";
}

const char* input_name(ComputeInput i) noexcept { return i == ComputeInput::kQdd ? "qdd" : "tau"; }

const char* output_name(Output o) noexcept {
  switch (o) {
    case Output::kQdd: return "qdd";
    case Output::kMinv: return "minv";
    case Output::kDqddDq: return "dqdd_dq";
    case Output::kDqddDqd: return "dqdd_dqd";
    case Output::kTau: return "tau";
    case Output::kDtauDq: return "dtau_dq";
    case Output::kDtauDqd: return "dtau_dqd";
    case Output::kM: return "m";
  }
  return "unknown";
}

const char* backend_name(Backend b) noexcept {
  switch (b) {
    case Backend::kAuto: return "auto";
    case Backend::kCpu: return "cpu";
    case Backend::kCuda: return "cuda";
    case Backend::kFpga: return "fpga";
  }
  return "unknown";
}

const char* scalar_type_name(ScalarType t) noexcept { return t == ScalarType::kF32 ? "f32" : "f64"; }

bool parse_precision(std::string_view text, Precision& out) noexcept {
  constexpr Precision kAll[] = {Precision::kAuto, Precision::kF64, Precision::kF32, Precision::kFixed};
  return parse_name(text, kAll, precision_name, out);
}

bool parse_input(std::string_view text, ComputeInput& out) noexcept {
  constexpr ComputeInput kAll[] = {ComputeInput::kTau, ComputeInput::kQdd};
  return parse_name(text, kAll, input_name, out);
}

bool parse_backend(std::string_view text, Backend& out) noexcept {
  constexpr Backend kAll[] = {Backend::kAuto, Backend::kCpu, Backend::kCuda, Backend::kFpga};
  return parse_name(text, kAll, backend_name, out);
}

bool parse_scalar_type(std::string_view text, ScalarType& out) noexcept {
  constexpr ScalarType kAll[] = {ScalarType::kF64, ScalarType::kF32};
  return parse_name(text, kAll, scalar_type_name, out);
}

}  // namespace rbdgrad
