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
