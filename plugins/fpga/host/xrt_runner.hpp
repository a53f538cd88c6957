// The kernel on an FPGA card through XRT's native C++ API (Debian's libxrt-dev 2.13): the device
// opened and the xclbin loaded once, the kernel and its buffer objects created once, two slots
// of input and output buffers for double buffering, one xrt::run per slot.
// Built only when XRT is found (RBDGRAD_HAVE_XRT); docs/fpga.md says what of it ran without a card.
#pragma once

#include <chrono>
#include <memory>
#include <string>

#include "host/kernel_runner.hpp"

namespace rbdgrad::fpga {

struct XrtRunnerOptions {
  std::string device = "0";  // an index ("0") or a PCIe BDF ("0000:3b:00.1")
  std::string xclbin;        // the kernel's bitstream (plugins/fpga/xclbin/Makefile.vitis)
  std::chrono::milliseconds timeout{10000};  // for one chunk's run
};

/// Opens the device, loads the xclbin, finds the kernel and allocates the buffers for chunk_states
/// states of a model with nv joints. Every XRT failure is unavailable naming the step: "XRT:
/// cannot open device '0': ...".
Status make_xrt_runner(const XrtRunnerOptions& options, int nv, std::size_t chunk_states,
                       std::unique_ptr<KernelRunner>& out);

}  // namespace rbdgrad::fpga
