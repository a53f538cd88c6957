// Does a CUDA Graph cut the host's launch overhead of the CUDA plugin's batch patterns (issue 4: "CUDA
// Graphs for the small-N path where they cut launch overhead")? The probe times, around a
// synchronous call as the plugin's compute() is, each pattern issued call by call on a stream and
// the same pattern captured once into a graph and replayed with cudaGraphLaunch:
//   mapped:  one kernel on mapped host memory, then a wait (the plugin's small batches);
//   copies:  upload, kernel, download, then a wait (a batch of one chunk through device buffers);
//   chunks:  4 chunks of upload, kernel, download on one stream, then a wait (a pipelined batch's
//            call count; the plugin spreads them over four streams with events).
// The kernel does almost nothing (each thread adds one to one value), so what is measured is the
// calls' own cost. Medians of 2000 calls after 200 warm-up calls, µs. Exits 0 with a message when
// there is no GPU.
#include <cuda_runtime.h>

#include <cstdio>
#include <functional>

#include "cuda_probe_support.hpp"

namespace {

using rbdgrad::probe::median_us;
using rbdgrad::probe::ok;

__global__ void touch(float* x, int n) {
  const int i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i < n) x[i] += 1.0f;
}

}  // namespace

int main() {
  int devices = 0;
  if (cudaGetDeviceCount(&devices) != cudaSuccess || devices == 0) {
    std::printf("cuda_graph_probe: no GPU, nothing measured\n");
    return 0;
  }
  cudaDeviceProp prop{};
  cudaGetDeviceProperties(&prop, 0);
  std::printf("device: %s\n", prop.name);
  constexpr int kN = 1024;  // floats per array: 4 KiB, like a small batch's inputs
  float *host = nullptr, *mapped = nullptr, *device = nullptr;
  if (!ok(cudaHostAlloc(&host, kN * sizeof(float), cudaHostAllocMapped), "cudaHostAlloc") ||
      !ok(cudaHostGetDevicePointer(&mapped, host, 0), "cudaHostGetDevicePointer") ||
      !ok(cudaMalloc(&device, 4 * kN * sizeof(float)), "cudaMalloc"))
    return 1;
  cudaStream_t stream;
  if (!ok(cudaStreamCreateWithFlags(&stream, cudaStreamNonBlocking), "cudaStreamCreate")) return 1;

  // the patterns, as calls on `stream`
  const auto mapped_pattern = [&] { touch<<<4, 256, 0, stream>>>(mapped, kN); };
  const auto copy_pattern = [&] {
    cudaMemcpyAsync(device, host, kN * sizeof(float), cudaMemcpyHostToDevice, stream);
    touch<<<4, 256, 0, stream>>>(device, kN);
    cudaMemcpyAsync(host, device, kN * sizeof(float), cudaMemcpyDeviceToHost, stream);
  };
  const auto chunk_pattern = [&] {
    for (int c = 0; c < 4; ++c) {
      float* d = device + c * kN;
      cudaMemcpyAsync(d, host, kN * sizeof(float), cudaMemcpyHostToDevice, stream);
      touch<<<4, 256, 0, stream>>>(d, kN);
      cudaMemcpyAsync(host, d, kN * sizeof(float), cudaMemcpyDeviceToHost, stream);
    }
  };
  struct Pattern {
    const char* name;
    std::function<void()> issue;
  };
  const Pattern patterns[] = {{"mapped: kernel, wait", mapped_pattern},
                              {"copies: upload, kernel, download, wait", copy_pattern},
                              {"chunks: 4 x (upload, kernel, download), wait", chunk_pattern}};
  std::printf("%-46s %10s %10s %12s %8s\n", "pattern", "stream us", "graph us", "graph, upd us", "ratio");
  for (const Pattern& p : patterns) {
    const double direct = median_us([&] {
      p.issue();
      cudaStreamSynchronize(stream);
    });
    cudaGraph_t graph = nullptr;
    cudaGraphExec_t exec = nullptr;
    if (!ok(cudaStreamBeginCapture(stream, cudaStreamCaptureModeThreadLocal), "begin capture")) return 1;
    p.issue();
    if (!ok(cudaStreamEndCapture(stream, &graph), "end capture") ||
        !ok(cudaGraphInstantiate(&exec, graph, 0), "instantiate"))
      return 1;
    const double replay = median_us([&] {
      cudaGraphLaunch(exec, stream);
      cudaStreamSynchronize(stream);
    });
    // the plugin's arrays change per call (the caller's pointers): the graph must be updated to
    // them first; capture again and update the executable graph in place
    const double updated = median_us([&] {
      cudaGraph_t fresh = nullptr;
      cudaStreamBeginCapture(stream, cudaStreamCaptureModeThreadLocal);
      p.issue();
      cudaStreamEndCapture(stream, &fresh);
      cudaGraphExecUpdateResultInfo info{};
      cudaGraphExecUpdate(exec, fresh, &info);
      cudaGraphDestroy(fresh);
      cudaGraphLaunch(exec, stream);
      cudaStreamSynchronize(stream);
    });
    std::printf("%-46s %10.2f %10.2f %12.2f %8.2f\n", p.name, direct, replay, updated, replay / direct);
    cudaGraphExecDestroy(exec);
    cudaGraphDestroy(graph);
  }
  // The mapped pattern with the kernel node's parameters set before each launch
  // (cudaGraphExecKernelNodeSetParams: new arrays and grid without capturing again), as the plugin
  // would do for a batch of one kernel whose caller arrays change per call.
  {
    cudaGraph_t graph = nullptr;
    cudaGraphExec_t exec = nullptr;
    cudaStreamBeginCapture(stream, cudaStreamCaptureModeThreadLocal);
    mapped_pattern();
    cudaStreamEndCapture(stream, &graph);
    cudaGraphInstantiate(&exec, graph, 0);
    cudaGraphNode_t node = nullptr;
    std::size_t count = 1;
    if (!ok(cudaGraphGetNodes(graph, &node, &count), "cudaGraphGetNodes")) return 1;
    int n = kN;
    float* x = mapped;
    void* args[] = {&x, &n};
    cudaKernelNodeParams params{};
    params.func = reinterpret_cast<void*>(touch);
    params.gridDim = dim3(4);
    params.blockDim = dim3(256);
    params.kernelParams = args;
    const double set = median_us([&] {
      n = kN - 1;  // a changed argument each call, as a new batch would bring
      cudaGraphExecKernelNodeSetParams(exec, node, &params);
      cudaGraphLaunch(exec, stream);
      cudaStreamSynchronize(stream);
    });
    std::printf("%-46s %10s %10s %12.2f\n", "mapped, kernel node's parameters set per call", "", "", set);
    cudaGraphExecDestroy(exec);
    cudaGraphDestroy(graph);
  }
  if (!ok(cudaGetLastError(), "after the runs")) return 1;
  cudaStreamDestroy(stream);
  cudaFree(device);
  cudaFreeHost(host);
  return 0;
}
