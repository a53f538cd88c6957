// Would a persistent kernel cut the CUDA plugin's small-batch overhead below a CUDA Graph's (issue 4:
// end to end at most 0.5x GRiD at small N)? A launch, even of a replayed graph, costs the host's
// runtime call, the GPU's block start and the completion's path back to the host. A kernel that
// stays resident and waits for batches on a doorbell in mapped host memory pays none of them: the
// host writes the batch's description and a sequence number, one GPU thread sees it over PCIe and
// wakes the rest, and the last block to finish writes the number back.
//
// The probe times, around a synchronous call, with a kernel that does almost nothing (one add per
// item of mapped host memory, as in cuda_graph_probe.cu):
//   stream:      a launch on a stream, then cudaStreamSynchronize;
//   graph:       the same kernel as a replayed one-node graph;
//   persistent:  the batch handed to the resident kernel (cooperative launch: every block
//                resident), then a spin on the answer;
//   stream while resident: a stream launch while the persistent kernel holds its blocks (do
//                other batches still run beside it?).
// Two ways to hand the batch over and back: volatile reads and writes with fences
// (__threadfence_system), and acquire loads and release stores at system scope (PTX), for grids of
// 16 blocks to two per SM. Medians of 2000 calls after 200 warm-up calls, µs. Exits 0 with a
// message when there is no GPU.
//
// Found on the H200 (docs/benchmarks/cuda.md, eighth session): with acquire and release the round
// trip is 6.5-7 us against 7.8-8.5 for the graph, 1-1.4 us less, and 5.3-6 us with nothing to do;
// with fences it is 8.5-11 us, no better than the graph. Not enough to take on a kernel that holds
// its SMs between batches.
#include <cuda_runtime.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdio>

#include "cuda_probe_support.hpp"

namespace {

using rbdgrad::probe::median_us;
using rbdgrad::probe::ok;

__global__ void touch(float* x, int n) {
  for (int i = blockIdx.x * blockDim.x + threadIdx.x; i < n; i += gridDim.x * blockDim.x) x[i] += 1.0f;
}

// the doorbell: written by the host, read by the GPU (mapped host memory)
struct Mailbox {
  unsigned seq;    // the batch's number, written last
  unsigned stop;   // nonzero: the kernel returns
  int items;       // the batch: items of data
  float* data;     // device address of mapped host memory
};

__device__ unsigned load_volatile(const unsigned* p) { return *static_cast<const volatile unsigned*>(p); }
__device__ unsigned load_acquire_system(const unsigned* p) {
  unsigned v;
  asm volatile("ld.acquire.sys.global.u32 %0, [%1];" : "=r"(v) : "l"(p) : "memory");
  return v;
}
__device__ void store_release_system(unsigned* p, unsigned v) {
  asm volatile("st.release.sys.global.u32 [%0], %1;" ::"l"(p), "r"(v) : "memory");
}
__device__ unsigned load_acquire_gpu(const unsigned* p) {
  unsigned v;
  asm volatile("ld.acquire.gpu.global.u32 %0, [%1];" : "=r"(v) : "l"(p) : "memory");
  return v;
}
__device__ void store_release_gpu(unsigned* p, unsigned v) {
  asm volatile("st.release.gpu.global.u32 [%0], %1;" ::"l"(p), "r"(v) : "memory");
}

// What block 0 relays to the others in device memory: one reader of host memory per batch (reads
// of one host address by many threads are served one after the other, about 1 us each: the
// probe's first version, whose every thread read the mailbox, took 16 us per block).
struct Relay {
  unsigned seq;
  int items;
  float* data;
};

// One item per thread of the grid per round. Block 0's thread 0 polls the host's mailbox and relays
// the batch to the other blocks through device memory.
// kAcquireRelease: the handover by acquire loads and release stores, else by volatile accesses
// and fences (each block's device-scope fence before it counts itself done; the last block's
// system-scope fence covers the others' writes). sleep_ns: block 0's pause between reads of the
// mailbox.
template <bool kAcquireRelease>
__global__ void resident(Mailbox* box, unsigned* done, Relay* relay, unsigned long long* finished,
                         unsigned sleep_ns) {
  __shared__ Relay batch;
  unsigned last = 0;
  for (;;) {
    if (threadIdx.x == 0) {
      unsigned s;
      if (blockIdx.x == 0 && kAcquireRelease) {
        // the stop flag rides in the sequence number's place: ~0
        while ((s = load_acquire_system(&box->seq)) == last) {
          if (sleep_ns) __nanosleep(sleep_ns);
        }
        batch.items = box->items;
        batch.data = box->data;
        relay->items = batch.items;
        relay->data = batch.data;
        store_release_gpu(&relay->seq, s);
      } else if (blockIdx.x == 0) {
        while ((s = load_volatile(&box->seq)) == last && load_volatile(&box->stop) == 0) {
          if (sleep_ns) __nanosleep(sleep_ns);
        }
        if (load_volatile(&box->stop) != 0) s = ~0u;
        __threadfence_system();
        batch.items = *static_cast<volatile int*>(&box->items);
        batch.data = *static_cast<float* volatile*>(&box->data);
        volatile Relay* r = relay;
        r->items = batch.items;
        r->data = batch.data;
        __threadfence();
        r->seq = s;
      } else if (kAcquireRelease) {
        while ((s = load_acquire_gpu(&relay->seq)) == last) __nanosleep(20);
        batch.items = relay->items;
        batch.data = relay->data;
      } else {
        while ((s = load_volatile(&relay->seq)) == last) __nanosleep(20);
        __threadfence();
        const volatile Relay* r = relay;
        batch.items = r->items;
        batch.data = r->data;
      }
      batch.seq = s;
    }
    __syncthreads();
    const unsigned s = batch.seq;
    if (s == ~0u) return;
    last = s;
    const int items = batch.items;
    float* data = batch.data;
    for (int i = blockIdx.x * blockDim.x + threadIdx.x; i < items; i += gridDim.x * blockDim.x) data[i] += 1.0f;
    __syncthreads();
    if (threadIdx.x == 0 && kAcquireRelease) {
      // acq_rel at device scope orders this block's writes before the count; the last block's
      // system-scope release covers what it has observed (cumulativity)
      unsigned long long old;
      asm volatile("atom.acq_rel.gpu.global.add.u64 %0, [%1], 1;" : "=l"(old) : "l"(finished) : "memory");
      if ((old + 1) % gridDim.x == 0) store_release_system(done, s);
    } else if (threadIdx.x == 0) {
      __threadfence();
      const unsigned long long old = atomicAdd(finished, 1ull);
      if ((old + 1) % gridDim.x == 0) {
        __threadfence_system();
        *static_cast<volatile unsigned*>(done) = s;
      }
    }
  }
}

}  // namespace

int main() {
  int devices = 0;
  if (cudaGetDeviceCount(&devices) != cudaSuccess || devices == 0) {
    std::printf("cuda_persistent_probe: no GPU, nothing measured\n");
    return 0;
  }
  cudaDeviceProp prop{};
  cudaGetDeviceProperties(&prop, 0);
  std::printf("device: %s, %d SMs\n", prop.name, prop.multiProcessorCount);
  constexpr int kItems = 16 * 256;  // 16 states of 256 threads
  float *host = nullptr, *mapped = nullptr;
  Mailbox* box = nullptr;
  Mailbox* box_dev = nullptr;
  unsigned *done = nullptr, *done_dev = nullptr;
  Relay* relay = nullptr;
  unsigned long long* finished = nullptr;
  const std::size_t capacity = static_cast<std::size_t>(2 * prop.multiProcessorCount * 256);  // the largest grid's items
  if (!ok(cudaHostAlloc(&host, capacity * sizeof(float), cudaHostAllocMapped), "cudaHostAlloc") ||
      !ok(cudaHostGetDevicePointer(&mapped, host, 0), "cudaHostGetDevicePointer") ||
      !ok(cudaHostAlloc(&box, 4096, cudaHostAllocMapped), "cudaHostAlloc box") ||
      !ok(cudaHostGetDevicePointer(&box_dev, box, 0), "box pointer") ||
      !ok(cudaHostAlloc(&done, 4096, cudaHostAllocMapped), "cudaHostAlloc done") ||
      !ok(cudaHostGetDevicePointer(&done_dev, done, 0), "done pointer") ||
      !ok(cudaMalloc(&relay, sizeof(Relay)), "cudaMalloc relay") ||
      !ok(cudaMalloc(&finished, sizeof(unsigned long long)), "cudaMalloc finished") ||
      !ok(cudaMemset(relay, 0, sizeof(Relay)), "memset") || !ok(cudaMemset(finished, 0, 8), "memset"))
    return 1;
  *box = Mailbox{0, 0, kItems, mapped};
  *done = 0;
  cudaStream_t stream, side;
  if (!ok(cudaStreamCreateWithFlags(&stream, cudaStreamNonBlocking), "cudaStreamCreate") ||
      !ok(cudaStreamCreateWithFlags(&side, cudaStreamNonBlocking), "cudaStreamCreate"))
    return 1;

  const double direct = median_us([&] {
    touch<<<16, 256, 0, stream>>>(mapped, kItems);
    cudaStreamSynchronize(stream);
  });
  cudaGraph_t graph = nullptr;
  cudaGraphExec_t exec = nullptr;
  cudaStreamBeginCapture(stream, cudaStreamCaptureModeThreadLocal);
  touch<<<16, 256, 0, stream>>>(mapped, kItems);
  cudaStreamEndCapture(stream, &graph);
  if (!ok(cudaGraphInstantiate(&exec, graph, 0), "instantiate")) return 1;
  const double replay = median_us([&] {
    cudaGraphLaunch(exec, stream);
    cudaStreamSynchronize(stream);
  });
  std::printf("%-44s %8.2f us\n", "stream launch, wait", direct);
  std::printf("%-44s %8.2f us\n", "graph replayed, wait", replay);

  int per_sm = 0;
  cudaOccupancyMaxActiveBlocksPerMultiprocessor(&per_sm, resident<false>, 256, 0);
  struct Variant {
    bool acquire_release;
    unsigned sleep_ns;
    int grid;
  };
  const int sms = prop.multiProcessorCount;
  const Variant variants[] = {{false, 0, 16},  {true, 0, 16},        {true, 0, sms},
                              {true, 100, sms}, {true, 0, 2 * sms}, {false, 0, sms}};
  for (const Variant& v : variants) {
    const int grid = v.grid;
    const int blocks_per_sm = (grid + sms - 1) / sms;
    if (blocks_per_sm > per_sm) continue;
    unsigned seq = 0;
    box->stop = 0;
    box->seq = 0;
    *done = 0;
    cudaMemset(relay, 0, sizeof(Relay));
    cudaMemset(finished, 0, 8);
    cudaDeviceSynchronize();
    unsigned sleep_ns = v.sleep_ns;
    void* args[] = {&box_dev, &done_dev, &relay, &finished, &sleep_ns};
    const auto t0 = std::chrono::steady_clock::now();
    const void* kernel = v.acquire_release ? reinterpret_cast<const void*>(resident<true>)
                                           : reinterpret_cast<const void*>(resident<false>);
    if (!ok(cudaLaunchCooperativeKernel(kernel, dim3(grid), dim3(256), args, 0, stream),
            "cooperative launch"))
      return 1;
    const auto call = [&](int items) {
      box->items = items;
      box->data = mapped;
      std::atomic_thread_fence(std::memory_order_seq_cst);
      *static_cast<volatile unsigned*>(&box->seq) = ++seq;
      while (*static_cast<volatile unsigned*>(done) != seq) {
      }
    };
    call(kItems);
    const double first = std::chrono::duration<double, std::micro>(std::chrono::steady_clock::now() - t0).count();
    const double persistent = median_us([&] { call(kItems); });
    const double persistent_big = median_us([&] { call(std::max(grid, 16) * 256); });  // <= capacity
    const double persistent_empty = median_us([&] { call(0); });
    // another kernel beside the resident one
    const double beside = median_us([&] {
      touch<<<16, 256, 0, side>>>(mapped, kItems);
      cudaStreamSynchronize(side);
    });
    const double after_beside = median_us([&] { call(kItems); });
    box->stop = 1;
    std::atomic_thread_fence(std::memory_order_seq_cst);
    if (v.acquire_release) *static_cast<volatile unsigned*>(&box->seq) = ~0u;
    const auto s0 = std::chrono::steady_clock::now();
    if (!ok(cudaStreamSynchronize(stream), "persistent kernel's end")) return 1;
    const double stop_us = std::chrono::duration<double, std::micro>(std::chrono::steady_clock::now() - s0).count();
    std::printf("grid %d blocks (%d possible per SM), %s, mailbox read every %u ns\n", grid, per_sm,
                v.acquire_release ? "acquire and release" : "fences", v.sleep_ns);
    std::printf("  %-42s %8.2f us\n", "launch and first batch", first);
    std::printf("  %-42s %8.2f us  (%.2fx the graph)\n", "persistent, 16 x 256 items", persistent, persistent / replay);
    std::printf("  %-42s %8.2f us\n", "persistent, one item per thread of the grid", persistent_big);
    std::printf("  %-42s %8.2f us\n", "persistent, no items", persistent_empty);
    std::printf("  %-42s %8.2f us\n", "stream launch beside the resident kernel", beside);
    std::printf("  %-42s %8.2f us\n", "persistent after that", after_beside);
    std::printf("  %-42s %8.2f us\n", "stop", stop_us);
  }
  // every call added one to each of the first kItems values: they must all be equal
  const float first_value = host[0];
  int unequal = 0;
  for (int i = 0; i < kItems; ++i) unequal += host[i] != first_value;
  std::printf("items written unequally: %d of %d (value %.0f)\n", unequal, kItems, first_value);
  if (!ok(cudaGetLastError(), "after the runs")) return 1;
  return unequal == 0 ? 0 : 1;
}
