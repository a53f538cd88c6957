// Counts the arithmetic of the CUDA block kernel for one state: block_evaluate_state (the device
// code, compiled as plain C++) runs on the host with a scalar type that counts every add,
// multiply and divide, on the benchmark's workload (forward-dynamics gradient from tau, outputs
// d qdd/d q and d qdd/d qd). With the bytes a state moves through device memory, that gives the
// floor under the kernel's time at N states: max(FLOPs / peak FLOP/s, bytes / bandwidth).
// Usage: cuda_flop_count [N [peak_f64_tflops peak_f32_tflops bandwidth_tb_s]]
// (defaults: 65536 states; the H100 SXM of the anchors and of docs/benchmarks/cuda.md's runs: 132
// SMs at 1.98 GHz with 64 FP64 and 128 FP32 FMA lanes each, 33.4 and 66.9 TFLOP/s; HBM3 3.35 TB/s.
// An H200 has the same SMs and 4.8 TB/s: `cuda_flop_count 65536 33.4 66.9 4.8`).
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <type_traits>
#include <vector>

#include "device/block_fused_state.hpp"
#include "flat_model.hpp"
#include "gradient_workload.hpp"
#include "rbdgrad/embedded_robots.hpp"
#include "rbdgrad/urdf.hpp"

namespace counting {

struct Counts {
  std::uint64_t add = 0, mul = 0, div = 0, transcendental = 0;
  std::uint64_t flops() const { return add + mul + div; }
};
inline Counts counts;

// A number that counts the arithmetic done on it; kSingle picks the kernel's f32 algorithms.
template <bool kSingle>
struct Counted {
  double v = 0;
  Counted() = default;
  explicit Counted(double x) : v(x) {}
  explicit Counted(int x) : v(x) {}
  Counted operator-() const { return Counted(-v); }
  Counted& operator+=(Counted o) { ++counts.add; v += o.v; return *this; }
  Counted& operator-=(Counted o) { ++counts.add; v -= o.v; return *this; }
  Counted& operator*=(Counted o) { ++counts.mul; v *= o.v; return *this; }
  Counted& operator/=(Counted o) { ++counts.div; v /= o.v; return *this; }
  friend Counted operator+(Counted a, Counted b) { return a += b; }
  friend Counted operator-(Counted a, Counted b) { return a -= b; }
  friend Counted operator*(Counted a, Counted b) { return a *= b; }
  friend Counted operator/(Counted a, Counted b) { return a /= b; }
  friend bool operator==(Counted a, Counted b) { return a.v == b.v; }
  friend bool operator!=(Counted a, Counted b) { return a.v != b.v; }
  friend bool operator<(Counted a, Counted b) { return a.v < b.v; }
  friend bool operator>(Counted a, Counted b) { return a.v > b.v; }
  friend Counted sin(Counted a) { ++counts.transcendental; return Counted(std::sin(a.v)); }
  friend Counted cos(Counted a) { ++counts.transcendental; return Counted(std::cos(a.v)); }
};

}  // namespace counting

namespace rbdgrad::cuda {
template <>
struct SinglePrecision<counting::Counted<true>> : std::true_type {};
}  // namespace rbdgrad::cuda

namespace {

// Arithmetic of one state of `robot` (averaged over a few random states, which differ only in
// the finiteness checks); kLean: the compact kernel with its lean working set (packed matrices).
template <bool kSingle, bool kLean = false>
counting::Counts count_state(const rbdgrad::Model& model) {
  using S = counting::Counted<kSingle>;
  const rbdgrad::cuda::FlatModel<S> flat(model);
  constexpr std::size_t kStates = 4;
  rbdgrad::cuda::GradientWorkload<S> work(model.nv, kStates, 3);
  const rbdgrad::cuda::BatchPointers<S>& b = work.batch;
  const bool with_aba = rbdgrad::cuda::block_uses_aba<S>(true);
  const rbdgrad::cuda::BlockMatrices matrices =
      rbdgrad::cuda::block_matrices(model.nv, flat.matrix_scalars, kLean, false);
  std::vector<S> shared(rbdgrad::cuda::BlockWorkspace<S>::scalars(model.nv, with_aba, matrices, kLean));
  const rbdgrad::cuda::BlockWorkspace<S> w(shared.data(), model.nv, with_aba, matrices, kLean);
  counting::counts = {};
  for (std::size_t k = 0; k < kStates; ++k) {
    rbdgrad::cuda::block_load_inputs(flat.host_view().nv, w, b, k, rbdgrad::cuda::ThreadGroup{});
    rbdgrad::cuda::block_evaluate_state<S, rbdgrad::cuda::ModelView<S>, S, rbdgrad::cuda::block_stages::kPerBatch,
                                        kLean, kLean>(flat.host_view(), w, b, k, true, rbdgrad::cuda::ThreadGroup{});
  }
  if (work.failed() != 0) std::fprintf(stderr, "warning: %zu states failed\n", work.failed());
  counting::Counts per = counting::counts;
  per.add /= kStates;
  per.mul /= kStates;
  per.div /= kStates;
  per.transcendental /= kStates;
  return per;
}

}  // namespace

int main(int argc, char** argv) {
  const double states = argc > 1 ? std::atof(argv[1]) : 65536;
  const double peak_f64 = (argc > 2 ? std::atof(argv[2]) : 33.4) * 1e12;
  const double peak_f32 = (argc > 3 ? std::atof(argv[3]) : 66.9) * 1e12;
  const double bandwidth = (argc > 4 ? std::atof(argv[4]) : 3.35) * 1e12;
  std::printf("| robot | precision | adds | multiplies | divides | sin/cos | FLOPs per state | bytes per state "
              "| floor at N = %.0f (us) | bound by |\n|---|---|---:|---:|---:|---:|---:|---:|---:|---|\n",
              states);
  for (const char* robot : {"iiwa14", "talos_reduced"}) {
    rbdgrad::Model model;
    if (!rbdgrad::load_urdf_string(std::string(rbdgrad::embedded_robot_urdf(robot)), robot, model).is_ok()) return 1;
    // the block kernel with its full working set, then with the lean one (option block_lean, the
    // default where the compact kernel is built)
    for (const int build : {0, 1, 2, 3}) {
      const bool single = build % 2 == 0, lean = build >= 2;
      const counting::Counts c = lean ? (single ? count_state<true, true>(model) : count_state<false, true>(model))
                                      : (single ? count_state<true>(model) : count_state<false>(model));
      const double scalar = single ? 4 : 8;
      // device memory per state: q, qd, tau in; d qdd/d q, d qdd/d qd and the status out (the
      // working set stays in shared memory, the robot's constants in cache)
      const double bytes = (3.0 * model.nv + 2.0 * model.nv * model.nv) * scalar + 4;
      const double compute_us = 1e6 * states * static_cast<double>(c.flops()) / (single ? peak_f32 : peak_f64);
      const double memory_us = 1e6 * states * bytes / bandwidth;
      std::printf("| %s%s | %s | %llu | %llu | %llu | %llu | %llu | %.0f | %.1f | %s |\n", robot, lean ? " (lean)" : "",
                  single ? "f32" : "f64",
                  static_cast<unsigned long long>(c.add), static_cast<unsigned long long>(c.mul),
                  static_cast<unsigned long long>(c.div), static_cast<unsigned long long>(c.transcendental),
                  static_cast<unsigned long long>(c.flops()), bytes, compute_us > memory_us ? compute_us : memory_us,
                  compute_us > memory_us ? "arithmetic" : "memory");
    }
  }
  return 0;
}
