// One model on one GPU: the robot constants uploaded once (f64 and f32), the kernel's workspace
// allocated once, streams, and one pinned host block and one device block per direction that
// grow by size class. compute() copies the inputs into the pinned block, then on a stream: one
// copy in, one kernel launch for the whole batch, one copy out; then the outputs out of the
// pinned block into the caller's arrays. Small batches skip the two device copies: the kernel
// reads and writes the pinned blocks directly (mapped memory). Larger batches skip the staging
// of every caller array that is pinned itself. Large batches go in chunks through a pipeline:
// every chunk's inputs on one upload stream, its kernel on one of two compute streams once they
// are there, its outputs on one download stream once it is done, so that a kernel never waits
// for an earlier chunk's download and the copies of one chunk overlap the kernels of others.
#pragma once

#include <cuda_runtime_api.h>

#include <cstddef>
#include <memory>
#include <optional>
#include <string>

#include "block_launch.hpp"
#include "warp_launch.hpp"
#include "common/batch_plan.hpp"
#include "device/fused_state.hpp"
#include "device_memory.hpp"
#include "kernel_graphs.hpp"
#include "specialized_kernel.hpp"
#include "specialized_warp_kernel.hpp"
#include "rbdgrad/model.hpp"
#include "rbdgrad/plugin_api.h"
#include "rbdgrad/status.hpp"

namespace rbdgrad::cuda {

// Largest model the instance takes: bounds the workspace of one thread slot.
inline constexpr int kMaxNv = 64;
static_assert(kMaxNv <= kMaxBlockNv, "the block kernel's index arithmetic must cover every model the instance takes");
// Default device memory for the kernel's workspace (the plugin's option workspace_mib); the number
// of thread slots follows from it, up to what the GPU can hold resident.
inline constexpr std::size_t kDefaultWorkspaceBytes = std::size_t{1} << 30;
// A batch that one pass of the resident threads covers is pipelined in up to kMaxChunks chunks,
// each with at least kChunkMatrixEntries entries in each nv x nv output and at least
// kMinChunkStates states (the plugin's options chunk_min_states, max_chunks); see chunk_states.
// Measured on the H200 (docs/benchmarks/cuda.md, run 23): iiwa14 (nv 7) is fastest in chunks of
// about 1024 states, talos_reduced (nv 32) of 128 to 512.
inline constexpr std::size_t kChunkMatrixEntries = 1024 * 49;
inline constexpr std::size_t kMinChunkStates = 64;
inline constexpr std::size_t kMaxChunks = 8;

/// How large batches are split into pipelined chunks (chunk_states).
struct ChunkRule {
  std::size_t min_states = 0;           // 0: by the model's size, chunk_min_states(nv)
  std::size_t max_chunks = kMaxChunks;  // 1 to kMaxChunks
};

/// The smallest chunk of a model with nv joints: kChunkMatrixEntries / nv^2 states rounded up,
/// at least kMinChunkStates.
std::size_t chunk_min_states(int nv);
// The block kernel computes gradient requests of up to this many states (the plugin's option
// block_max_states); larger ones, and every other request, go to the one-thread kernel. At most
// 2^29: the kernel indexes a launch's states, and 6 times them, by 32 bits (block_kernel_entry.hpp).
inline constexpr std::size_t kDefaultBlockMaxStates = std::size_t{1} << 29;

// f32 gradient batches of at least this many states on models of at most kThreadKernelMaxNv
// joints go to the one-thread kernel (the plugin's option f32_thread_kernel_min_states; 0:
// never). Measured on the H200, end to end (docs/benchmarks/cuda.md): at 65536 states the
// one-thread kernel wins for iiwa14, panda and hyq (nv 7, 9, 12: 1866 against 2339 us, 2861
// against 3718, 3029 against 3951); at 32768 the block kernel wins for iiwa14 and panda, and for
// talos_reduced (nv 32) at every size; in f64 the block kernel wins everywhere.
inline constexpr std::size_t kDefaultF32ThreadKernelMinStates = 65536;
inline constexpr int kThreadKernelMaxNv = 16;

// Batches whose inputs and outputs together take up to this many KiB skip the copies: the kernel
// reads its inputs from the pinned host block and writes its outputs into the other one, over
// PCIe (the plugin's option mapped_io_max_kib). On the H200 that is faster for iiwa14 up to 256
// states (243 KiB in f64) and slower for talos_reduced from 32 states (548 KiB), see
// docs/benchmarks/cuda.md.
inline constexpr std::size_t kDefaultMappedIoMaxKib = 320;
// Batches of at least this many bytes (inputs and outputs) check whether the caller's arrays are
// pinned, so that the copies or the kernel use them in place instead of staging them
// (KernelOptions::pinned_check_min_bytes). On the H200 (run 46) checking from 16 KiB made iiwa14
// f64 at 64 states 20.2 us end to end instead of 22.8, f32 at 128 21.0 instead of 23.2, and
// changed nothing at 16 and 32 states.
inline constexpr std::size_t kMappedPinnedCheckMinBytes = 16 * 1024;
// Batches whose arrays are all pinned skip the device copies up to this many KiB (the plugin's
// option mapped_pinned_max_kib): the kernel reads and writes them in place over PCIe, which hides
// the transfers behind the kernel. On the H200 (run 28) that is faster up to about 4 MB: iiwa14 f64
// at N = 1024 55.4 against 77.1 us with copies, talos_reduced f64 at N = 256 135 against 174; and
// slower above (iiwa14 f64 at N = 16384 496 against 412, talos_reduced at N = 1024 471 against 431).
inline constexpr std::size_t kDefaultMappedPinnedMaxKib = 4096;

/// What an f32 gradient batch computes in (the plugin's option f32_compute: auto, f32, f64). In
/// f64 the block kernel reads the f32 inputs and rounds its results to f32 as it writes them:
/// more accurate than f32 arithmetic and, where the GPU's f64 rate is at least half its f32 rate,
/// faster (the f32 kernel does twice the f64 kernel's operations, docs/benchmarks/cuda.md). auto:
/// f64 on such GPUs (cudaDevAttrSingleToDoublePrecisionPerfRatio <= 2: A100, H100, H200), f32
/// elsewhere.
enum class F32Compute { kAuto, kF32, kF64 };
inline constexpr int kFastF64MaxRatio = 2;

/// Which kernel computes a batch, the block kernel's shape, and which batches skip the copies
/// (plugin options of the same names; mapped_io_max_kib 0: none).
struct KernelOptions {
  std::size_t block_max_states = kDefaultBlockMaxStates;
  std::size_t f32_thread_kernel_min_states = kDefaultF32ThreadKernelMinStates;
  BlockShape block_shape;
  std::size_t mapped_io_max_kib = kDefaultMappedIoMaxKib;
  std::size_t mapped_pinned_max_kib = kDefaultMappedPinnedMaxKib;
  // batches of at least this many bytes check whether the caller's arrays are pinned
  std::size_t pinned_check_min_bytes = kMappedPinnedCheckMinBytes;
  // the block kernel compiled for the robot (specialize()) where there is one, else the generic
  bool robot_specific = true;
  // CUDA events around the kernels, for last_kernel_ms (benchmarks): two more calls per batch
  bool time_kernel = false;
  // a batch of one block-kernel launch without copies goes as a CUDA Graph (kernel_graphs.hpp)
  bool graphs = true;
  // gradient batches computed in f64 on models of up to kMaxWarpNv joints run the warp kernel
  // (warp_launch.hpp) instead of the block kernel
  bool warp_kernel = true;
  // the block kernel compiled for the robot is the compact one (device/block_kernel_entry.hpp):
  // more states an SM where shared memory limits them (talos_reduced on an H200: four instead of
  // three, its kernel 29% faster at 65536 states and no slower end to end at any size measured,
  // docs/benchmarks/cuda.md). Read by specialize(), which builds the kernel.
  bool block_compact = true;
  // the compact kernel's lean working set (device/block_workspace.hpp): the inertias and B's and
  // Bc's symmetric parts by their parameters, their other parts by the momenta, each array placed
  // by its lifetime (talos_reduced: 26 KiB a state where the compact kernel takes 55, eight states
  // an SM at 128 threads a state, its automatic shape for large launches: block_shape_for; on an
  // H200 its kernel 21% faster at 65536 states, end to end from 0.3% slower to 5% faster at the
  // sizes measured, docs/benchmarks/cuda.md). Needs block_compact. Read by specialize(), which
  // builds the kernel, and by the launches' shape.
  bool block_lean = true;
  // the lean build's M^-1 by the tree's chains where they fit one warp (device/block_tree_chains.hpp:
  // talos_reduced's 10 level passes and the columns' pass one pass, on one warp, the other warps
  // on d tau/d qd's rows; on an H200 its kernel 5.4% faster at 65536 f64 states, 4.8% f32
  // batches, docs/benchmarks/cuda.md). Read by specialize(); ignored without block_lean.
  bool block_tree_chains = true;
  // with the chains, M^-1's columns by the tree's blocks (device/block_tree_columns.hpp: the
  // column's ancestors and its block's segments as constants, the same bits as the generic
  // columns; talos_reduced's kernel at 65536 states 0.2-0.3% faster f64, 0.6-0.7% f32 batches, on
  // an H100, runs 154 and 158, docs/benchmarks/cuda.md). Read by specialize(); ignored without
  // block_tree_chains.
  bool block_tree_columns = true;
  // warp-kernel batches with at least this many bytes of outputs write the first ones early
  // (warp_launch.hpp)
  std::uint64_t warp_early_outputs_min_bytes = kDefaultWarpEarlyOutputsMinBytes;
  // a warp-kernel batch without copies whose q, qd and u fit kWarpInlineInputBytes (and no
  // external forces or M^-1) carries them in the kernel's parameters, in a block of at least
  // warp_inline_min_block bytes (warp_inline_block_bytes)
  bool warp_inline_inputs = true;
  std::size_t warp_inline_min_block = 0;
  ChunkRule chunks;
  F32Compute f32_compute = F32Compute::kAuto;
};

/// Errors: invalid_argument (a block of more than 1024 threads, or none; chunks.max_chunks outside
/// 1 to kMaxChunks; block_lean without block_compact).
Status check_kernel_options(const KernelOptions& options);

/// States per chunk of a batch of `n` states whose kernel has `slots` resident thread slots (the
/// one-thread kernel's workspace; n for the block kernel, which needs none): whole passes of the
/// slots when the batch needs several, else n split in up to rule.max_chunks
/// chunks of at least rule.min_states (0: chunk_min_states(nv)). n >= 1, slots >= 1, rule as
/// check_kernel_options allows.
std::size_t chunk_states(std::size_t n, std::size_t slots, const ChunkRule& rule, int nv);

class CudaInstance {
 public:
  /// \param[in] model a validated model (model_from_desc), nv <= kMaxNv (else unimplemented).
  /// \param[in] device the CUDA device index.
  /// \param[out] out set on success. Errors: unavailable (no driver or GPU, no such device, out of
  ///             device memory), unimplemented (model too large).
  /// \param[in] workspace_bytes device memory for the kernel's workspace (at least one block of
  ///             thread slots is always allocated).
  static Status create(const Model& model, int device, std::unique_ptr<CudaInstance>& out,
                       std::size_t workspace_bytes = kDefaultWorkspaceBytes);
  ~CudaInstance();
  CudaInstance(const CudaInstance&) = delete;
  CudaInstance& operator=(const CudaInstance&) = delete;

  /// Validates `batch` (f64 or f32; fixed point is unimplemented) and computes it. Every state is
  /// attempted; state_status says which failed, and the error names the first of them:
  /// "state 3: fd_derivatives: result is not finite (NaN or Inf)". Not reentrant.
  Status compute(const rbdgrad_batch* batch);

  /// Fixes what every batch computes (a scene's plan, ABI 1.3): compute() then refuses batches that
  /// do not follow it, and specialize() compiles the block kernel with the plan's stages only.
  void set_plan(std::optional<plugin::BatchPlan> plan) { plan_ = std::move(plan); }
  /// The plan's block_stages, or kPerBatch without a plan.
  int block_stages() const;

  /// Compiles the block kernel for this robot in both precisions (SpecializedBlockKernel, NVRTC)
  /// and, for models of up to kMaxWarpNv joints, the warp kernel (SpecializedWarpKernel), from
  /// `cache_dir` when it holds them ("" = no disk cache). Until then, and for a kernel or
  /// precision where it fails, the generic kernel runs; kernel_description() says which runs and
  /// why.
  /// \return the first failure (the instance stays usable).
  Status specialize(const std::string& cache_dir);
  /// "kernel compiled for this robot (f64: compiled in 2.1 s; f32: disk cache)", or "generic
  /// kernel" and why, then "; gradient batches computed in f64 on the warp kernel" where they
  /// are, with how that was built ("(compiled for this robot: disk cache, 0.1 s)"): for logs
  /// (describe_instance).
  const std::string& kernel_description() const { return kernel_description_; }

  /// Kernel choice and shape for the next compute() calls. Errors: check_kernel_options.
  Status set_kernel_options(const KernelOptions& options);
  const KernelOptions& kernel_options() const { return kernel_; }
  /// Whether the last successful compute() ran the block kernel, and whether it skipped the copies.
  bool last_used_block_kernel() const { return last_block_; }
  bool last_used_mapped_io() const { return last_mapped_; }
  /// Whether the last successful compute() ran the warp kernel (one of the block kernel's requests).
  bool last_used_warp_kernel() const { return last_warp_; }
  /// The bytes of the parameter block that carried its inputs in the warp kernel's parameters
  /// (KernelOptions::warp_inline_inputs); 0: none.
  std::size_t last_inline_block_bytes() const { return last_inline_; }
  /// Whether the last successful compute() ran the block or warp kernel compiled for this robot.
  bool last_used_robot_specific_kernel() const { return last_specific_; }
  /// How many chunks the last successful compute() went in (chunk_states).
  std::size_t last_chunks() const { return last_chunks_; }
  /// Whether the last successful compute() launched its kernel as a CUDA Graph.
  bool last_used_graph() const { return last_graph_; }
  /// Whether the last successful compute() was an f32 batch computed in f64 (F32Compute).
  bool last_computed_f32_in_f64() const { return last_f32_in_f64_; }
  /// Whether f32 gradient batches compute in f64 with the current options on this GPU.
  bool f32_in_f64() const;
  /// How many of the caller's arrays the last successful compute() moved without staging (pinned),
  /// or, with mapped memory, the kernel read or wrote in place.
  int last_pinned_arrays() const { return last_pinned_; }

  int device() const { return device_; }
  /// "NVIDIA H200 (device 0)": for logs (describe_instance).
  const std::string& device_name() const { return device_name_; }
  std::size_t slots() const { return slots_; }
  /// The kernel's own time in the last successful compute(), from CUDA events around the launch
  /// (resolution about 0.5 us): the benchmarks' kernel-only figure. 0 unless the options'
  /// time_kernel was set for that compute().
  float last_kernel_ms() const { return last_kernel_ms_; }

 private:
  CudaInstance(const Model& model, int device, std::size_t workspace_bytes);
  Status init();
  template <class S> Status upload_model(Allocation& block, ModelView<S>& view);
  // sets kernel_description_ from block_description_ and the options
  void describe();
  template <class S> Status compute_typed(const rbdgrad_batch& batch);
  // C: what the block kernel would compute in, S: the batch's scalars
  template <class C, class S> bool use_block_kernel(const BatchPointers<S>& batch, std::size_t n) const;
  // whether a block-kernel batch computed in C runs the warp kernel instead
  template <class C, class S> bool use_warp_kernel(const BatchPointers<S>& batch) const;
  // the block kernel, or with `warp` (computing in f64) the warp kernel, its inputs from the
  // first inline_block bytes of inline_inputs_ where inline_block is not 0
  template <class C, class S>
  cudaError_t launch_block(const BatchPointers<S>& batch, const BlockShape& shape, bool warp,
                           std::size_t inline_block, cudaStream_t stream) const;
  // the same as a CUDA Graph (graphs_), else as launch_block
  template <class C, class S>
  cudaError_t launch_block_graph(const BatchPointers<S>& batch, const BlockShape& shape, bool warp,
                                 std::size_t inline_block, cudaStream_t stream);
  template <class S> const ModelView<S>& view() const;
  template <class C, class S> const SpecializedBlockKernel* specialized() const;
  // the block kernel's shape for a batch of n states computed in C: lean where the kernel that
  // runs is the lean build (not where the option is on but the generic kernel runs instead)
  template <class C, class S> BlockShape block_shape(std::size_t n) const;
  // the warp kernel's entry points compiled for the robot, or null (the generic ones)
  const WarpKernelTable* warp_table() const;

  Model model_;
  std::optional<plugin::BatchPlan> plan_;  // a scene's (set_plan)
  int device_;
  std::string device_name_;
  std::size_t workspace_bytes_;
  // a batch of one chunk runs on streams_[0]; the chunks of a larger one alternate between the
  // two for their kernels, their copies go on upload_ and download_
  cudaStream_t streams_[2] = {};
  cudaStream_t upload_ = nullptr, download_ = nullptr;
  cudaEvent_t kernel_start_ = nullptr;  // before the first chunk's launch (time_kernel)
  // after each chunk's inputs reached the device (batches of several chunks): its kernel waits
  cudaEvent_t uploaded_[kMaxChunks] = {};
  // after each chunk's launch but the last (and after the last, with time_kernel): its download,
  // and the next chunk's one-thread kernel, wait for it
  cudaEvent_t kernel_end_[kMaxChunks] = {};
  // after each chunk's outputs reached the pinned block (batches of several chunks; one chunk
  // waits for its stream)
  cudaEvent_t copied_[kMaxChunks] = {};
  float last_kernel_ms_ = 0;
  KernelOptions kernel_;
  std::size_t max_shared_bytes_ = 0;  // per block, the device's opt-in limit
  bool last_block_ = false;
  bool last_mapped_ = false;
  bool last_specific_ = false;
  bool last_warp_ = false;
  std::size_t last_inline_ = 0;  // the parameter block's bytes, 0: none
  WarpInlineInputs inline_inputs_{};  // a small batch's inputs for the warp kernel's parameters
  bool last_f32_in_f64_ = false;
  bool last_graph_ = false;
  KernelGraphs graphs_;
  std::size_t last_chunks_ = 0;
  bool fast_f64_ = false;  // the GPU's f64 rate is at least half its f32 rate (F32Compute)
  std::unique_ptr<SpecializedBlockKernel> specialized_f64_, specialized_f32_, specialized_f64_for_f32_;
  std::unique_ptr<SpecializedWarpKernel> specialized_warp_;
  // the block kernel's build and the warp kernel's (specialize()), then the whole description
  std::string block_description_ = "generic kernel";
  std::string warp_build_;
  std::string kernel_description_ = "generic kernel";
  int last_pinned_ = 0;
  Allocation d_ints_{MemoryKind::kDevice};      // (ModelLayout::ints) topology, shared by both precisions
  Allocation d_model_f64_{MemoryKind::kDevice};  // (ModelLayout::scalars) constants in f64
  Allocation d_model_f32_{MemoryKind::kDevice};  // same in f32
  ModelView<double> view_f64_;
  ModelView<float> view_f32_;
  Allocation d_scratch_{MemoryKind::kDevice};    // (slots_ x WorkspaceView::scalars) in f64 size
  std::size_t slots_ = 0;
  Allocation h_in_{MemoryKind::kPinnedHost}, d_in_{MemoryKind::kDevice};    // q | qd | u | fext | minv
  Allocation h_out_{MemoryKind::kPinnedHost}, d_out_{MemoryKind::kDevice};  // outputs | status
};

}  // namespace rbdgrad::cuda
