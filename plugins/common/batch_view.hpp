// Typed access to an rbdgrad_batch for one scalar type S, and its validation against an instance.
//
// Batch arrays hold S itself for f64 and f32, and the raw int32 of Q16.16 for fixed point
// (value = raw / 65536): Slot<S> says which. Inputs of floating-point batches are mapped without a
// copy; fixed-point inputs are converted into per-worker buffers (StateBuffers), sized once.
#pragma once

#include <Eigen/Core>
#include <cstddef>
#include <cstdint>

#include "rbdgrad/fixed_point.hpp"
#include "rbdgrad/plugin_api.h"
#include "rbdgrad/spatial.hpp"
#include "rbdgrad/status.hpp"

namespace rbdgrad::plugin {

inline constexpr std::uint32_t kAllPrecisions =
    RBDGRAD_PRECISION_F64 | RBDGRAD_PRECISION_F32 | RBDGRAD_PRECISION_FIXED_Q16_16;
inline constexpr std::uint32_t kAllOutputs = 255;  // the eight rbdgrad_output flags
inline constexpr std::uint32_t kMatrixOutputs = RBDGRAD_OUTPUT_MINV | RBDGRAD_OUTPUT_DQDD_DQ | RBDGRAD_OUTPUT_DQDD_DQD |
                                                RBDGRAD_OUTPUT_DTAU_DQ | RBDGRAD_OUTPUT_DTAU_DQD | RBDGRAD_OUTPUT_M;

// What one scalar occupies in a batch array.
template <class S> struct Slot { using type = S; };
template <> struct Slot<Q16_16> { using type = std::int32_t; };
template <class S> using SlotT = typename Slot<S>::type;

/// Bytes of one scalar of a batch in `precision` (one flag): 8 for f64, 4 for f32 and Q16.16.
inline constexpr std::size_t scalar_bytes(std::uint32_t precision) {
  return precision == RBDGRAD_PRECISION_F64 ? sizeof(double) : sizeof(std::int32_t);
}

// The precision flag of S.
template <class S> constexpr rbdgrad_precision precision_of();
template <> constexpr rbdgrad_precision precision_of<double>() { return RBDGRAD_PRECISION_F64; }
template <> constexpr rbdgrad_precision precision_of<float>() { return RBDGRAD_PRECISION_F32; }
template <> constexpr rbdgrad_precision precision_of<Q16_16>() { return RBDGRAD_PRECISION_FIXED_Q16_16; }

/// "f64", "f32", "fixed_q16_16", or "unknown".
const char* precision_name(std::uint32_t precision) noexcept;
/// "qdd", "minv", "dqdd_dq", ... for one flag (the batch field that receives it), or "unknown".
const char* output_name(std::uint32_t output) noexcept;

/// The output array of `output` (one rbdgrad_output flag) in the batch: batch.qdd, batch.minv_out, ...
void* output_pointer(const rbdgrad_batch& batch, std::uint32_t output) noexcept;

/// States [first, first + n) of `batch` (a model with `nv` joints) as a batch of their own, over
/// the same arrays; first + n <= batch.n. The split of a request across backends runs these.
rbdgrad_batch states_of(const rbdgrad_batch& batch, int nv, std::uint64_t first, std::uint64_t n) noexcept;

/// Whether a backend supporting `supported_precisions` and `supported_outputs` can take this request:
/// invalid_argument for a precision that is not exactly one known flag or for outputs that are 0 or
/// hold unknown bits; unimplemented (UNSUPPORTED) for a known precision or output it lacks.
Status check_request(std::uint32_t precision, std::uint32_t outputs, std::uint32_t supported_precisions,
                     std::uint32_t supported_outputs);

/// Validates a batch for a model with `nv` joints: struct_size, n >= 1, precision, input_kind,
/// outputs (check_request), the inputs the outputs need (q always; qd and u unless only M is asked
/// for), an output pointer per requested output, pointer alignment, and n * nv * nv * sizeof fitting
/// in size_t. Messages name the field: "batch.dtau_dq is NULL but RBDGRAD_OUTPUT_DTAU_DQ is requested".
Status validate_batch(const rbdgrad_batch* batch, int nv, std::uint32_t supported_precisions,
                      std::uint32_t supported_outputs);

// Per-worker storage for one state's inputs in S, sized at instance creation.
template <class S>
struct StateBuffers {
  explicit StateBuffers(int nv);
  VectorX<S> q, qd, u;  // (nv) converted fixed-point inputs (unused for floating point)
  VectorX<S> fext;      // (6 nv) same
  MatrixX<S> minv;      // (nv x nv) the caller's M^-1 as the column-major matrix the core takes
};

// One state's inputs as the core algorithms take them.
template <class S>
struct StateInputs {
  Eigen::Map<const VectorX<S>> q, qd, u;  // (nv); u is tau or qdd as batch.input_kind says
  const S* fext;                          // (6 x nv, column i = body i) or null
  const MatrixX<S>* minv;                 // (nv x nv) or null
};

// A validated batch seen as arrays of S. Cheap to build; reads and writes state k only.
template <class S>
class BatchView {
 public:
  using Raw = SlotT<S>;
  using RawVector = Eigen::Matrix<Raw, Eigen::Dynamic, 1>;
  using RawRowMajor = Eigen::Matrix<Raw, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

  BatchView(const rbdgrad_batch& batch, int nv) : b_(batch), nv_(nv) {}

  const rbdgrad_batch& batch() const { return b_; }
  std::uint64_t size() const { return b_.n; }

  /// Raw views of state k's inputs (no copy).
  Eigen::Map<const RawVector> q(std::size_t k) const { return vector(b_.q, k, 1); }
  Eigen::Map<const RawVector> qd(std::size_t k) const { return vector(b_.qd, k, 1); }
  Eigen::Map<const RawVector> u(std::size_t k) const { return vector(b_.u, k, 1); }
  Eigen::Map<const RawVector> fext(std::size_t k) const { return vector(b_.fext, k, 6); }  // needs b_.fext
  // Read with its true row-major layout, so the copy into a column-major MatrixX is exact for any
  // matrix. (A row-major array read as column-major gives the transpose, which equals the matrix
  // only when it is exactly symmetric; a computed M^-1 is symmetric only up to rounding.)
  Eigen::Map<const RawRowMajor> minv(std::size_t k) const {
    return {static_cast<const Raw*>(b_.minv) + k * nv_ * nv_, nv_, nv_};
  }

  /// State k's inputs in S: maps into the batch for floating point, converted into `buf` for fixed
  /// point; the caller's M^-1 (if any) is always copied into buf.minv (the core takes a MatrixX).
  StateInputs<S> inputs(std::size_t k, StateBuffers<S>& buf) const;

  /// Writes a vector (nv) or a column-major matrix (nv x nv) into the output slot of `output`
  /// (one rbdgrad_output flag) for state k, row-major.
  template <class Derived>
  void write(rbdgrad_output output, std::size_t k, const Eigen::MatrixBase<Derived>& value) const;

  /// state_status[k] = code (0 = computed), when the caller gave state_status.
  void set_status(std::size_t k, std::int32_t code) const {
    if (b_.state_status) b_.state_status[k] = code;
  }

 private:
  Eigen::Map<const RawVector> vector(const void* base, std::size_t k, std::size_t per_joint) const {
    const std::size_t len = per_joint * static_cast<std::size_t>(nv_);
    return {static_cast<const Raw*>(base) + k * len, static_cast<Eigen::Index>(len)};
  }

  const rbdgrad_batch& b_;
  Eigen::Index nv_;
};

// ---- implementation -------------------------------------------------------------------------------

template <class S>
StateBuffers<S>::StateBuffers(int nv)
    : q(VectorX<S>::Zero(nv)), qd(VectorX<S>::Zero(nv)), u(VectorX<S>::Zero(nv)),
      fext(VectorX<S>::Zero(6 * nv)), minv(MatrixX<S>::Zero(nv, nv)) {}

// raw int32 -> Q16.16 is exact (every int32 is a Q16.16 value); the reverse is raw()
template <class S, class Src, class Dst>
void to_scalar(const Eigen::MatrixBase<Src>& raw, Dst& out) {
  if constexpr (is_fixed_point_v<S>) {
    out = raw.unaryExpr([](std::int32_t r) { return S::from_raw(r); });
  } else {
    out = raw;
  }
}

template <class S>
StateInputs<S> BatchView<S>::inputs(std::size_t k, StateBuffers<S>& buf) const {
  const MatrixX<S>* minv_ptr = nullptr;
  if (b_.minv) {
    to_scalar<S>(minv(k), buf.minv);
    minv_ptr = &buf.minv;
  }
  if constexpr (is_fixed_point_v<S>) {
    // qd and u may be NULL when only M is asked for: then they are never read
    to_scalar<S>(q(k), buf.q);
    if (b_.qd) to_scalar<S>(qd(k), buf.qd);
    if (b_.u) to_scalar<S>(u(k), buf.u);
    if (b_.fext) to_scalar<S>(fext(k), buf.fext);
    return {{buf.q.data(), nv_}, {buf.qd.data(), nv_}, {buf.u.data(), nv_}, b_.fext ? buf.fext.data() : nullptr, minv_ptr};
  } else {
    auto at = [&](const void* base, std::size_t per) {
      return base ? static_cast<const S*>(base) + k * per * static_cast<std::size_t>(nv_) : nullptr;
    };
    return {{at(b_.q, 1), nv_}, {at(b_.qd, 1), nv_}, {at(b_.u, 1), nv_}, at(b_.fext, 6), minv_ptr};
  }
}

template <class S>
template <class Derived>
void BatchView<S>::write(rbdgrad_output output, std::size_t k, const Eigen::MatrixBase<Derived>& value) const {
  const bool matrix = (output & kMatrixOutputs) != 0;
  const std::size_t per_state = static_cast<std::size_t>(matrix ? nv_ * nv_ : nv_);
  Raw* out = static_cast<Raw*>(output_pointer(b_, output)) + k * per_state;
  // a row-major map takes care of the layout change; Eigen assigns element (i, j) to (i, j)
  Eigen::Map<RawRowMajor> dst(out, value.rows(), value.cols());
  if constexpr (is_fixed_point_v<S>) {
    dst = value.unaryExpr([](S x) { return static_cast<Raw>(x.raw()); });
  } else {
    dst = value;
  }
}

}  // namespace rbdgrad::plugin
