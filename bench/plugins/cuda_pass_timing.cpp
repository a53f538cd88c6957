// Where the block kernel's time goes for one state: the SM clock at the kernel's entry, after its
// prologue (inputs and constants into shared memory) and after every pass (sync) of state 0's
// thread group, in a build with RBDGRAD_CUDA_PASS_TIMING=ON (the passes are then timed, the
// kernel is otherwise the same; the kernels compiled into the plugin for any robot, not those
// NVRTC compiles for it). The warp kernel the same way, at the end of each of its stages
// (WarpLanes::stamp). Prints, per kernel, robot and precision, the cycles of each pass and their
// sum, the median over repeated launches of a small batch. Needs a GPU.
#include <cuda_runtime_api.h>

#include <algorithm>
#include <cstdio>
#include <random>
#include <string>
#include <vector>

#include "block_launch.hpp"
#include "cuda_instance.hpp"
#include "warp_launch.hpp"
#include "rbdgrad/embedded_robots.hpp"
#include "rbdgrad/urdf.hpp"

namespace {

using rbdgrad::Model;

constexpr int kClocks = rbdgrad::cuda::ThreadGroup::kMaxPassClocks;
constexpr int kWarpClocks = rbdgrad::cuda::WarpLanes<8>::kMaxStageClocks + 1;
constexpr int kRepeats = 51;

template <class S>
int run(const std::string& robot, std::uint32_t precision, std::size_t n, double clock_ghz, bool mapped_io,
        bool warp) {
  Model model;
  if (!rbdgrad::load_urdf_string(std::string(rbdgrad::embedded_robot_urdf(robot)), robot, model)) return 1;
  std::unique_ptr<rbdgrad::cuda::CudaInstance> instance;
  if (auto s = rbdgrad::cuda::CudaInstance::create(model, 0, instance); !s) {
    std::printf("%s\n", s.to_string().c_str());
    return 1;
  }
  // copies instead of host memory read and written by the kernel (mapped I/O, the default here)
  rbdgrad::cuda::KernelOptions options;
  options.time_kernel = true;
  options.warp_kernel = warp;
  // the kernels compiled into the plugin, which this build times: those NVRTC compiles for the
  // robot at load have no clocks
  options.robot_specific = false;
  if (!mapped_io) options.mapped_io_max_kib = 0;
  if (!instance->set_kernel_options(options)) return 1;
  const std::size_t v = n * static_cast<std::size_t>(model.nv);
  std::vector<S> q(v), qd(v), tau(v), dq(v * model.nv), dqd(v * model.nv);
  std::vector<std::int32_t> status(n);
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-1, 1);
  for (auto* x : {&q, &qd, &tau})
    for (S& e : *x) e = static_cast<S>(u(rng));
  rbdgrad_batch b{};
  b.struct_size = sizeof(b);
  b.n = n;
  b.precision = precision;
  b.input_kind = RBDGRAD_INPUT_TAU;
  b.outputs = RBDGRAD_OUTPUT_DQDD_DQ | RBDGRAD_OUTPUT_DQDD_DQD;
  b.q = q.data();
  b.qd = qd.data();
  b.u = tau.data();
  b.dqdd_dq = dq.data();
  b.dqdd_dqd = dqd.data();
  b.state_status = status.data();

  std::vector<std::vector<long long>> deltas;  // per repeat, per pass
  int passes = 0;
  for (int r = 0; r < kRepeats; ++r) {
    std::vector<long long> clocks(kClocks, 0);
    if (auto s = instance->compute(&b); !s) {
      std::printf("%s\n", s.to_string().c_str());
      return 1;
    }
    if (!instance->last_used_block_kernel() || instance->last_used_warp_kernel() != warp ||
        instance->last_used_robot_specific_kernel()) {
      std::printf("the %s kernel compiled into the plugin did not run\n", warp ? "warp" : "block");
      return 1;
    }
    const cudaError_t read = warp ? rbdgrad::cuda::read_warp_stage_clocks(clocks.data(), kWarpClocks)
                                  : rbdgrad::cuda::read_block_pass_clocks(clocks.data(), kClocks);
    if (read != cudaSuccess) return 1;
    int count = 1;
    while (count < kClocks && clocks[count] > clocks[count - 1]) ++count;
    passes = count - 1;
    std::vector<long long> d;
    for (int k = 1; k < count; ++k) d.push_back(clocks[k] - clocks[k - 1]);
    deltas.push_back(d);
  }
  std::printf("%s kernel, %s %s N=%zu %s: %d passes, kernel %.1f us (event)\n", warp ? "warp" : "block",
              robot.c_str(), sizeof(S) == 8 ? "f64" : "f32", n, mapped_io ? "mapped I/O" : "copies", passes - 1,
              instance->last_kernel_ms() * 1e3);
  long long total = 0;
  for (int k = 0; k < passes; ++k) {
    std::vector<long long> at;
    for (const auto& d : deltas)
      if (k < static_cast<int>(d.size())) at.push_back(d[static_cast<std::size_t>(k)]);
    std::nth_element(at.begin(), at.begin() + static_cast<long>(at.size() / 2), at.end());
    const long long median = at[at.size() / 2];
    total += median;
    // the first interval is the prologue: the inputs and the robot's constants into shared memory
    if (k == 0) std::printf("  prologue: %6lld cycles %6.2f us\n", median, static_cast<double>(median) / clock_ghz / 1e3);
    else std::printf("  pass %2d: %7lld cycles %6.2f us\n", k, median, static_cast<double>(median) / clock_ghz / 1e3);
  }
  std::printf("  sum of medians: %lld cycles, %.2f us at %.3f GHz\n", total, static_cast<double>(total) / clock_ghz / 1e3,
              clock_ghz);
  return 0;
}

}  // namespace

int main() {
  cudaDeviceProp prop{};
  if (cudaGetDeviceProperties(&prop, 0) != cudaSuccess) {
    std::printf("no GPU\n");
    return 1;
  }
  int clock_khz = 0;
  cudaDeviceGetAttribute(&clock_khz, cudaDevAttrClockRate, 0);
  const double ghz = clock_khz / 1e6;
  std::printf("%s, SM clock %.3f GHz\n", prop.name, ghz);
  int rc = 0;
  for (const bool mapped_io : {true, false})
    for (const char* robot : {"iiwa14", "talos_reduced"}) {
      for (const bool warp : {true, false}) {
        rc |= run<double>(robot, RBDGRAD_PRECISION_F64, 16, ghz, mapped_io, warp);
        rc |= run<float>(robot, RBDGRAD_PRECISION_F32, 16, ghz, mapped_io, warp);
      }
    }
  return rc;
}
