// The warp kernel for any robot of up to kMaxWarpNv joints (device/warp_kernel_entry.hpp), one
// instantiation per segment width (8 or 16 lanes), place of the first outputs and place of the
// inputs.
#include <type_traits>

#include "warp_launch.hpp"

namespace rbdgrad::cuda {

#if defined(RBDGRAD_BLOCK_PASS_TIMING)
cudaError_t read_warp_stage_clocks(long long* out, int count) {
  return cudaMemcpyFromSymbol(out, g_warp_stage_clocks, sizeof(long long) * static_cast<std::size_t>(count));
}
#endif

namespace {

using Generic = ModelView<double>;

WarpEntry warp_entry(bool early_outputs, std::size_t inline_block) {
  if (inline_block == 2048) return WarpEntry::kInline2048;
  if (inline_block == 4096) return WarpEntry::kInline4096;
  if (inline_block != 0) return WarpEntry::kInline8192;
  return early_outputs ? WarpEntry::kEarly : WarpEntry::kLate;
}

template <int W, class IO>
const void* generic_kernel(WarpEntry entry) {
  switch (entry) {
    case WarpEntry::kLate: return reinterpret_cast<const void*>(warp_fused_kernel<W, Generic, IO, false>);
    case WarpEntry::kEarly: return reinterpret_cast<const void*>(warp_fused_kernel<W, Generic, IO, true>);
    case WarpEntry::kInline2048: return reinterpret_cast<const void*>(warp_fused_inline_kernel<W, Generic, IO, 2048>);
    case WarpEntry::kInline4096: return reinterpret_cast<const void*>(warp_fused_inline_kernel<W, Generic, IO, 4096>);
    case WarpEntry::kInline8192:
      return reinterpret_cast<const void*>(warp_fused_inline_kernel<W, Generic, IO, kWarpInlineInputBytes>);
  }
  return nullptr;
}

}  // namespace

template <class IO>
KernelLaunch warp_fused_launch(const ModelView<double>& model, const BatchPointers<IO>& batch,
                               std::uint64_t early_outputs_min_bytes, std::size_t inline_block,
                               const WarpKernelTable* robot) {
  const int W = warp_segment_width(model.nv);
  const std::uint64_t n = batch.n;
  KernelLaunch l;
  const int per_block = kWarpKernelThreads / W;
  // the outputs' bytes: qdd n x nv, the matrices n x nv x nv each
  const std::uint64_t nv = static_cast<std::uint64_t>(model.nv);
  std::uint64_t per_state = batch.out[output_index(kOutputQdd)] ? nv : 0;
  for (const std::uint32_t f : {kOutputMinv, kOutputDqddDq, kOutputDqddDqd})
    if (batch.out[output_index(f)]) per_state += nv * nv;
  const bool early = n * per_state * sizeof(IO) >= early_outputs_min_bytes;
  const WarpEntry entry = warp_entry(early, inline_block);
  const void* specific = nullptr;
  if (robot != nullptr) specific = (std::is_same_v<IO, float> ? robot->f32 : robot->f64)[static_cast<int>(entry)];
  l.function = specific != nullptr ? specific : W == 8 ? generic_kernel<8, IO>(entry) : generic_kernel<16, IO>(entry);
  l.grid = dim3(static_cast<unsigned>((n + per_block - 1) / per_block));
  l.block = dim3(kWarpKernelThreads);
  l.shared_bytes = W == 8 ? kWarpBlockSharedBytes<8> : kWarpBlockSharedBytes<16>;
  return l;
}

template <class IO>
cudaError_t launch_warp_fused(const ModelView<double>& model, const BatchPointers<IO>& batch,
                              std::uint64_t early_outputs_min_bytes, const WarpInlineInputs* inline_inputs,
                              std::size_t inline_block, cudaStream_t stream, const WarpKernelTable* robot) {
  const KernelLaunch l =
      warp_fused_launch(model, batch, early_outputs_min_bytes, inline_inputs != nullptr ? inline_block : 0, robot);
  ModelView<double> model_arg = model;
  BatchPointers<IO> batch_arg = batch;
  void* args[] = {&model_arg, &batch_arg, const_cast<WarpInlineInputs*>(inline_inputs)};
  if (const cudaError_t e = cudaLaunchKernel(l.function, l.grid, l.block, args, l.shared_bytes, stream); e != cudaSuccess)
    return e;
  return cudaGetLastError();
}

template KernelLaunch warp_fused_launch<double>(const ModelView<double>&, const BatchPointers<double>&,
                                                std::uint64_t, std::size_t, const WarpKernelTable*);
template KernelLaunch warp_fused_launch<float>(const ModelView<double>&, const BatchPointers<float>&, std::uint64_t,
                                               std::size_t, const WarpKernelTable*);
template cudaError_t launch_warp_fused<double>(const ModelView<double>&, const BatchPointers<double>&, std::uint64_t,
                                               const WarpInlineInputs*, std::size_t, cudaStream_t,
                                               const WarpKernelTable*);
template cudaError_t launch_warp_fused<float>(const ModelView<double>&, const BatchPointers<float>&, std::uint64_t,
                                              const WarpInlineInputs*, std::size_t, cudaStream_t,
                                              const WarpKernelTable*);

}  // namespace rbdgrad::cuda
