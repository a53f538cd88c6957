#include "host/csim_runner.hpp"

#include <mutex>

#include "kernel/gradient_top.hpp"

namespace rbdgrad::fpga {
namespace {

// the top function's statics are the process's one "device"
std::mutex& top_function_lock() {
  static std::mutex lock;
  return lock;
}

}  // namespace

CsimRunner::CsimRunner(int nv, std::size_t chunk_states) : nv_(nv), chunk_states_(chunk_states) {
  for (int s = 0; s < kSlots; ++s) {
    in_[s].assign(chunk_states * static_cast<std::size_t>(AxiLayout::in_words(nv)), 0);
    out_[s].assign(chunk_states * static_cast<std::size_t>(AxiLayout::out_words(nv)), 0);
  }
}

Status CsimRunner::set_robot(const std::vector<DeviceWord>& robot) {
  if (robot.size() != static_cast<std::size_t>(AxiLayout::robot_words(nv_)))
    return Status(StatusCode::kInternal, "csim: robot block of " + std::to_string(robot.size()) + " words, expected " +
                                             std::to_string(AxiLayout::robot_words(nv_)));
  robot_ = robot;
  return Status::ok();
}

Status CsimRunner::start(int slot, int n_states, int mode) {
  if (robot_.empty()) return Status(StatusCode::kInternal, "csim: start before set_robot");
  if (n_states < 1 || static_cast<std::size_t>(n_states) > chunk_states_)
    return Status(StatusCode::kInternal, "csim: " + std::to_string(n_states) + " states in a slot of " +
                                             std::to_string(chunk_states_));
  if (pending_[slot].n_states != 0) return Status(StatusCode::kInternal, "csim: slot started twice without a wait");
  clear_status_words(out_[slot].data(), nv_, n_states);
  pending_[slot] = {n_states, mode};
  return Status::ok();
}

Status CsimRunner::wait(int slot) {
  const Pending p = pending_[slot];
  if (p.n_states == 0) return Status(StatusCode::kInternal, "csim: wait on a slot that was not started");
  pending_[slot] = {};
  const std::lock_guard lock(top_function_lock());
  rbdgrad_fpga_gradient(robot_.data(), in_[slot].data(), out_[slot].data(), p.n_states, p.mode);
  return Status::ok();
}

}  // namespace rbdgrad::fpga
