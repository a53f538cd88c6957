// The result of a compute call: what the server computed, where and how fast, and every output as
// Eigen::Map views onto the received message's bytes (no copy). Move-only: a ComputeResult owns
// the response, and passing the same object to successive calls reuses its buffers.
#pragma once

#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "rbdgrad/client_export.hpp"
#include "rbdgrad/compute_types.hpp"

namespace rbdgrad {

using RowMajorMatrixXd = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
using RowMajorMatrixXf = Eigen::Matrix<float, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

struct ComputeTimings {
  std::uint64_t queue_us = 0;    // server: request accepted -> compute started
  std::uint64_t compute_us = 0;  // server: in the backend
  std::uint64_t total_us = 0;    // server: request accepted -> response ready
  double round_trip_us = 0;      // client: call started -> response checked (encoding, transport,
                                 // server and decoding; for async calls, up to the callback;
                                 // every attempt and pause included)
  std::uint32_t attempts = 1;    // client: calls sent for this result, 1 + retries after UNAVAILABLE
};

// One backend's share of a request the server split across backends: states
// [first_state, first_state + num_states).
struct ComputePart {
  Backend backend = Backend::kAuto;
  std::uint32_t first_state = 0;
  std::uint32_t num_states = 0;
  std::uint64_t compute_us = 0;  // server: in that backend
};

namespace detail {
struct ResultAccess;  // the library's own access to the response (not part of the API)
}

class RBDGRAD_CLIENT_EXPORT ComputeResult {
 public:
  ComputeResult();
  ~ComputeResult();
  ComputeResult(ComputeResult&&) noexcept;
  ComputeResult& operator=(ComputeResult&&) noexcept;
  ComputeResult(const ComputeResult&) = delete;
  ComputeResult& operator=(const ComputeResult&) = delete;

  // False until a call succeeded into this object, and again after a failed call into it.
  bool valid() const noexcept;

  const std::string& request_id() const noexcept;
  std::uint32_t num_states() const noexcept;  // N
  int nv() const noexcept;
  Backend backend() const noexcept;           // the backend that computed
  const std::string& backend_mode() const noexcept;  // "" as itself; "csim": the FPGA kernel's C
                                                     // simulation on the server's CPU
  Precision precision() const noexcept;       // the precision used (never kAuto)
  ScalarType output_type() const noexcept;    // encoding of every output
  std::uint32_t outputs() const noexcept;     // Output bits present
  bool has(Output o) const noexcept;
  const ComputeTimings& timings() const noexcept;
  // States of a PRECISION_FIXED request that left the Q16.16 range and were computed again on
  // fallback_backend() in fallback_precision() (ascending; empty when none): their outputs are
  // that backend's, in its precision.
  std::span<const std::uint32_t> fallback_states() const noexcept;
  Backend fallback_backend() const noexcept;      // kAuto when no state fell back
  Precision fallback_precision() const noexcept;  // kAuto when no state fell back
  // Backends that failed the request as a whole before backend() computed it, with their errors
  // ("cuda: device lost"), in order; empty when none did. Only requests without a backend hint
  // move on to another backend.
  std::vector<std::string> failovers() const;
  // A large request the server split across backends (its scheduler.split_min_states): each
  // backend's share, in order; backend() is then the one with the most states. Empty when one
  // backend computed every state.
  std::vector<ComputePart> parts() const;

  // Views. The f64 forms need output_type() == kF64, the _f32 forms kF32. They throw
  // std::invalid_argument when the output is absent (not requested) or of the other type, and
  // std::out_of_range when k >= num_states(); the message says which. Views stay valid while
  // this object lives and is not the target of another call.

  // The whole block of an output: N x nv, or N x nv x nv (each matrix row-major), state-major.
  std::span<const double> block(Output o) const;
  std::span<const float> block_f32(Output o) const;
  // State k of a vector output (qdd, tau): nv values.
  Eigen::Map<const Eigen::VectorXd> vector(Output o, std::uint32_t k) const;
  Eigen::Map<const Eigen::VectorXf> vector_f32(Output o, std::uint32_t k) const;
  // State k of a matrix output: nv x nv; d(a)/d(b) has row i = a_i, column j = b_j.
  Eigen::Map<const RowMajorMatrixXd> matrix(Output o, std::uint32_t k) const;
  Eigen::Map<const RowMajorMatrixXf> matrix_f32(Output o, std::uint32_t k) const;

  // Shorthands for the f64 views of state k.
  Eigen::Map<const Eigen::VectorXd> qdd(std::uint32_t k) const { return vector(Output::kQdd, k); }
  Eigen::Map<const Eigen::VectorXd> tau(std::uint32_t k) const { return vector(Output::kTau, k); }
  Eigen::Map<const RowMajorMatrixXd> minv(std::uint32_t k) const { return matrix(Output::kMinv, k); }
  Eigen::Map<const RowMajorMatrixXd> dqdd_dq(std::uint32_t k) const { return matrix(Output::kDqddDq, k); }
  Eigen::Map<const RowMajorMatrixXd> dqdd_dqd(std::uint32_t k) const { return matrix(Output::kDqddDqd, k); }
  Eigen::Map<const RowMajorMatrixXd> dtau_dq(std::uint32_t k) const { return matrix(Output::kDtauDq, k); }
  Eigen::Map<const RowMajorMatrixXd> dtau_dqd(std::uint32_t k) const { return matrix(Output::kDtauDqd, k); }
  Eigen::Map<const RowMajorMatrixXd> m(std::uint32_t k) const { return matrix(Output::kM, k); }

  struct Impl;

 private:
  friend struct detail::ResultAccess;
  enum class View : unsigned char { kBlock, kVector, kMatrix };
  // the first byte of output o (of state k unless kBlock), checked for presence, type, shape and k
  const unsigned char* checked_data(Output o, ScalarType type, View view, std::uint32_t k) const;

  std::unique_ptr<Impl> impl_;
};

}  // namespace rbdgrad
