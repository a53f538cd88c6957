// A batch of one kernel launched as a CUDA Graph (issue 4: "CUDA Graphs for the small-N path where
// they cut launch overhead"). On an H200 (GPU run 31, docs/benchmarks/cuda.md) a one-kernel graph
// whose kernel node gets each call's arguments (cudaGraphExecKernelNodeSetParams), then a launch
// and a wait, takes 9.5 us of host time against 12 us for a stream launch and a wait; capturing the
// call again and updating the graph takes 11 us, and the copy pipeline's many calls gained nothing.
// So only batches of one kernel launch (mapped memory, no copies) go through a graph: one graph per
// kernel, built at its first use and reused with new arguments, grid and shared memory.
#pragma once

#include <cuda_runtime_api.h>

#include <vector>

#include "block_launch.hpp"

namespace rbdgrad::cuda {

class KernelGraphs {
 public:
  KernelGraphs() = default;
  ~KernelGraphs();
  KernelGraphs(const KernelGraphs&) = delete;
  KernelGraphs& operator=(const KernelGraphs&) = delete;

  /// Enqueues `launch` with `args` on `stream` as the kernel's graph (built on first use: the
  /// device current). An error leaves no half-built graph behind; the caller may launch the usual
  /// way instead.
  cudaError_t launch(const KernelLaunch& launch, void** args, cudaStream_t stream);

 private:
  struct Graph {
    const void* function = nullptr;
    cudaGraph_t graph = nullptr;
    cudaGraphExec_t exec = nullptr;
    cudaGraphNode_t node = nullptr;
  };
  std::vector<Graph> graphs_;  // a handful: one per kernel an instance runs
};

}  // namespace rbdgrad::cuda
