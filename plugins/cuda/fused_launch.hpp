// The host's entry to the fused kernel (fused_kernel.cu): one launch computes every state of a
// batch. Plain C++ callers see only this declaration, not the device code.
#pragma once

#include <cuda_runtime_api.h>

#include <cstddef>

#include "device/fused_state.hpp"

namespace rbdgrad::cuda {

inline constexpr int kFusedThreadsPerBlock = 128;

/// Enqueues the kernel on `stream`: thread t of min(slots, n rounded up to a block) runs states
/// t, t + threads, ... in workspace slot t of `scratch` (WorkspaceView, `slots` interleaved slots).
/// \return the launch error, if any (execution errors show at the next synchronisation).
template <class S>
cudaError_t launch_fused(const ModelView<S>& model, S* scratch, std::size_t slots, const BatchPointers<S>& batch,
                         cudaStream_t stream);

}  // namespace rbdgrad::cuda
