// The kernel's C simulation as a KernelRunner: the top function (kernel/gradient_top.cpp), compiled
// by g++, runs on the host CPU in wait(). It computes exactly what the kernel's arithmetic gives,
// at the speed of a CPU emulating fixed point, not of an FPGA.
#pragma once

#include <string>
#include <vector>

#include "host/kernel_runner.hpp"

namespace rbdgrad::fpga {

class CsimRunner final : public KernelRunner {
 public:
  /// Areas for chunk_states states of a model with nv joints.
  CsimRunner(int nv, std::size_t chunk_states);

  Status set_robot(const std::vector<DeviceWord>& robot) override;
  DeviceWord* input(int slot) override { return in_[slot].data(); }
  const DeviceWord* output(int slot) const override { return out_[slot].data(); }
  Status start(int slot, int n_states, int mode) override;
  /// Runs the slot's states through the top function. The top function keeps its on-chip memory
  /// in statics (as the hardware has one set), so runs of every instance in the process take
  /// turns on one lock.
  Status wait(int slot) override;

  const char* mode() const override { return "csim"; }
  const std::string& device() const override { return device_; }

 private:
  struct Pending {
    int n_states = 0;  // 0 = nothing started
    int mode = 0;
  };

  int nv_;
  std::size_t chunk_states_;
  std::vector<DeviceWord> robot_;
  std::vector<DeviceWord> in_[kSlots], out_[kSlots];
  Pending pending_[kSlots];
  std::string device_ = "host CPU (C simulation of the HLS kernel)";
};

}  // namespace rbdgrad::fpga
