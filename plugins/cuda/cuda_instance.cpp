#include "cuda_instance.hpp"

#include <algorithm>
#include <cstdio>
#include <cstring>
#include <string>
#include <type_traits>
#include <vector>

#include "common/batch_view.hpp"
#include "common/error.hpp"
#include "cuda_device.hpp"
#include "flat_model.hpp"
#include "fused_launch.hpp"
#include "host_copy.hpp"
#include "state_message.hpp"

namespace rbdgrad::cuda {

namespace {

constexpr std::uint32_t kPrecisions = RBDGRAD_PRECISION_F64 | RBDGRAD_PRECISION_F32;

constexpr bool same(rbdgrad_output abi, std::uint32_t device) { return static_cast<std::uint32_t>(abi) == device; }
static_assert(same(RBDGRAD_OUTPUT_QDD, kOutputQdd) && same(RBDGRAD_OUTPUT_MINV, kOutputMinv) &&
                  same(RBDGRAD_OUTPUT_DQDD_DQ, kOutputDqddDq) && same(RBDGRAD_OUTPUT_DQDD_DQD, kOutputDqddDqd) &&
                  same(RBDGRAD_OUTPUT_TAU, kOutputTau) && same(RBDGRAD_OUTPUT_DTAU_DQ, kOutputDtauDq) &&
                  same(RBDGRAD_OUTPUT_DTAU_DQD, kOutputDtauDqd) && same(RBDGRAD_OUTPUT_M, kOutputM),
              "the device code's output flags must equal the plugin ABI's");

// Regions of one I/O block, each aligned for coalesced access.
class BlockLayout {
 public:
  std::size_t add(std::size_t bytes) {
    const std::size_t at = size_;
    size_ = (size_ + bytes + 255) / 256 * 256;
    return at;
  }
  std::size_t size() const { return size_; }

 private:
  std::size_t size_ = 0;
};

// the caller's array of one output flag
void* caller_output(const rbdgrad_batch& b, int index) {
  return plugin::output_pointer(b, 1u << index);
}

// The device's address of the caller's array if it is page-locked host memory (cudaMallocHost,
// cudaHostRegister), else null: the copy engines then move it directly, without the staging
// block, and a kernel on mapped memory reads or writes it in place.
unsigned char* pinned_device_address(const void* p) {
  cudaPointerAttributes attributes{};
  if (cudaPointerGetAttributes(&attributes, p) != cudaSuccess) {
    cudaGetLastError();
    return nullptr;
  }
  return attributes.type == cudaMemoryTypeHost ? static_cast<unsigned char*>(attributes.devicePointer) : nullptr;
}

}  // namespace

CudaInstance::CudaInstance(const Model& model, int device, std::size_t workspace_bytes)
    : model_(model), device_(device), workspace_bytes_(workspace_bytes) {}

CudaInstance::~CudaInstance() {
  // the allocations free themselves; they need this device current
  cudaSetDevice(device_);
  for (const cudaEvent_t* events : {uploaded_, kernel_end_, copied_})
    for (std::size_t c = 0; c < kMaxChunks; ++c)
      if (events[c]) cudaEventDestroy(events[c]);
  if (kernel_start_) cudaEventDestroy(kernel_start_);
  for (cudaStream_t s : {streams_[0], streams_[1], upload_, download_})
    if (s) cudaStreamDestroy(s);
}

Status CudaInstance::create(const Model& model, int device, std::unique_ptr<CudaInstance>& out,
                            std::size_t workspace_bytes) {
  if (model.nv > kMaxNv)
    return unimplemented("model has " + std::to_string(model.nv) + " joints, more than the " + std::to_string(kMaxNv) +
                         " the cuda backend supports");
  if (Status s = check_device(device); !s) return s;
  std::unique_ptr<CudaInstance> instance(new CudaInstance(model, device, workspace_bytes));
  if (Status s = instance->init(); !s) return s;
  out = std::move(instance);
  return Status::ok();
}

template <class S>
Status CudaInstance::upload_model(Allocation& block, ModelView<S>& view) {
  const FlatModel<S> flat(model_);
  if (Status s = block.reserve(flat.scalars.size() * sizeof(S)); !s) return s;
  if (Status s = cuda_status(cudaMemcpy(block.data(), flat.scalars.data(), flat.scalars.size() * sizeof(S),
                                        cudaMemcpyHostToDevice),
                             "copying the model to the device");
      !s)
    return s;
  view = flat.view(block.as<S>(), d_ints_.as<int>());
  return Status::ok();
}

Status CudaInstance::init() {
  if (Status s = cuda_status(cudaSetDevice(device_), "cudaSetDevice(" + std::to_string(device_) + ")"); !s) return s;
  for (cudaStream_t* stream : {&streams_[0], &streams_[1], &upload_, &download_}) {
    if (Status s = cuda_status(cudaStreamCreateWithFlags(stream, cudaStreamNonBlocking), "cudaStreamCreate"); !s)
      return s;
  }
  if (Status s = cuda_status(cudaEventCreate(&kernel_start_), "cudaEventCreate"); !s) return s;
  for (std::size_t c = 0; c < kMaxChunks; ++c) {
    if (Status s = cuda_status(cudaEventCreate(&kernel_end_[c]), "cudaEventCreate"); !s) return s;
    for (cudaEvent_t* e : {&uploaded_[c], &copied_[c]})
      if (Status s = cuda_status(cudaEventCreateWithFlags(e, cudaEventDisableTiming), "cudaEventCreate"); !s) return s;
  }
  // robot constants, once
  const FlatModel<double> flat(model_);
  if (Status s = d_ints_.reserve(flat.ints.size() * sizeof(int)); !s) return s;
  if (Status s = cuda_status(
          cudaMemcpy(d_ints_.data(), flat.ints.data(), flat.ints.size() * sizeof(int), cudaMemcpyHostToDevice),
          "copying the model to the device");
      !s)
    return s;
  if (Status s = upload_model(d_model_f64_, view_f64_); !s) return s;
  if (Status s = upload_model(d_model_f32_, view_f32_); !s) return s;

  // workspace: one slot per thread that can be resident, as far as the budget allows
  cudaDeviceProp prop{};
  if (Status s = cuda_status(cudaGetDeviceProperties(&prop, device_), "cudaGetDeviceProperties"); !s) return s;
  const std::size_t slot_bytes = WorkspaceView<double>::scalars(model_.nv) * sizeof(double);
  const std::size_t resident = static_cast<std::size_t>(prop.multiProcessorCount) * prop.maxThreadsPerMultiProcessor;
  const std::size_t block = kFusedThreadsPerBlock;
  slots_ = std::min(resident, workspace_bytes_ / slot_bytes) / block * block;
  slots_ = std::max(slots_, block);
  max_shared_bytes_ = prop.sharedMemPerBlockOptin;
  device_name_ = std::string(prop.name) + " (device " + std::to_string(device_) + ")";
  if (Status s = cuda_status(allow_block_shared_bytes<double>(max_shared_bytes_), "cudaFuncSetAttribute"); !s) return s;
  if (Status s = cuda_status(allow_block_shared_bytes<float>(max_shared_bytes_), "cudaFuncSetAttribute"); !s) return s;
  if (Status s = cuda_status(allow_block_shared_bytes<double, float>(max_shared_bytes_), "cudaFuncSetAttribute"); !s)
    return s;
  int f32_per_f64 = 0;
  if (Status s = cuda_status(cudaDeviceGetAttribute(&f32_per_f64, cudaDevAttrSingleToDoublePrecisionPerfRatio, device_),
                             "cudaDeviceGetAttribute");
      !s)
    return s;
  fast_f64_ = f32_per_f64 >= 1 && f32_per_f64 <= kFastF64MaxRatio;
  // zero-filled: entries outside the tree's sparsity are never written, and must read as zero
  return d_scratch_.allocate_zeroed(slots_ * slot_bytes);
}

std::size_t chunk_min_states(int nv) {
  const auto entries = static_cast<std::size_t>(nv) * static_cast<std::size_t>(nv);
  return std::max(kMinChunkStates, (kChunkMatrixEntries + entries - 1) / entries);
}

std::size_t chunk_states(std::size_t n, std::size_t slots, const ChunkRule& rule, int nv) {
  const std::size_t rounds = (n + slots - 1) / slots;  // passes of the resident threads over the batch
  if (rounds >= 2) {
    // whole rounds per chunk: splitting a round would add one (talos_reduced, N = 65536: +7%)
    const std::size_t chunks = std::min(rule.max_chunks, rounds);
    return (rounds + chunks - 1) / chunks * slots;
  }
  // one round: the kernel is latency-bound and a chunk of it costs about as much as the whole
  // (iiwa14, N = 65536 in 4 chunks: end to end 4.9 -> 3.2 ms in f32)
  const std::size_t min_states = rule.min_states > 0 ? rule.min_states : chunk_min_states(nv);
  const std::size_t chunks = std::clamp<std::size_t>(n / min_states, 1, rule.max_chunks);
  return (n + chunks - 1) / chunks;
}

Status check_kernel_options(const KernelOptions& options) {
  // the largest automatic threads_per_state stands in for 0
  const BlockShape b = block_shape_for(options.block_shape, kMaxNv, 1);
  if (options.block_lean && !options.block_compact)
    return invalid_argument("block_lean without block_compact: the lean working set is the compact kernel's");
  if (b.threads_per_state < 1 || b.states_per_block < 1 || b.threads_per_state * b.states_per_block > 1024)
    return invalid_argument("block shape " + std::to_string(b.threads_per_state) + " threads per state x " +
                            std::to_string(b.states_per_block) + " states per block: a block holds 1 to 1024 threads");
  if (options.chunks.max_chunks < 1 || options.chunks.max_chunks > kMaxChunks)
    return invalid_argument("at most " + std::to_string(options.chunks.max_chunks) + " chunks: a batch goes in 1 to " +
                            std::to_string(kMaxChunks) + " chunks");
  return Status::ok();
}

Status CudaInstance::set_kernel_options(const KernelOptions& options) {
  if (Status s = check_kernel_options(options); !s) return s;
  kernel_ = options;
  describe();
  return Status::ok();
}

void CudaInstance::describe() {
  const bool warp = kernel_.warp_kernel && model_.nv <= kMaxWarpNv;
  kernel_description_ =
      block_description_ + (warp ? "; gradient batches computed in f64 on the warp kernel" + warp_build_ : "");
}

bool CudaInstance::f32_in_f64() const {
  return kernel_.f32_compute == F32Compute::kF64 || (kernel_.f32_compute == F32Compute::kAuto && fast_f64_);
}

template <class C, class S>
bool CudaInstance::use_block_kernel(const BatchPointers<S>& batch, std::size_t n) const {
  // large f32 batches of small models: more states resident at once in the one-thread kernel
  if (std::is_same_v<C, float> && model_.nv <= kThreadKernelMaxNv && kernel_.f32_thread_kernel_min_states > 0 &&
      n >= kernel_.f32_thread_kernel_min_states)
    return false;
  return n <= kernel_.block_max_states && block_kernel_supports(batch) &&
         block_shared_bytes<C>(model_.nv, batch.tau_input, block_shape<C, S>(n)) <= max_shared_bytes_;
}

template <> const ModelView<double>& CudaInstance::view<double>() const { return view_f64_; }
template <> const ModelView<float>& CudaInstance::view<float>() const { return view_f32_; }
template <class C, class S>
const SpecializedBlockKernel* CudaInstance::specialized() const {
  if (!kernel_.robot_specific) return nullptr;
  if constexpr (std::is_same_v<C, float>) return specialized_f32_.get();
  else if constexpr (std::is_same_v<S, float>) return specialized_f64_for_f32_.get();
  else return specialized_f64_.get();
}

template <class C, class S>
BlockShape CudaInstance::block_shape(std::size_t n) const {
  const SpecializedBlockKernel* k = specialized<C, S>();
  return block_shape_for(kernel_.block_shape, model_.nv, n, k && k->build().lean);
}

const WarpKernelTable* CudaInstance::warp_table() const {
  return kernel_.robot_specific && specialized_warp_ ? &specialized_warp_->table() : nullptr;
}

template <class C, class S>
bool CudaInstance::use_warp_kernel(const BatchPointers<S>& batch) const {
  if constexpr (std::is_same_v<C, double>) return kernel_.warp_kernel && warp_kernel_supports(batch, model_.nv);
  else return false;
}

template <class C, class S>
cudaError_t CudaInstance::launch_block(const BatchPointers<S>& batch, const BlockShape& shape, bool warp,
                                       std::size_t inline_block, cudaStream_t stream) const {
  if constexpr (std::is_same_v<C, double>)
    if (warp)
      return launch_warp_fused<S>(view<double>(), batch, kernel_.warp_early_outputs_min_bytes,
                                  inline_block != 0 ? &inline_inputs_ : nullptr, inline_block, stream, warp_table());
  const SpecializedBlockKernel* specific = specialized<C, S>();
  return specific ? specific->launch<C, S>(view<C>(), batch, shape, stream)
                  : launch_block_fused<C, S>(view<C>(), batch, shape, stream);
}

int CudaInstance::block_stages() const {
  if (!plan_) return block_stages::kPerBatch;
  return (plan_->wants(RBDGRAD_OUTPUT_DQDD_DQ) ? block_stages::kDq : 0) |
         (plan_->wants(RBDGRAD_OUTPUT_DQDD_DQD) ? block_stages::kDqd : 0) |
         (plan_->minv_supplied ? block_stages::kMinvSupplied : 0);
}

template <class C, class S>
cudaError_t CudaInstance::launch_block_graph(const BatchPointers<S>& batch, const BlockShape& shape, bool warp,
                                             std::size_t inline_block, cudaStream_t stream) {
  KernelLaunch launch;
  const SpecializedBlockKernel* specific = specialized<C, S>();
  if (std::is_same_v<C, double> && warp)
    launch = warp_fused_launch<S>(view<double>(), batch, kernel_.warp_early_outputs_min_bytes, inline_block,
                                  warp_table());
  else if (!specific || !specific->launch_config<C, S>(view<C>(), batch, shape, launch))
    launch = block_fused_launch<C, S>(view<C>(), batch, shape);
  ModelView<C> model_arg = view<C>();
  BatchPointers<S> batch_arg = batch;
  void* args[] = {&model_arg, &batch_arg, &inline_inputs_};
  if (graphs_.launch(launch, args, stream) == cudaSuccess) {
    last_graph_ = true;
    return cudaSuccess;
  }
  cudaGetLastError();  // the graph failed: the usual launch
  return launch_block<C, S>(batch, shape, warp, inline_block, stream);
}

Status CudaInstance::specialize(const std::string& cache_dir) {
  if (Status s = cuda_status(cudaSetDevice(device_), "cudaSetDevice(" + std::to_string(device_) + ")"); !s) return s;
  Status first = Status::ok();
  std::string parts;
  specialized_f64_for_f32_.reset();
  // f32 batches computed in f64 need a kernel of their own (f32 inputs and outputs)
  std::vector<KernelScalars> kinds = {KernelScalars::kF64, KernelScalars::kF32};
  if (f32_in_f64()) kinds.push_back(KernelScalars::kF64ForF32);
  for (const KernelScalars scalars : kinds) {
    std::unique_ptr<SpecializedBlockKernel>& k = scalars == KernelScalars::kF32   ? specialized_f32_
                                                 : scalars == KernelScalars::kF64 ? specialized_f64_
                                                                                  : specialized_f64_for_f32_;
    k.reset();
    BlockBuild wanted;
    wanted.compact = kernel_.block_compact;
    wanted.lean = kernel_.block_lean;
    wanted.tree_chains = kernel_.block_tree_chains;
    wanted.tree_columns = kernel_.block_tree_columns;
    const Status s = SpecializedBlockKernel::load(model_, scalars, block_stages(), wanted, kernel_.block_shape,
                                                  device_, max_shared_bytes_, cache_dir, k);
    if (!s && first) first = s;
    parts += std::string(parts.empty() ? "" : "; ") + kernel_scalars_name(scalars) + ": ";
    if (!s) {
      parts += "generic kernel, " + s.message().substr(0, s.message().find('\n'));
      continue;
    }
    parts += k->library().description();
    const BlockBuild& build = k->build();
    if (build.compact) parts += ", compact";
    if (build.lean) parts += ", lean working set";
    if (build.tree_chains) parts += ", M^-1 by the tree's chains where they fit";
    if (build.tree_columns) parts += ", its columns by the tree's blocks";
    if (build.register_cap > 0) parts += ", at most " + std::to_string(build.register_cap) + " registers a thread";
  }
  // the warp kernel for the robot, its f32 entry points where f32 batches compute in f64
  specialized_warp_.reset();
  warp_build_.clear();
  if (model_.nv <= kMaxWarpNv) {
    const Status s = SpecializedWarpKernel::load(model_, f32_in_f64(), device_, cache_dir, specialized_warp_);
    if (!s && first) first = s;
    warp_build_ = s ? " (compiled for this robot: " + specialized_warp_->library().description() + ")"
                    : " (generic, " + s.message().substr(0, s.message().find('\n')) + ")";
  }
  block_description_ = (specialized_f64_ || specialized_f32_ ? "kernel compiled for this robot (" : "generic kernel (") +
                       parts + ")" + (f32_in_f64() ? ", f32 batches computed in f64" : "") +
                       (plan_ ? ", " + block_stages_text(block_stages()) : "");
  describe();
  return first;
}

Status CudaInstance::compute(const rbdgrad_batch* batch) {
  if (Status s = plugin::validate_batch(batch, model_.nv, kPrecisions, plugin::kAllOutputs); !s) return s;
  if (plan_)
    if (Status s = plugin::check_batch_plan(*batch, *plan_); !s) return s;
  if (Status s = cuda_status(cudaSetDevice(device_), "cudaSetDevice(" + std::to_string(device_) + ")"); !s) return s;
  if (batch->precision == RBDGRAD_PRECISION_F64) return compute_typed<double>(*batch);
  return compute_typed<float>(*batch);
}

template <class S>
Status CudaInstance::compute_typed(const rbdgrad_batch& b) {
  const std::size_t n = b.n, nv = static_cast<std::size_t>(model_.nv);
  const std::size_t vec = n * nv * sizeof(S), mat = vec * nv;

  // where each array goes in the two blocks
  struct Input {
    const void* from;
    std::size_t bytes, at;
  };
  BlockLayout in_layout;
  Input inputs[] = {{b.q, vec, 0}, {b.qd, vec, 0}, {b.u, vec, 0}, {b.fext, 6 * vec, 0}, {b.minv, mat, 0}};
  for (Input& i : inputs)
    if (i.from) i.at = in_layout.add(i.bytes);
  BlockLayout out_layout;
  std::size_t out_at[kOutputCount] = {};
  for (int f = 0; f < kOutputCount; ++f)
    if (b.outputs & (1u << f)) out_at[f] = out_layout.add((plugin::kMatrixOutputs & (1u << f)) ? mat : vec);
  const std::size_t status_at = out_layout.add(n * sizeof(std::uint32_t));

  for (Allocation* a : {&h_in_, &d_in_})
    if (Status s = a->reserve(in_layout.size()); !s) return s;
  for (Allocation* a : {&h_out_, &d_out_})
    if (Status s = a->reserve(out_layout.size()); !s) return s;

  // Every array is state-major, so a chunk of states [a, a + m) is one contiguous range of each:
  // scalars per state of each input and each output.
  const std::size_t in_per_state[] = {nv, nv, nv, 6 * nv, nv * nv};
  std::size_t out_per_state[kOutputCount] = {};
  for (int f = 0; f < kOutputCount; ++f)
    out_per_state[f] = (plugin::kMatrixOutputs & (1u << f)) ? nv * nv : nv;
  auto* h_in = h_in_.as<unsigned char>();
  auto* h_out = h_out_.as<unsigned char>();
  // The caller's pinned arrays go straight to and from the device, or with mapped memory are the
  // kernel's own inputs and outputs; a check costs about a microsecond, so batches smaller than
  // pinned_check_min_bytes are staged unchecked.
  const std::size_t io_bytes = in_layout.size() + out_layout.size();
  unsigned char* in_device[5] = {};
  unsigned char* out_device[kOutputCount] = {};
  bool in_pinned[5] = {}, out_pinned[kOutputCount] = {};
  bool any_pinned = false, all_pinned = true;
  if (io_bytes >= kernel_.pinned_check_min_bytes) {
    for (int k = 0; k < 5; ++k) {
      if (!inputs[k].from) continue;
      in_device[k] = pinned_device_address(inputs[k].from);
      any_pinned |= in_pinned[k] = in_device[k] != nullptr;
      all_pinned &= in_pinned[k];
    }
    for (int f = 0; f < kOutputCount; ++f) {
      if (!(b.outputs & (1u << f))) continue;
      out_device[f] = pinned_device_address(caller_output(b, f));
      any_pinned |= out_pinned[f] = out_device[f] != nullptr;
      all_pinned &= out_pinned[f];
    }
  }
  // Small batches (mapped_io_max_kib), and larger ones whose arrays are all pinned
  // (mapped_pinned_max_kib): no device copies, one chunk; the kernel works on the pinned arrays in
  // place or on the staging blocks.
  const bool mapped = io_bytes <= (kernel_.mapped_io_max_kib << 10) ||
                      (any_pinned && all_pinned && io_bytes <= (kernel_.mapped_pinned_max_kib << 10));
  auto* d_in = static_cast<unsigned char*>(mapped ? h_in_.device_address() : d_in_.data());
  auto* d_out = static_cast<unsigned char*>(mapped ? h_out_.device_address() : d_out_.data());

  // The kernel, chosen for the whole batch so that every chunk runs the same one: the block kernel
  // for the gradient requests it takes, an f32 batch in f64 where the options say so (F32Compute).
  // Its arrays matter here only in being there or not.
  BatchPointers<S> whole;
  whole.n = n;
  whole.outputs = b.outputs;
  whole.tau_input = b.input_kind == RBDGRAD_INPUT_TAU;
  whole.qd = static_cast<const S*>(b.qd);
  whole.u = static_cast<const S*>(b.u);
  whole.minv = static_cast<const S*>(b.minv);
  const bool wide = std::is_same_v<S, float> && f32_in_f64() && use_block_kernel<double>(whole, n);
  const bool block = wide || use_block_kernel<S>(whole, n);
  // the warp kernel instead, where it is faster
  const bool warp = block && (wide ? use_warp_kernel<double>(whole) : use_warp_kernel<S>(whole));
  last_graph_ = false;
  // the one-thread kernels of a batch share the workspace's slots: whole passes over them per chunk
  const std::size_t chunk = mapped ? n : chunk_states(n, block ? n : slots_, kernel_.chunks, model_.nv);
  const std::size_t chunks = (n + chunk - 1) / chunk;
  const bool pipelined = chunks > 1;
  // a staged batch in one chunk goes over in one copy each way
  const bool one_copy = chunks == 1 && !mapped && !any_pinned;
  const auto chunk_begin = [&](std::size_t c) { return std::min(n, c * chunk); };
  // on an error, what is under way must finish before the buffers can be reused
  const auto fail = [&](Status s) {
    for (cudaStream_t stream : {streams_[0], streams_[1], upload_, download_}) cudaStreamSynchronize(stream);
    cudaGetLastError();
    return s;
  };

  // a small warp-kernel batch without copies: q, qd and u in the kernel's parameters
  const bool inline_inputs = warp && mapped && !pipelined && kernel_.warp_inline_inputs && !inputs[3].from &&
                             !inputs[4].from && inputs[0].from && inputs[1].from && inputs[2].from &&
                             3 * vec <= kWarpInlineInputBytes;
  const std::size_t inline_block = inline_inputs ? warp_inline_block_bytes(3 * vec, kernel_.warp_inline_min_block) : 0;
  // by the states of one launch: a pipelined batch's chunks of few states each leave the GPU as
  // idle as a small batch does
  const BlockShape shape = wide ? block_shape<double, S>(chunk) : block_shape<S, S>(chunk);
  for (std::size_t c = 0; c < chunks; ++c) {
    const std::size_t a = chunk_begin(c), m = chunk_begin(c + 1) - a;
    // one chunk: everything on one stream (fewest calls); several: see the class comment
    cudaStream_t stream = pipelined ? streams_[c % 2] : streams_[0];
    cudaStream_t in_stream = pipelined ? upload_ : stream, out_stream = pipelined ? download_ : stream;
    BatchPointers<S> p;
    p.n = m;
    p.outputs = b.outputs;
    p.tau_input = b.input_kind == RBDGRAD_INPUT_TAU;
    const S** device_inputs[] = {&p.q, &p.qd, &p.u, &p.fext, &p.minv};
    // the host's part, overlapping the device's work on the previous chunk
    HostCopy staging[5];
    std::size_t staged = 0;
    for (int k = 0; k < 3 && inline_inputs; ++k)
      staging[staged++] = {inline_inputs_.bytes + k * vec, static_cast<const unsigned char*>(inputs[k].from), vec};
    for (int k = 0; k < 5 && !inline_inputs; ++k) {
      if (!inputs[k].from || in_pinned[k]) continue;
      staging[staged++] = {h_in + inputs[k].at + a * in_per_state[k] * sizeof(S),
                           static_cast<const unsigned char*>(inputs[k].from) + a * in_per_state[k] * sizeof(S),
                           m * in_per_state[k] * sizeof(S)};
    }
    copy_in_parallel({staging, staged}, host_copy_threads());
    for (int k = 0; k < 5; ++k) {
      if (!inputs[k].from) continue;
      const std::size_t at = inputs[k].at + a * in_per_state[k] * sizeof(S), bytes = m * in_per_state[k] * sizeof(S);
      const unsigned char* from = static_cast<const unsigned char*>(inputs[k].from) + a * in_per_state[k] * sizeof(S);
      if (!in_pinned[k]) from = h_in + at;
      if (!mapped && !one_copy) {
        if (Status s = cuda_status(cudaMemcpyAsync(d_in + at, from, bytes, cudaMemcpyHostToDevice, in_stream),
                                   "copying the batch to the device");
            !s)
          return fail(s);
      }
      *device_inputs[k] = reinterpret_cast<const S*>(mapped && in_pinned[k] ? in_device[k] + a * in_per_state[k] * sizeof(S)
                                                                            : d_in + at);
    }
    if (one_copy) {
      if (Status s = cuda_status(cudaMemcpyAsync(d_in, h_in, in_layout.size(), cudaMemcpyHostToDevice, stream),
                                 "copying the batch to the device");
          !s)
        return fail(s);
    }
    for (int f = 0; f < kOutputCount; ++f)
      if (b.outputs & (1u << f))
        p.out[f] = reinterpret_cast<S*>(mapped && out_pinned[f] ? out_device[f] + a * out_per_state[f] * sizeof(S)
                                                                : d_out + out_at[f] + a * out_per_state[f] * sizeof(S));
    p.status = reinterpret_cast<std::uint32_t*>(d_out + status_at) + a;

    // the kernel once its inputs are there; the first kernel starts the clock; the one-thread
    // kernels run one after the other (they share the workspace), the block kernel's may overlap
    // (shared memory only)
    cudaError_t e = cudaSuccess;
    if (pipelined) {
      e = cudaEventRecord(uploaded_[c], upload_);
      if (e == cudaSuccess) e = cudaStreamWaitEvent(stream, uploaded_[c], 0);
    }
    if (e == cudaSuccess && c == 0 && kernel_.time_kernel) e = cudaEventRecord(kernel_start_, stream);
    else if (e == cudaSuccess && c > 0 && !block) e = cudaStreamWaitEvent(stream, kernel_end_[c - 1], 0);
    if (Status s = cuda_status(e, "ordering the kernels"); !s) return fail(s);
    // one launch and no copies: as a CUDA Graph, which costs the host less (kernel_graphs.hpp)
    const bool graph = block && kernel_.graphs && mapped && !pipelined && !kernel_.time_kernel;
    const cudaError_t launched = !block  ? launch_fused<S>(view<S>(), d_scratch_.as<S>(), slots_, p, stream)
                                 : graph ? (wide ? launch_block_graph<double>(p, shape, warp, inline_block, stream)
                                                 : launch_block_graph<S>(p, shape, warp, inline_block, stream))
                                 : wide  ? launch_block<double>(p, shape, warp, inline_block, stream)
                                         : launch_block<S>(p, shape, warp, inline_block, stream);
    if (Status s = cuda_status(launched, "launching the fused kernel"); !s) return fail(s);
    // each runtime call costs about a microsecond of a small batch's time: only the events used
    if (pipelined || kernel_.time_kernel)
      if (Status s = cuda_status(cudaEventRecord(kernel_end_[c], stream), "cudaEventRecord"); !s) return fail(s);
    // the download waits for this chunk's kernel only, never the other way round
    if (pipelined)
      if (Status s = cuda_status(cudaStreamWaitEvent(download_, kernel_end_[c], 0), "ordering the copies"); !s)
        return fail(s);

    if (one_copy) {
      if (Status s = cuda_status(cudaMemcpyAsync(h_out, d_out, out_layout.size(), cudaMemcpyDeviceToHost, stream),
                                 "copying the results from the device");
          !s)
        return fail(s);
    }
    for (int f = 0; f <= kOutputCount && !one_copy && !mapped; ++f) {
      const bool is_status = f == kOutputCount;
      if (!is_status && !(b.outputs & (1u << f))) continue;
      const std::size_t at = is_status ? status_at + a * sizeof(std::uint32_t) : out_at[f] + a * out_per_state[f] * sizeof(S);
      const std::size_t bytes = is_status ? m * sizeof(std::uint32_t) : m * out_per_state[f] * sizeof(S);
      // straight into the caller's array when it is pinned, else into the staging block
      unsigned char* to = !is_status && out_pinned[f]
                              ? static_cast<unsigned char*>(caller_output(b, f)) + a * out_per_state[f] * sizeof(S)
                              : h_out + at;
      if (Status s = cuda_status(cudaMemcpyAsync(to, d_out + at, bytes, cudaMemcpyDeviceToHost, out_stream),
                                 "copying the results from the device");
          !s)
        return fail(s);
    }
    if (pipelined)
      if (Status s = cuda_status(cudaEventRecord(copied_[c], download_), "cudaEventRecord"); !s) return fail(s);
  }

  // outputs out of the pinned block, chunk by chunk as they arrive
  for (std::size_t c = 0; c < chunks; ++c) {
    const cudaError_t done = pipelined ? cudaEventSynchronize(copied_[c]) : cudaStreamSynchronize(streams_[0]);
    if (Status s = cuda_status(done, "running the fused kernel"); !s) return fail(s);
    const std::size_t a = chunk_begin(c), m = chunk_begin(c + 1) - a;
    HostCopy unstaging[kOutputCount];
    std::size_t unstaged = 0;
    for (int f = 0; f < kOutputCount; ++f) {
      if (!(b.outputs & (1u << f)) || out_pinned[f]) continue;
      const std::size_t at = a * out_per_state[f] * sizeof(S), bytes = m * out_per_state[f] * sizeof(S);
      unstaging[unstaged++] = {static_cast<unsigned char*>(caller_output(b, f)) + at, h_out + out_at[f] + at, bytes};
    }
    copy_in_parallel({unstaging, unstaged}, host_copy_threads());
  }
  // from the first kernel's start to the last kernel's end (the two compute streams may finish
  // out of order)
  last_kernel_ms_ = 0;
  for (std::size_t c = 0; c < chunks && kernel_.time_kernel; ++c) {
    float ms = 0;
    if (Status s = cuda_status(cudaEventElapsedTime(&ms, kernel_start_, kernel_end_[c]), "cudaEventElapsedTime"); !s)
      return s;
    last_kernel_ms_ = std::max(last_kernel_ms_, ms);
  }
  last_block_ = block;
  last_warp_ = warp;
  last_inline_ = inline_block;
  const WarpKernelTable* robot_warp = warp_table();
  const bool robot_warp_ran =
      robot_warp != nullptr && (std::is_same_v<S, float> ? robot_warp->f32[0] : robot_warp->f64[0]) != nullptr;
  const bool robot_block_ran = (wide ? specialized<double, S>() : specialized<S, S>()) != nullptr;
  last_specific_ = block && (warp ? robot_warp_ran : robot_block_ran);
  last_f32_in_f64_ = wide;
  last_chunks_ = chunks;
  last_mapped_ = mapped;
  last_pinned_ = 0;
  for (bool pinned : in_pinned) last_pinned_ += pinned;
  for (bool pinned : out_pinned) last_pinned_ += pinned;
  const auto* status = reinterpret_cast<const std::uint32_t*>(h_out + status_at);
  std::size_t failures = 0, first = 0;
  for (std::size_t k = 0; k < n; ++k) {
    if (status[k] == 0) {
      if (b.state_status) b.state_status[k] = 0;
      continue;
    }
    if (failures++ == 0) first = k;
    if (b.state_status)
      b.state_status[k] = static_cast<std::int32_t>(plugin::error_code_from_status(state_failure(status[k], model_).code()));
  }
  if (failures == 0) return Status::ok();
  const Status s = state_failure(status[first], model_);
  std::string message = "state " + std::to_string(first) + ": " + s.message();
  if (failures > 1) message += " (and " + std::to_string(failures - 1) + " more failed states, see state_status)";
  return Status(s.code(), std::move(message));
}

}  // namespace rbdgrad::cuda
