// The vocabulary of a compute call on the rbdgrad service, as plain C++ types: precisions, input
// kinds, output selection, backend hints and the request itself. No protobuf or gRPC type appears
// here; the client library converts at its edge (see rbdgrad/client.hpp).
#pragma once

#include <chrono>
#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <string_view>

#include "rbdgrad/client_export.hpp"

namespace rbdgrad {

// Scalar type of the computation on the server.
enum class Precision : std::uint8_t {
  kAuto,   // the server chooses (today: f64)
  kF64,
  kF32,
  kFixed,  // Q16.16 fixed point, saturating: an overflow is an error, never silent
};

// What ComputeRequest::u holds.
enum class ComputeInput : std::uint8_t {
  kTau,  // joint torques: qdd = FD(q, qd, tau) is computed first
  kQdd,  // joint accelerations
};

// One output of a compute call. The values are bits, the same as the plugin ABI's rbdgrad_output,
// so that a selection is a mask: `Output::kDqddDq | Output::kDqddDqd`.
enum class Output : std::uint32_t {
  kQdd = 1,        // (nv)      forward dynamics
  kMinv = 2,       // (nv x nv) M^-1
  kDqddDq = 4,     // (nv x nv) d qdd / d q
  kDqddDqd = 8,    // (nv x nv) d qdd / d qd
  kTau = 16,       // (nv)      RNEA(q, qd, qdd)
  kDtauDq = 32,    // (nv x nv) d tau / d q
  kDtauDqd = 64,   // (nv x nv) d tau / d qd
  kM = 128,        // (nv x nv) joint-space inertia matrix
};

// Every output, in bit order.
inline constexpr Output kEveryOutput[] = {Output::kQdd,   Output::kMinv,   Output::kDqddDq,   Output::kDqddDqd,
                                          Output::kTau,   Output::kDtauDq, Output::kDtauDqd, Output::kM};

constexpr std::uint32_t mask(Output o) noexcept { return static_cast<std::uint32_t>(o); }
constexpr std::uint32_t operator|(Output a, Output b) noexcept { return mask(a) | mask(b); }
constexpr std::uint32_t operator|(std::uint32_t a, Output b) noexcept { return a | mask(b); }
// true for qdd and tau (nv values per state), false for the nv x nv matrices
constexpr bool is_vector_output(Output o) noexcept { return o == Output::kQdd || o == Output::kTau; }

// Backend hint: where the server should compute.
enum class Backend : std::uint8_t { kAuto, kCpu, kCuda, kFpga };

// Encoding of the output arrays in the response.
enum class ScalarType : std::uint8_t { kF64, kF32 };

// Lower-case names, as the CLI and the logs spell them: "auto", "f64", "f32", "fixed"; "tau",
// "qdd"; "qdd", "minv", "dqdd_dq", ... (the proto's field names); "auto", "cpu", "cuda", "fpga".
RBDGRAD_CLIENT_EXPORT const char* precision_name(Precision p) noexcept;
RBDGRAD_CLIENT_EXPORT const char* input_name(ComputeInput i) noexcept;
RBDGRAD_CLIENT_EXPORT const char* output_name(Output o) noexcept;
RBDGRAD_CLIENT_EXPORT const char* backend_name(Backend b) noexcept;
RBDGRAD_CLIENT_EXPORT const char* scalar_type_name(ScalarType t) noexcept;
// The inverse of the names above; false (and `out` untouched) for anything else.
RBDGRAD_CLIENT_EXPORT bool parse_precision(std::string_view text, Precision& out) noexcept;
RBDGRAD_CLIENT_EXPORT bool parse_input(std::string_view text, ComputeInput& out) noexcept;
RBDGRAD_CLIENT_EXPORT bool parse_backend(std::string_view text, Backend& out) noexcept;
RBDGRAD_CLIENT_EXPORT bool parse_scalar_type(std::string_view text, ScalarType& out) noexcept;

// One batch of N states for one model. The arrays are state-major and contiguous: state k's
// vector at [k*nv, (k+1)*nv), its matrix at [k*nv*nv, (k+1)*nv*nv) in ROW-MAJOR order (element
// (i, j) at i*nv + j), joints in the model's order (Client::get_model lists it). The spans are
// read while the call starts (compute, compute_async, ComputeSession::step) and copied into the
// message: they need not outlive that call. The client does not check sizes or values: the server
// does, and its message names the state and field.
struct ComputeRequest {
  std::string model;                 // a model the server serves (Client::list_models)
  // Or a scene (Client::list_scenes; model then empty or the scene's): the arrays in the scene's
  // joints (Client::get_scene), outputs 0 for the scene's own, fext for its force links only
  // (N x links x 6, in SceneDescription::force_links' order), minv when the scene takes it.
  std::string scene;
  std::uint32_t num_states = 0;      // N >= 1, at most ServerInfo::max_states_per_request
  Precision precision = Precision::kAuto;
  ComputeInput input = ComputeInput::kTau;
  std::uint32_t outputs = 0;         // Output bits, at least one (with a scene: 0 = the scene's)
  std::span<const double> q;         // (N x nv) joint positions
  std::span<const double> qd;        // (N x nv) joint velocities
  std::span<const double> u;         // (N x nv) tau or qdd, as `input` says
  std::span<const double> minv;      // optional (N x nv x nv) caller-supplied M^-1; empty = none
  std::span<const double> fext;      // optional (N x nv x 6) external forces per body, [moment;
                                     // force] in its URDF link frame about the link origin
  Backend backend = Backend::kAuto;  // hint
  ScalarType output_type = ScalarType::kF64;
  std::string request_id;            // echoed in the result and in the server's logs
  // Time allowed for this call (for a session step: this step); empty = the client's default
  // (ClientOptions::default_timeout, SessionOptions::step_timeout).
  std::optional<std::chrono::nanoseconds> timeout;
};

}  // namespace rbdgrad
