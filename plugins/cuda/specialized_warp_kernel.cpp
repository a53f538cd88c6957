#include "specialized_warp_kernel.hpp"

#include <algorithm>

#include "kernel_source.hpp"

namespace rbdgrad::cuda {

Status SpecializedWarpKernel::load(const Model& model, bool f32_batches, int device, const std::string& cache_dir,
                                   std::unique_ptr<SpecializedWarpKernel>& out) {
  if (warp_segment_width(model.nv) == 0)
    return Status(StatusCode::kInvalidArgument, "the warp kernel takes models of up to " +
                                                    std::to_string(kMaxWarpNv) + " joints, not " +
                                                    std::to_string(model.nv));
  int arch = 0;
  if (Status s = device_arch(device, arch); !s) return s;
  std::unique_ptr<SpecializedWarpKernel> k(new SpecializedWarpKernel());
  // the warp kernel's blocks stay within the default 48 KiB of shared memory (warp_kernel_entry.hpp)
  constexpr std::size_t kSharedBytes = std::max(kWarpBlockSharedBytes<8>, kWarpBlockSharedBytes<16>);
  if (Status s = CompiledLibrary::load(warp_kernel_program(model, f32_batches, arch), device, kSharedBytes, cache_dir,
                                       k->library_);
      !s)
    return s;
  for (int e = 0; e < kWarpEntries; ++e) {
    k->table_.f64[e] = k->library_->kernel(static_cast<std::size_t>(e));
    if (f32_batches) k->table_.f32[e] = k->library_->kernel(static_cast<std::size_t>(kWarpEntries + e));
  }
  out = std::move(k);
  return Status::ok();
}

}  // namespace rbdgrad::cuda
