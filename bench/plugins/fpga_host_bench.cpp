// Where the FPGA backend's conversions between floating and fixed point cost what, per state of
// iiwa14 (docs/fpga.md): the server's conversion of a request's f64 inputs to Q16.16, the
// plugin's host share (sin/cos and packing, M^-1 in double), and the kernel's C simulation for
// scale (a CPU emulating the kernel's arithmetic, not the FPGA's speed).
#include <benchmark/benchmark.h>

#include <random>
#include <vector>

#include "host/axi_packing.hpp"
#include "kernel/gradient_top.hpp"
#include "rbdgrad/algorithm/minverse.hpp"
#include "rbdgrad/fixed_point.hpp"
#include "rbdgrad/embedded_robots.hpp"
#include "rbdgrad/urdf.hpp"

namespace {

using namespace rbdgrad;
using fpga::AxiLayout;
using fpga::DeviceWord;

struct State {
  explicit State(int nv) : q(nv), qd(nv), u(nv), minv(nv * nv) {
    std::mt19937 rng(3);
    std::uniform_real_distribution<double> d(-1, 1);
    for (int i = 0; i < nv; ++i) q[i] = d(rng), qd[i] = d(rng), u[i] = d(rng);
  }
  std::vector<double> q, qd, u, minv;
};

const Model& iiwa() {
  static const Model model = [] {
    Model m;
    if (!load_urdf_string(std::string(embedded_robot_urdf("iiwa14")), "iiwa14.urdf", m)) std::abort();
    return m;
  }();
  return model;
}

// the server: a state's inputs (q, qd, u) from f64 to Q16.16 words
void BM_ServerToFixed(benchmark::State& st) {
  const int nv = iiwa().nv;
  State s(nv);
  std::vector<std::int32_t> out(3 * static_cast<std::size_t>(nv));
  for (auto _ : st) {
    for (int i = 0; i < nv; ++i) {
      out[i] = Q16_16(s.q[i]).raw();
      out[nv + i] = Q16_16(s.qd[i]).raw();
      out[2 * nv + i] = Q16_16(s.u[i]).raw();
    }
    benchmark::DoNotOptimize(out.data());
  }
}
BENCHMARK(BM_ServerToFixed);

// the plugin: sin, cos and the range-checked words of one state
void BM_HostPackState(benchmark::State& st) {
  const int nv = iiwa().nv;
  State s(nv);
  std::vector<DeviceWord> words(static_cast<std::size_t>(AxiLayout::in_words(nv)));
  std::string error;
  for (auto _ : st) {
    benchmark::DoNotOptimize(fpga::pack_state(nv, s.q.data(), s.qd.data(), s.u.data(), s.minv.data(), words.data(), error));
  }
}
BENCHMARK(BM_HostPackState);

// the plugin: M^-1 in double (skipped when the caller sends M^-1)
void BM_HostMinverse(benchmark::State& st) {
  WorkspaceTpl<double> ws(iiwa());
  State s(iiwa().nv);
  const Eigen::Map<const Eigen::VectorXd> q(s.q.data(), iiwa().nv);
  for (auto _ : st) benchmark::DoNotOptimize(minverse(iiwa(), ws, q).is_ok());
}
BENCHMARK(BM_HostMinverse);

// the kernel's C simulation, one state from tau; the argument is the top function's mode: both
// column sets, or a scene's d/dq or d/dqd alone (the other datapaths skipped)
void BM_CsimKernel(benchmark::State& st) {
  const int mode = static_cast<int>(st.range(0));
  const int nv = iiwa().nv;
  State s(nv);
  WorkspaceTpl<double> ws(iiwa());
  if (!minverse(iiwa(), ws, Eigen::Map<const Eigen::VectorXd>(s.q.data(), nv))) std::abort();
  for (int r = 0; r < nv; ++r)
    for (int c = 0; c < nv; ++c) s.minv[static_cast<std::size_t>(r * nv + c)] = ws.Minv(r, c);
  std::vector<DeviceWord> robot, in;
  std::string error;
  if (!fpga::pack_robot(iiwa(), robot, error) || !fpga::pack_state(nv, s.q.data(), s.qd.data(), s.u.data(), s.minv.data(), in, error))
    std::abort();
  std::vector<DeviceWord> out(static_cast<std::size_t>(AxiLayout::out_words(nv)));
  for (auto _ : st) {
    rbdgrad_fpga_gradient(robot.data(), in.data(), out.data(), 1, mode);
    benchmark::DoNotOptimize(out.data());
  }
}
BENCHMARK(BM_CsimKernel)
    ->ArgName("mode")
    ->Arg(fpga::kModeTauInput)
    ->Arg(fpga::kModeTauInput | fpga::kModeNoDqd)
    ->Arg(fpga::kModeTauInput | fpga::kModeNoDq);

}  // namespace

BENCHMARK_MAIN();
