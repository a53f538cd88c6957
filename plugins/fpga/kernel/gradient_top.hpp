// The FPGA kernel's top function (the one HLS synthesizes, with AXI master ports): a batch of
// states through fd_gradient in the device scalar, words laid out as axi_layout.hpp says. Compiled
// with g++ it is the C simulation that the host runs in csim mode and the tests call.
#pragma once

#include "axi_layout.hpp"

extern "C" {
/// \param robot AxiLayout::robot_words(nv) words.
/// \param in n_states x AxiLayout::in_words(nv) words.
/// \param out n_states x AxiLayout::out_words(nv) words.
/// \param mode kModeTauInput: u holds tau (qdd = M^-1 (tau - c)), else qdd; kModeNoDq, kModeNoDqd:
///             the d/dq or d/dqd columns are not computed (their words are 0).
/// Not reentrant: its on-chip memory is static, as on hardware, so one call runs at a time.
void rbdgrad_fpga_gradient(const rbdgrad::fpga::DeviceWord* robot, const rbdgrad::fpga::DeviceWord* in,
                           rbdgrad::fpga::DeviceWord* out, int n_states, int mode);
}

namespace rbdgrad::fpga {
/// The same top function with its columns fixed at compile time (kColumnsDq, kColumnsDqd or both;
/// gradient_kernel.hpp's FixedColumns): the kernel built for one column set, which never had the
/// other's datapaths. mode's kModeTauInput is read; its kModeNoDq and kModeNoDqd are ignored.
/// The same words as rbdgrad_fpga_gradient with the matching mode (GradientTop tests). Issue 8's
/// reference for what the run-time mode costs (bench/plugins/fpga_host_bench.cpp, SkipCost);
/// the plugin does not use it. Not reentrant; its on-chip memory is its own.
template <unsigned kColumns>
void gradient_fixed_columns(const DeviceWord* robot, const DeviceWord* in, DeviceWord* out, int n_states, int mode);
}  // namespace rbdgrad::fpga
