#include "fixed_format_kernel.hpp"

#include <cmath>
#include <memory>

#include "kernel/axi_layout.hpp"
#include "kernel/gradient_kernel.hpp"
#include "kernel/robot_constants.hpp"
#include "rbdgrad/algorithm/minverse.hpp"
#include "rbdgrad/workspace.hpp"

namespace rbdgrad::bench {
namespace {

constexpr int kMaxNv = fpga::kDeviceMaxNv;

template <int W, int F>
Status run_format(const Model& model, const StateSet& states, Gradients& out) {
  using T = Fixed<W, F>;
  auto robot = std::make_unique<fpga::RobotConstants<T, kMaxNv>>();
  if (!fpga::robot_constants(model, *robot))
    return invalid_argument("model '" + model.name + "' has " + std::to_string(model.nv) + " joints; the kernel takes " +
                            std::to_string(kMaxNv));
  auto state = std::make_unique<fpga::KernelState<T, kMaxNv>>();
  Workspace ws(model);
  const int n = model.nv;
  const auto nv = static_cast<std::size_t>(n);
  out.dqdd_dq.assign(states.n * nv * nv, 0.0);
  out.dqdd_dqd.assign(states.n * nv * nv, 0.0);
  out.state_status.assign(states.n, 0);
  out.qdd.assign(states.n * nv, 0.0);
  out.minv.assign(states.n * nv * nv, 0.0);
  T q[kMaxNv], s[kMaxNv], c[kMaxNv], qd[kMaxNv], u[kMaxNv], minv[kMaxNv * kMaxNv];
  T qdd[kMaxNv], dq[kMaxNv * kMaxNv], dqd[kMaxNv * kMaxNv];
  Eigen::VectorXd qk(n);
  for (std::size_t k = 0; k < states.n; ++k) {
    // the state arrives in the format, as a fixed-point request does through the plugin ABI: the
    // host's sin, cos and M^-1 are of the rounded q. The conversions may overflow too.
    const FixedOverflowScope scope;
    for (int i = 0; i < n; ++i) {
      const auto at = k * nv + static_cast<std::size_t>(i);
      q[i] = T(states.q[at]);
      qd[i] = T(states.qd[at]);
      u[i] = T(states.tau[at]);
      qk(i) = static_cast<double>(q[i]);
      s[i] = T(std::sin(qk(i)));
      c[i] = T(std::cos(qk(i)));
    }
    if (Status st = minverse(model, ws, qk); !st) {
      out.state_status[k] = 1;
      continue;
    }
    for (int r = 0; r < n; ++r)
      for (int col = 0; col < n; ++col) minv[r * n + col] = T(ws.Minv(r, col));
    fpga::fd_gradient(*robot, q, s, c, qd, u, true, minv, *state, qdd, dq, dqd);
    if (scope.overflowed()) {
      out.state_status[k] = 1;
      continue;
    }
    for (std::size_t e = 0; e < nv * nv; ++e) {
      out.dqdd_dq[k * nv * nv + e] = static_cast<double>(dq[e]);
      out.dqdd_dqd[k * nv * nv + e] = static_cast<double>(dqd[e]);
      out.minv[k * nv * nv + e] = static_cast<double>(minv[e]);
    }
    for (std::size_t i = 0; i < nv; ++i) out.qdd[k * nv + i] = static_cast<double>(qdd[i]);
  }
  return Status::ok();
}

}  // namespace

const std::vector<FixedFormat>& fixed_formats() {
  static const std::vector<FixedFormat> formats = {
      {"Q20.12", 32, 12}, {"Q16.16", 32, 16}, {"Q12.20", 32, 20}, {"Q24.24", 48, 24}};
  return formats;
}

Status run_fixed_format(const FixedFormat& format, const Model& model, const StateSet& states, Gradients& out) {
  const int w = format.total_bits, f = format.frac_bits;
  if (w == 32 && f == 12) return run_format<32, 12>(model, states, out);
  if (w == 32 && f == 16) return run_format<32, 16>(model, states, out);
  if (w == 32 && f == 20) return run_format<32, 20>(model, states, out);
  if (w == 48 && f == 24) return run_format<48, 24>(model, states, out);
  return invalid_argument("fixed-point format " + format.name + " is not compiled into this benchmark");
}

}  // namespace rbdgrad::bench
