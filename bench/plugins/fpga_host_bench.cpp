// Where the FPGA backend's conversions between floating and fixed point cost what, per state of
// iiwa14 (docs/fpga.md): the server's conversion of a request's f64 inputs to Q16.16, the
// plugin's host share (sin/cos and packing, M^-1 in double), and the kernel's C simulation for
// scale (a CPU emulating the kernel's arithmetic, not the FPGA's speed).
//
// SkipCost (issue 8, docs/benchmarks/scenes.md, FPGA): what skipping a column set through the
// top function's run-time mode word costs against the kernel built without it. Per robot (iiwa14,
// hyq) and variant (dq_only: d qdd/d q alone, dqd_only: d qdd/d qd alone), tau input, a batch of
// 64 seeded random states through three ways in rotating order, so that the machine's noise falls
// on all three alike:
//   full:  rbdgrad_fpga_gradient with both columns (the mode word kModeTauInput);
//   mode:  rbdgrad_fpga_gradient with the variant's mode word (kModeNoDqd or kModeNoDq), as the
//          plugin calls it: the columns decided at run time;
//   fixed: gradient_fixed_columns<kColumnsDq or kColumnsDqd>: the same computation with the
//          columns a compile-time constant, the build that never had the other datapaths.
// Counters: full_ns, mode_ns, fixed_ns per state; speedup = full / mode; mode_over_fixed = mode /
// fixed; model_cycles and model_full_cycles: the latency model's cycles per gradient for the
// variant's columns and for both (host/latency_model.hpp; it takes the columns, not whether they
// are fixed, so mode and fixed have the same figure).
#include <benchmark/benchmark.h>

#include <array>
#include <cmath>
#include <cstdio>
#include <map>
#include <numbers>
#include <random>
#include <string>
#include <vector>

#include "../support/rotating_ways.hpp"
#include "host/axi_packing.hpp"
#include "host/latency_model.hpp"
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

// ---- SkipCost (issue 8): the run-time mode word against the columns fixed at compile time ----

constexpr int kPoolSize = 64;
constexpr unsigned kPoolSeed = 20240801;

const Model& robot_model(const std::string& name) {
  static std::map<std::string, Model> models;
  auto it = models.find(name);
  if (it == models.end()) {
    Model m;
    if (!load_urdf_string(std::string(embedded_robot_urdf(name)), name + ".urdf", m)) std::abort();
    it = models.emplace(name, std::move(m)).first;
  }
  return it->second;
}

// A robot's words and a batch of kPoolSize seeded random states (q within the joint limits, qd
// within +-2, tau within the effort limits, M^-1(q) in double), each one the full kernel keeps
// within Q16.16's range (the others are drawn again).
struct Pool {
  int nv = 0;
  std::vector<DeviceWord> robot, in;
  int rejected = 0;
};

const Pool& pool_of(const std::string& name) {
  static std::map<std::string, Pool> pools;
  if (auto it = pools.find(name); it != pools.end()) return it->second;
  const Model& m = robot_model(name);
  Pool p;
  p.nv = m.nv;
  const int n = m.nv;
  std::string error;
  if (!fpga::pack_robot(m, p.robot, error)) std::abort();
  std::mt19937 rng(kPoolSeed);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  WorkspaceTpl<double> ws(m);
  std::vector<double> q(n), qd(n), tau(n), minv(n * n);
  std::vector<DeviceWord> one, out(static_cast<std::size_t>(AxiLayout::out_words(n)));
  while (static_cast<int>(p.in.size()) < kPoolSize * AxiLayout::in_words(n)) {
    if (p.rejected > 100 * kPoolSize) std::abort();
    for (int i = 0; i < n; ++i) {
      const JointInfo& j = m.joints[static_cast<std::size_t>(i)];
      const bool limited = j.lower_limit != 0 || j.upper_limit != 0;
      const double lo = limited ? j.lower_limit : -std::numbers::pi, hi = limited ? j.upper_limit : std::numbers::pi;
      q[i] = lo + (hi - lo) * (0.5 + 0.5 * unit(rng));
      qd[i] = 2.0 * unit(rng);
      tau[i] = (j.effort_limit > 0 ? j.effort_limit : 10.0) * unit(rng);
    }
    if (!minverse(m, ws, Eigen::Map<const Eigen::VectorXd>(q.data(), n))) std::abort();
    for (int r = 0; r < n; ++r)
      for (int c = 0; c < n; ++c) minv[static_cast<std::size_t>(r * n + c)] = ws.Minv(r, c);
    one.clear();
    if (!fpga::pack_state(n, q.data(), qd.data(), tau.data(), minv.data(), one, error)) {
      ++p.rejected;
      continue;
    }
    rbdgrad_fpga_gradient(p.robot.data(), one.data(), out.data(), 1, fpga::kModeTauInput);
    if (out.back() != fpga::kStatusOk) {
      ++p.rejected;
      continue;
    }
    p.in.insert(p.in.end(), one.begin(), one.end());
  }
  return pools.emplace(name, std::move(p)).first->second;
}

void BM_SkipCost(benchmark::State& st, const char* robot, unsigned columns) {
  const Pool& p = pool_of(robot);
  const int n = p.nv;
  using Top = void (*)(const DeviceWord*, const DeviceWord*, DeviceWord*, int, int);
  const int full_mode = fpga::kModeTauInput;
  const int mode = fpga::kModeTauInput | (columns == fpga::kColumnsDq ? fpga::kModeNoDqd : fpga::kModeNoDq);
  const Top fixed = columns == fpga::kColumnsDq ? &fpga::gradient_fixed_columns<fpga::kColumnsDq>
                                                : &fpga::gradient_fixed_columns<fpga::kColumnsDqd>;
  std::vector<DeviceWord> out[3];
  for (std::vector<DeviceWord>& o : out) o.assign(static_cast<std::size_t>(kPoolSize * AxiLayout::out_words(n)), -1);
  // way 0: full, 1: mode, 2: fixed; one call each with the whole batch
  const auto run = [&](int which) {
    DeviceWord* o = out[which].data();
    if (which == 2)
      fixed(p.robot.data(), p.in.data(), o, kPoolSize, fpga::kModeTauInput);
    else
      rbdgrad_fpga_gradient(p.robot.data(), p.in.data(), o, kPoolSize, which == 0 ? full_mode : mode);
    benchmark::DoNotOptimize(o);
    benchmark::ClobberMemory();
  };
  // untimed: each way once; the fixed kernel must write the mode's words
  for (int which = 0; which < 3; ++which) run(which);
  if (out[1] != out[2]) {
    st.SkipWithError("the fixed-columns kernel's words differ from the mode's");
    return;
  }
  long passes = 0;
  const std::array<double, 3> ns = bench::time_rotating_ways<3>(st, run, passes);
  bench::report_three_ways(st, ns, static_cast<double>(passes) * kPoolSize, {"full", "mode", "fixed"});
  fpga::LatencyEstimate variant, full;
  const Model& m = robot_model(robot);
  if (!fpga::estimate_latency(m, fpga::KernelTiming{}, 1, fpga::InputKind::kTau, columns, variant) ||
      !fpga::estimate_latency(m, fpga::KernelTiming{}, 1, fpga::InputKind::kTau, fpga::kAllColumns, full)) {
    st.SkipWithError("estimate_latency failed");
    return;
  }
  st.counters["model_cycles"] = static_cast<double>(variant.cycles_per_gradient);
  st.counters["model_full_cycles"] = static_cast<double>(full.cycles_per_gradient);
  st.SetLabel("nv=" + std::to_string(n) + ", " + std::to_string(p.rejected) + " drawn states out of range");
}
BENCHMARK_CAPTURE(BM_SkipCost, iiwa14_dq_only, "iiwa14", fpga::kColumnsDq)->Unit(benchmark::kMicrosecond);
BENCHMARK_CAPTURE(BM_SkipCost, iiwa14_dqd_only, "iiwa14", fpga::kColumnsDqd)->Unit(benchmark::kMicrosecond);
BENCHMARK_CAPTURE(BM_SkipCost, hyq_dq_only, "hyq", fpga::kColumnsDq)->Unit(benchmark::kMicrosecond);
BENCHMARK_CAPTURE(BM_SkipCost, hyq_dqd_only, "hyq", fpga::kColumnsDqd)->Unit(benchmark::kMicrosecond);

}  // namespace

BENCHMARK_MAIN();
