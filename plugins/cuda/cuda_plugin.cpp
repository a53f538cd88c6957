// The CUDA backend's plugin table: the completely fused kernel (one launch per batch) on one GPU
// per instance, in f64 and f32. Without a driver or GPU the library still loads, and every
// instance creation says why it cannot run (RBDGRAD_ERROR_UNAVAILABLE).
#include <memory>
#include <optional>
#include <string>
#include <string_view>

#include "common/batch_plan.hpp"
#include "common/batch_view.hpp"
#include "common/entry_checks.hpp"
#include "common/error.hpp"
#include "common/host_api.hpp"
#include "common/model_desc.hpp"
#include "common/options.hpp"
#include "cuda_device.hpp"
#include "cuda_instance.hpp"
#include "kernel_cache.hpp"
#include "rbdgrad/plugin_api.h"

#ifndef RBDGRAD_VERSION
#define RBDGRAD_VERSION "unknown"
#endif

// Completes the ABI's opaque instance type for this plugin.
struct rbdgrad_instance {
  std::unique_ptr<rbdgrad::cuda::CudaInstance> gpu;
};

namespace rbdgrad::plugin {
namespace {

// the oldest host minor this plugin works with: it uses nothing added after 1.0
constexpr std::uint32_t kMinHostMinor = 0;
constexpr std::uint32_t kPrecisions = RBDGRAD_PRECISION_F64 | RBDGRAD_PRECISION_F32;
// more devices than this is a typo, not a machine
constexpr std::uint64_t kMaxDevice = 1023;
// 1 TiB of workspace is a typo, not a GPU
constexpr std::uint64_t kMaxWorkspaceMib = std::uint64_t{1} << 20;

rbdgrad_error* get_info(rbdgrad_plugin_info* info) {
  return guarded([&]() -> Status {
    if (Status s = check_info(info); !s) return s;
    info->name = "cuda";
    info->version = RBDGRAD_VERSION;
    info->precisions = kPrecisions;
    info->outputs = kAllOutputs;
    info->max_batch = 0;  // the I/O blocks grow with the batch
    info->max_nv = cuda::kMaxNv;
    return Status::ok();
  });
}

// The request first (cheap), then the model's size, then whether there is a GPU at all.
rbdgrad_error* can_run(const rbdgrad_model_desc* model, std::uint32_t precision, std::uint32_t outputs, std::uint64_t n) {
  return guarded([&]() -> Status {
    if (Status s = check_can_run_question(model, n); !s) return s;
    if (Status s = check_request(precision, outputs, kPrecisions, kAllOutputs); !s) return s;
    if (model->nv > static_cast<std::uint32_t>(cuda::kMaxNv))
      return unimplemented("model has " + std::to_string(model->nv) + " joints, more than the " +
                           std::to_string(cuda::kMaxNv) + " the cuda backend supports");
    return cuda::check_device(0);
  });
}

rbdgrad_error* create_instance(const rbdgrad_model_desc* desc, const rbdgrad_options* options,
                               rbdgrad_instance** instance) {
  return guarded([&]() -> Status {
    if (instance == nullptr) return invalid_argument("instance is NULL");
    *instance = nullptr;
    if (desc == nullptr) return invalid_argument("model is NULL");
    // device: the CUDA device index; each visible GPU is its own instance.
    // workspace_mib: device memory for the one-thread kernel's workspace (default 1024).
    // block_max_states: the block kernel takes gradient requests of up to this many states (0:
    // never); threads_per_state (0: by the model's size), states_per_block: its block shape.
    // mapped_io_max_kib: batches whose inputs and outputs take up to this many KiB skip the
    // device copies (the kernel works on pinned host memory); mapped_pinned_max_kib: the same for
    // batches whose arrays are all pinned (0: none). f32_thread_kernel_min_states: f32
    // gradient batches of at least this many states on small models run the one-thread kernel
    // (0: never). chunk_min_states, max_chunks: batches larger than one chunk go through the
    // pipeline in up to max_chunks chunks of at least chunk_min_states states (0: by the model's
    // size). f32_compute: auto (default), f32 or f64: what f32 gradient batches compute in
    // (cuda::F32Compute). specialize: compile the block and warp kernels for the robot at load
    // (NVRTC; default true); kernel_cache_dir: where compiled kernels are kept across restarts ("" = not kept;
    // default $XDG_CACHE_HOME or $HOME/.cache, under rbdgrad/cuda-kernels). graphs: a batch of one
    // kernel launch without copies goes as a CUDA Graph (default true). warp_kernel: gradient
    // batches computed in f64 on models of up to 16 joints run the warp kernel (default true).
    // block_compact: the block kernel compiled for the robot is the compact one, which fits more
    // states an SM (default true; false: the dense one; cuda_instance.hpp). block_lean: that kernel
    // with its lean working set (default true where the compact kernel is built; needs
    // block_compact). block_tree_chains: the lean kernel's M^-1 by the tree's chains (default true
    // where the lean kernel is built; needs block_lean). block_tree_columns: with the chains,
    // M^-1's columns by the tree's blocks (default true with the chains; needs block_tree_chains).
    if (Status s = check_options(options, {"device", "workspace_mib", "block_max_states", "threads_per_state",
                                           "states_per_block", "mapped_io_max_kib", "f32_thread_kernel_min_states",
                                           "mapped_pinned_max_kib", "chunk_min_states", "max_chunks", "f32_compute",
                                           "specialize", "kernel_cache_dir", "graphs", "warp_kernel",
                                           "block_compact", "block_lean", "block_tree_chains",
                                           "block_tree_columns"});
        !s)
      return s;
    bool specialize = true;
    if (Status s = option_bool(options, "specialize", specialize); !s) return s;
    bool graphs = true;
    if (Status s = option_bool(options, "graphs", graphs); !s) return s;
    bool warp_kernel = true;
    if (Status s = option_bool(options, "warp_kernel", warp_kernel); !s) return s;
    bool block_compact = true;
    if (Status s = option_bool(options, "block_compact", block_compact); !s) return s;
    // asked for explicitly only: without specialize the generic kernel runs, and the default is moot
    if (block_compact && !specialize && find_option(options, "block_compact") != nullptr)
      return invalid_argument("option 'block_compact' needs 'specialize' (the compact kernel is compiled for the robot)");
    // on by default with the compact kernel; asked for explicitly, it needs what it is part of
    bool block_lean = block_compact;
    if (Status s = option_bool(options, "block_lean", block_lean); !s) return s;
    const bool lean_asked = find_option(options, "block_lean") != nullptr;
    if (block_lean && !specialize && lean_asked)
      return invalid_argument(
          "option 'block_lean' needs 'specialize' (the lean working set is compiled for the robot)");
    // on by default with the lean kernel; asked for explicitly, it needs the lean kernel
    bool block_tree_chains = block_lean;
    if (Status s = option_bool(options, "block_tree_chains", block_tree_chains); !s) return s;
    if (block_tree_chains && !block_lean && find_option(options, "block_tree_chains") != nullptr)
      return invalid_argument("option 'block_tree_chains' needs 'block_lean' (the chains are the lean kernel's)");
    // on by default with the chains; asked for explicitly, it needs them
    bool block_tree_columns = block_tree_chains;
    if (Status s = option_bool(options, "block_tree_columns", block_tree_columns); !s) return s;
    if (block_tree_columns && !block_tree_chains && find_option(options, "block_tree_columns") != nullptr)
      return invalid_argument(
          "option 'block_tree_columns' needs 'block_tree_chains' (the columns by the tree are the chains' pass)");
    const char* cache_option = find_option(options, "kernel_cache_dir");
    const std::string cache_dir = cache_option != nullptr ? cache_option : cuda::default_kernel_cache_dir();
    std::uint64_t device = 0;
    if (Status s = option_uint(options, "device", 0, kMaxDevice, device); !s) return s;
    std::uint64_t workspace_mib = cuda::kDefaultWorkspaceBytes >> 20;
    if (Status s = option_uint(options, "workspace_mib", 1, kMaxWorkspaceMib, workspace_mib); !s) return s;
    cuda::KernelOptions kernel;
    std::uint64_t block_max = kernel.block_max_states;
    std::uint64_t tps = static_cast<std::uint64_t>(kernel.block_shape.threads_per_state);
    std::uint64_t spb = static_cast<std::uint64_t>(kernel.block_shape.states_per_block);
    std::uint64_t mapped_max = kernel.mapped_io_max_kib, mapped_pinned_max = kernel.mapped_pinned_max_kib;
    std::uint64_t f32_thread_min = kernel.f32_thread_kernel_min_states;
    std::uint64_t chunk_min = kernel.chunks.min_states, max_chunks = kernel.chunks.max_chunks;
    if (Status s = option_uint(options, "block_max_states", 0, cuda::kDefaultBlockMaxStates, block_max); !s) return s;
    if (Status s = option_uint(options, "threads_per_state", 0, 1024, tps); !s) return s;
    if (Status s = option_uint(options, "states_per_block", 1, 1024, spb); !s) return s;
    if (Status s = option_uint(options, "mapped_io_max_kib", 0, std::uint64_t{1} << 30, mapped_max); !s)
      return s;
    if (Status s = option_uint(options, "f32_thread_kernel_min_states", 0, std::uint64_t{1} << 40, f32_thread_min); !s)
      return s;
    if (Status s = option_uint(options, "chunk_min_states", 0, std::uint64_t{1} << 40, chunk_min); !s) return s;
    if (Status s = option_uint(options, "max_chunks", 1, cuda::kMaxChunks, max_chunks); !s) return s;
    kernel.chunks = {static_cast<std::size_t>(chunk_min), static_cast<std::size_t>(max_chunks)};
    if (const char* f32_compute = find_option(options, "f32_compute")) {
      const std::string_view v(f32_compute);
      if (v != "auto" && v != "f32" && v != "f64")
        return invalid_argument("option 'f32_compute' is '" + std::string(v) + "': expected 'auto', 'f32' or 'f64'");
      kernel.f32_compute = v == "f32" ? cuda::F32Compute::kF32 : v == "f64" ? cuda::F32Compute::kF64 : cuda::F32Compute::kAuto;
    }
    kernel.block_max_states = static_cast<std::size_t>(block_max);
    kernel.f32_thread_kernel_min_states = static_cast<std::size_t>(f32_thread_min);
    kernel.mapped_io_max_kib = static_cast<std::size_t>(mapped_max);
    if (Status s = option_uint(options, "mapped_pinned_max_kib", 0, std::uint64_t{1} << 30, mapped_pinned_max); !s)
      return s;
    kernel.mapped_pinned_max_kib = static_cast<std::size_t>(mapped_pinned_max);
    kernel.block_shape = {static_cast<int>(tps), static_cast<int>(spb)};
    kernel.graphs = graphs;
    kernel.warp_kernel = warp_kernel;
    kernel.block_compact = block_compact;
    kernel.block_lean = block_lean;
    kernel.block_tree_chains = block_tree_chains;
    kernel.block_tree_columns = block_tree_columns;
    if (Status s = cuda::check_kernel_options(kernel); !s) return s;
    Model model;
    if (Status s = model_from_desc(*desc, model); !s) return s;
    std::optional<BatchPlan> plan;
    if (Status s = plan_from_desc(*desc, kAllOutputs, plan); !s) return s;
    auto made = std::make_unique<rbdgrad_instance>();
    if (Status s = cuda::CudaInstance::create(model, static_cast<int>(device), made->gpu,
                                              static_cast<std::size_t>(workspace_mib) << 20);
        !s)
      return s;
    if (Status s = made->gpu->set_kernel_options(kernel); !s) return s;
    made->gpu->set_plan(std::move(plan));
    // a kernel that cannot be compiled leaves the generic one, and the description says why
    if (specialize) (void)made->gpu->specialize(cache_dir);
    *instance = made.release();
    return Status::ok();
  });
}

rbdgrad_error* compute(rbdgrad_instance* instance, const rbdgrad_batch* batch) {
  return guarded([&]() -> Status {
    if (instance == nullptr || !instance->gpu) return invalid_argument("instance is NULL");
    return instance->gpu->compute(batch);
  });
}

void destroy_instance(rbdgrad_instance* instance) {
  guarded([&] { delete instance; });
}

rbdgrad_error* describe_instance(const rbdgrad_instance* instance, rbdgrad_instance_info* info) {
  return guarded([&]() -> Status {
    if (instance == nullptr || !instance->gpu) return invalid_argument("instance is NULL");
    if (Status s = check_instance_info(info); !s) return s;
    info->mode = "";
    info->device = instance->gpu->device_name().c_str();
    if (instance_info_has_detail(*info)) info->detail = instance->gpu->kernel_description().c_str();
    return Status::ok();
  });
}

constexpr rbdgrad_plugin_api kApi = {
    sizeof(rbdgrad_plugin_api),
    RBDGRAD_PLUGIN_API_MAJOR,
    RBDGRAD_PLUGIN_API_MINOR,
    &get_info,
    &can_run,
    &create_instance,
    &compute,
    &destroy_instance,
    &error_code,
    &error_message,
    &error_delete,
    &describe_instance,
    nullptr,  // estimate_latency: the host times the GPU (calibration)
};

}  // namespace
}  // namespace rbdgrad::plugin

// The one exported symbol (exports.map hides everything else).
extern "C" __attribute__((visibility("default"))) const rbdgrad_plugin_api* rbdgrad_plugin_entry(
    std::uint32_t host_api_major, std::uint32_t host_api_minor) {
  if (!rbdgrad::plugin::host_api_compatible("cuda", host_api_major, host_api_minor, rbdgrad::plugin::kMinHostMinor)) {
    return nullptr;
  }
  return &rbdgrad::plugin::kApi;
}
