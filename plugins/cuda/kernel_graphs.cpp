#include "kernel_graphs.hpp"

namespace rbdgrad::cuda {

namespace {

cudaKernelNodeParams node_params(const KernelLaunch& launch, void** args) {
  cudaKernelNodeParams p{};
  p.func = const_cast<void*>(launch.function);
  p.gridDim = launch.grid;
  p.blockDim = launch.block;
  p.sharedMemBytes = static_cast<unsigned>(launch.shared_bytes);
  p.kernelParams = args;
  return p;
}

}  // namespace

KernelGraphs::~KernelGraphs() {
  for (Graph& g : graphs_) {
    if (g.exec) cudaGraphExecDestroy(g.exec);
    if (g.graph) cudaGraphDestroy(g.graph);
  }
}

cudaError_t KernelGraphs::launch(const KernelLaunch& launch, void** args, cudaStream_t stream) {
  const cudaKernelNodeParams params = node_params(launch, args);
  for (Graph& g : graphs_) {
    if (g.function != launch.function) continue;
    const cudaError_t e = cudaGraphExecKernelNodeSetParams(g.exec, g.node, &params);
    return e == cudaSuccess ? cudaGraphLaunch(g.exec, stream) : e;
  }
  Graph g;
  g.function = launch.function;
  cudaError_t e = cudaGraphCreate(&g.graph, 0);
  if (e == cudaSuccess) e = cudaGraphAddKernelNode(&g.node, g.graph, nullptr, 0, &params);
  if (e == cudaSuccess) e = cudaGraphInstantiate(&g.exec, g.graph, 0);
  if (e != cudaSuccess) {
    if (g.exec) cudaGraphExecDestroy(g.exec);
    if (g.graph) cudaGraphDestroy(g.graph);
    return e;
  }
  graphs_.push_back(g);
  return cudaGraphLaunch(g.exec, stream);
}

}  // namespace rbdgrad::cuda
