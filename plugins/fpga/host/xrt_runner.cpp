#include "host/xrt_runner.hpp"

#include <cstdlib>
#include <cstring>
#include <exception>
#include <utility>

#include "host/xclbin_check.hpp"

#include "xrt/xrt_bo.h"
#include "xrt/xrt_device.h"
#include "xrt/xrt_kernel.h"

namespace rbdgrad::fpga {
namespace {

constexpr const char* kKernelName = "rbdgrad_fpga_gradient";
// the top function's arguments (kernel/gradient_top.hpp)
enum Arg { kRobot = 0, kIn = 1, kOut = 2, kNStates = 3, kMode = 4 };

class XrtRunner final : public KernelRunner {
 public:
  XrtRunner(const XrtRunnerOptions& options, int nv, std::size_t chunk_states)
      : options_(options), nv_(nv), chunk_states_(chunk_states) {}

  // the steps of make_xrt_runner; each throws what XRT throws
  void open() {
    step_ = "cannot open device '" + options_.device + "'";
    const bool is_index = options_.device.find_first_not_of("0123456789") == std::string::npos;
    device_handle_ = is_index ? xrt::device(static_cast<unsigned>(std::stoul(options_.device)))
                              : xrt::device(options_.device);
    step_ = "cannot load xclbin '" + options_.xclbin + "'";
    const xrt::uuid uuid = device_handle_.load_xclbin(options_.xclbin);
    step_ = std::string("the xclbin has no kernel '") + kKernelName + "'";
    kernel_ = xrt::kernel(device_handle_, uuid, kKernelName);
    step_ = "cannot allocate the kernel's buffers";
    const auto word = sizeof(DeviceWord);
    robot_ = xrt::bo(device_handle_, static_cast<std::size_t>(AxiLayout::robot_words(nv_)) * word, kernel_.group_id(kRobot));
    for (int s = 0; s < kSlots; ++s) {
      in_[s] = xrt::bo(device_handle_, chunk_states_ * static_cast<std::size_t>(AxiLayout::in_words(nv_)) * word,
                       kernel_.group_id(kIn));
      out_[s] = xrt::bo(device_handle_, chunk_states_ * static_cast<std::size_t>(AxiLayout::out_words(nv_)) * word,
                        kernel_.group_id(kOut));
      in_map_[s] = in_[s].map<DeviceWord*>();
      out_map_[s] = out_[s].map<DeviceWord*>();
      runs_[s] = xrt::run(kernel_);
    }
    // names for the log; the noop shim and some platforms cannot answer: the index will do
    try {
      name_ = device_handle_.get_info<xrt::info::device::name>() + " (" +
              device_handle_.get_info<xrt::info::device::bdf>() + ")";
    } catch (const std::exception&) {
      name_ = "FPGA device " + options_.device;
    }
    step_.clear();
  }
  const std::string& step() const { return step_; }

  Status set_robot(const std::vector<DeviceWord>& robot) override {
    return guard("cannot upload the robot", [&] {
      robot_.write(robot.data(), robot.size() * sizeof(DeviceWord), 0);
      robot_.sync(XCL_BO_SYNC_BO_TO_DEVICE);
      for (int s = 0; s < kSlots; ++s) runs_[s].set_arg(kRobot, robot_);
    });
  }
  DeviceWord* input(int slot) override { return in_map_[slot]; }
  const DeviceWord* output(int slot) const override { return out_map_[slot]; }

  Status start(int slot, int n_states, int mode) override {
    return guard("cannot start the kernel", [&] {
      const auto bytes = static_cast<std::size_t>(n_states) * static_cast<std::size_t>(AxiLayout::in_words(nv_)) *
                         sizeof(DeviceWord);
      in_[slot].sync(XCL_BO_SYNC_BO_TO_DEVICE, bytes, 0);
      // on the host side only: the run's sync from the device overwrites them with what the
      // kernel wrote (under XRT's noop shim, which computes nothing, they stay 0)
      clear_status_words(out_map_[slot], nv_, n_states);
      xrt::run& run = runs_[slot];
      run.set_arg(kIn, in_[slot]);
      run.set_arg(kOut, out_[slot]);
      run.set_arg(kNStates, n_states);
      run.set_arg(kMode, mode);
      run.start();
      started_[slot] = n_states;
    });
  }

  Status wait(int slot) override {
    const int n_states = std::exchange(started_[slot], 0);
    if (n_states == 0) return Status(StatusCode::kInternal, "XRT: wait on a slot that was not started");
    ert_cmd_state state = ERT_CMD_STATE_NEW;
    if (Status s = guard("the kernel run failed", [&] { state = runs_[slot].wait(options_.timeout); }); !s) return s;
    // anything but completed (a timeout, an error, an abort) leaves the slot without results
    if (state != ERT_CMD_STATE_COMPLETED) {
      const bool late = state == ERT_CMD_STATE_NEW || state == ERT_CMD_STATE_QUEUED ||
                        state == ERT_CMD_STATE_RUNNING || state == ERT_CMD_STATE_TIMEOUT;
      return unavailable("XRT: the kernel run did not complete (ert_cmd_state " + std::to_string(state) +
                         (late ? ", not done after " + std::to_string(options_.timeout.count()) + " ms" : "") + ")");
    }
    return guard("cannot read the results", [&] {
      const auto bytes = static_cast<std::size_t>(n_states) * static_cast<std::size_t>(AxiLayout::out_words(nv_)) *
                         sizeof(DeviceWord);
      out_[slot].sync(XCL_BO_SYNC_BO_FROM_DEVICE, bytes, 0);
    });
  }

  const char* mode() const override { return ""; }
  const std::string& device() const override { return name_; }

 private:
  template <class F>
  static Status guard(const char* what, F&& fn) {
    try {
      fn();
      return Status::ok();
    } catch (const std::exception& e) {
      return unavailable(std::string("XRT: ") + what + ": " + e.what());
    }
  }

  XrtRunnerOptions options_;
  int nv_;
  std::size_t chunk_states_;
  std::string step_;  // what open() was doing, for its error
  std::string name_;
  xrt::device device_handle_;
  xrt::kernel kernel_;
  xrt::bo robot_;
  xrt::bo in_[kSlots], out_[kSlots];
  DeviceWord* in_map_[kSlots] = {};
  DeviceWord* out_map_[kSlots] = {};
  xrt::run runs_[kSlots];
  int started_[kSlots] = {};
};

}  // namespace

Status make_xrt_runner(const XrtRunnerOptions& options, int nv, std::size_t chunk_states,
                       std::unique_ptr<KernelRunner>& out) {
  if (options.xclbin.empty())
    return unavailable("no xclbin configured: set the fpga plugin's option 'xclbin' to the kernel's bitstream "
                       "(docs/fpga.md), or 'emulation: csim' to run the kernel's C simulation");
  // XRT's software and hardware emulation need Vitis; without it, loading an xclbin makes XRT
  // exit the process (sw_emu) or hang (hw_emu) rather than throw
  if (const char* mode = std::getenv("XCL_EMULATION_MODE");
      mode != nullptr && (std::strcmp(mode, "sw_emu") == 0 || std::strcmp(mode, "hw_emu") == 0) &&
      std::getenv("XILINX_VITIS") == nullptr)
    return unavailable(std::string("XCL_EMULATION_MODE is ") + mode + " but XILINX_VITIS is not set: XRT's emulation " +
                       "needs Vitis (set emulation: csim for the kernel's C simulation)");
  // a malformed file can crash or hang XRT instead of making it throw
  if (Status s = check_xclbin_file(options.xclbin); !s) return unavailable("XRT: " + s.message());
  auto runner = std::make_unique<XrtRunner>(options, nv, chunk_states);
  try {
    runner->open();
  } catch (const std::exception& e) {
    return unavailable("XRT: " + runner->step() + ": " + e.what());
  }
  out = std::move(runner);
  return Status::ok();
}

}  // namespace rbdgrad::fpga
