// The stages of a block kernel compiled for a scene (issue 8), as its template argument kStages:
// bit 0 the d/dq columns, bit 1 the d/dqd columns, bit 2 M^-1 supplied by the caller (not
// computed). kPerBatch: decided per batch from its outputs and whether it brings M^-1 (the kernel
// of every other instance). Host code (the kernel's generated source) and device code share them.
#pragma once

namespace rbdgrad::cuda::block_stages {

inline constexpr int kPerBatch = -1;
inline constexpr int kDq = 1, kDqd = 2, kMinvSupplied = 4;

}  // namespace rbdgrad::cuda::block_stages
