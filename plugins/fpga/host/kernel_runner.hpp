// How the host drives the FPGA kernel, whatever runs it (the C simulation here, XRT on a card):
// two slots for double buffering, each an input and an output area of up to chunk_states states
// in the kernel's AXI words (kernel/axi_layout.hpp). The host fills a slot's input, start()s it,
// fills the other slot while the first computes, then wait()s for the first one's output.
#pragma once

#include <cstddef>
#include <string>
#include <vector>

#include "kernel/axi_layout.hpp"
#include "rbdgrad/status.hpp"

namespace rbdgrad::fpga {

class KernelRunner {
 public:
  static constexpr int kSlots = 2;

  virtual ~KernelRunner() = default;

  /// The robot block (pack_robot), once before the first start.
  virtual Status set_robot(const std::vector<DeviceWord>& robot) = 0;
  /// Slot `slot`'s input area: chunk_states * AxiLayout::in_words(nv) words, host-writable while
  /// the slot is not started.
  virtual DeviceWord* input(int slot) = 0;
  /// Its output area: chunk_states * AxiLayout::out_words(nv) words, valid after wait(slot).
  virtual const DeviceWord* output(int slot) const = 0;
  /// Hands the first n_states states of the slot's input to the kernel (uploads and launches), with
  /// the top function's `mode` (kModeTauInput, kModeNoDq, kModeNoDqd). Clears their status words in
  /// the output area first, so that a state the kernel never writes does not read as a result.
  virtual Status start(int slot, int n_states, int mode) = 0;
  /// Returns once the slot's run has finished and its output is on the host.
  virtual Status wait(int slot) = 0;

  /// "csim" for the C simulation, "" for hardware (rbdgrad_instance_info.mode).
  virtual const char* mode() const = 0;
  /// What it runs on, for logs: "xilinx_u280 (0000:3b:00.1)".
  virtual const std::string& device() const = 0;
};

/// Zeroes the status words of the first n_states states of an output area (KernelRunner::start).
inline void clear_status_words(DeviceWord* out, int nv, int n_states) {
  for (int k = 0; k < n_states; ++k) out[static_cast<long>(k) * AxiLayout::out_words(nv) + AxiLayout::out_words(nv) - 1] = 0;
}

}  // namespace rbdgrad::fpga
