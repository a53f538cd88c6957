#include "gradient_top.hpp"

#include "gradient_kernel.hpp"
#include "rbdgrad/fixed_point.hpp"

namespace rbdgrad::fpga {
namespace {

// Q16.16, as the paper's design; ap_fixed<32, 16, AP_RND_INF, AP_SAT> under synthesis
using DeviceScalar = Q16_16;

DeviceScalar scalar(DeviceWord w) { return DeviceScalar::from_raw(w); }

void read_robot(const DeviceWord* w, RobotConstants<DeviceScalar, kDeviceMaxNv>& robot) {
  robot.nv = w[0];
  const DeviceWord* joint = w + 1;
  for (int i = 0; i < robot.nv; ++i, joint += AxiLayout::kWordsPerJoint) {
    robot.parent[i] = joint[0];
    robot.prismatic[i] = joint[1] != 0;
    for (int e = 0; e < 9; ++e) robot.joint_rotation[i][e] = scalar(joint[2 + e]);
    for (int e = 0; e < 3; ++e) robot.joint_translation[i][e] = scalar(joint[11 + e]);
    for (int e = 0; e < 36; ++e) robot.inertia[i][e] = scalar(joint[14 + e]);
  }
  for (int e = 0; e < 3; ++e) robot.gravity[e] = scalar(joint[e]);
}

// The top function's body for one batch. Columns: an unsigned when the mode word sets them at run
// time (rbdgrad_fpga_gradient), FixedColumns<...> when they are fixed at compile time
// (gradient_fixed_columns). Each instantiation has its own on-chip memory.
template <class Columns>
void gradient_batch(const DeviceWord* robot_words, const DeviceWord* in, DeviceWord* out, int n_states,
                    bool tau_input, Columns columns) {
  // on-chip for the whole batch (static: BRAM on hardware, and off the stack in C simulation)
  static RobotConstants<DeviceScalar, kDeviceMaxNv> robot;
  static KernelState<DeviceScalar, kDeviceMaxNv> state;
  read_robot(robot_words, robot);
  const int n = robot.nv;
  for (int k = 0; k < n_states; ++k) {
    const DeviceWord* w = in + static_cast<long>(k) * AxiLayout::in_words(n);
    DeviceWord* o = out + static_cast<long>(k) * AxiLayout::out_words(n);
    DeviceScalar q[kDeviceMaxNv], s[kDeviceMaxNv], c[kDeviceMaxNv], qd[kDeviceMaxNv], u[kDeviceMaxNv];
    DeviceScalar minv[kDeviceMaxNv * kDeviceMaxNv];
    for (int i = 0; i < n; ++i) {
      q[i] = scalar(w[i]);
      s[i] = scalar(w[n + i]);
      c[i] = scalar(w[2 * n + i]);
      qd[i] = scalar(w[3 * n + i]);
      u[i] = scalar(w[4 * n + i]);
    }
    for (int e = 0; e < n * n; ++e) minv[e] = scalar(w[5 * n + e]);
    DeviceScalar qdd[kDeviceMaxNv], dq[kDeviceMaxNv * kDeviceMaxNv], dqd[kDeviceMaxNv * kDeviceMaxNv];
    // In C simulation the overflow status of the scalar type says whether the state left the
    // range. ap_fixed saturates without telling: on hardware the flag is to come from comparing
    // every stored value with the format's bounds (docs/fpga.md, "Overflow is never silent"),
    // which is designed but waits for synthesis.
    const rbdgrad::FixedOverflowScope scope;
    fd_gradient(robot, q, s, c, qd, u, tau_input, minv, state, qdd, dq, dqd, columns);
    for (int i = 0; i < n; ++i) o[i] = qdd[i].raw();
    for (int e = 0; e < n * n; ++e) {
      o[n + e] = (columns & kColumnsDq) ? dq[e].raw() : 0;
      o[n + n * n + e] = (columns & kColumnsDqd) ? dqd[e].raw() : 0;
    }
    o[n + 2 * n * n] = scope.overflowed() ? kStatusOverflow : kStatusOk;
  }
}

}  // namespace

template <unsigned kColumns>
void gradient_fixed_columns(const DeviceWord* robot, const DeviceWord* in, DeviceWord* out, int n_states, int mode) {
  gradient_batch(robot, in, out, n_states, (mode & kModeTauInput) != 0, FixedColumns<kColumns>{});
}
template void gradient_fixed_columns<kColumnsDq>(const DeviceWord*, const DeviceWord*, DeviceWord*, int, int);
template void gradient_fixed_columns<kColumnsDqd>(const DeviceWord*, const DeviceWord*, DeviceWord*, int, int);
template void gradient_fixed_columns<kColumnsDq | kColumnsDqd>(const DeviceWord*, const DeviceWord*, DeviceWord*, int,
                                                               int);

}  // namespace rbdgrad::fpga

extern "C" void rbdgrad_fpga_gradient(const rbdgrad::fpga::DeviceWord* robot_words, const rbdgrad::fpga::DeviceWord* in,
                                      rbdgrad::fpga::DeviceWord* out, int n_states, int mode) {
  using namespace rbdgrad::fpga;
  RBDGRAD_HLS_PRAGMA(HLS INTERFACE m_axi port = robot_words offset = slave bundle = gmem0)
  RBDGRAD_HLS_PRAGMA(HLS INTERFACE m_axi port = in offset = slave bundle = gmem0)
  RBDGRAD_HLS_PRAGMA(HLS INTERFACE m_axi port = out offset = slave bundle = gmem1)
  RBDGRAD_HLS_PRAGMA(HLS INTERFACE s_axilite port = n_states)
  RBDGRAD_HLS_PRAGMA(HLS INTERFACE s_axilite port = mode)
  RBDGRAD_HLS_PRAGMA(HLS INTERFACE s_axilite port = return)
  const unsigned columns = ((mode & kModeNoDq) ? 0u : kColumnsDq) | ((mode & kModeNoDqd) ? 0u : kColumnsDqd);
  gradient_batch(robot_words, in, out, n_states, (mode & kModeTauInput) != 0, columns);
}
