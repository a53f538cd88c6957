#include "host/fpga_instance.hpp"

#include <algorithm>
#include <utility>

#include "common/batch_view.hpp"
#include "common/error.hpp"
#include "host/axi_packing.hpp"
#include "kernel/gradient_kernel.hpp"
#include "rbdgrad/algorithm/minverse.hpp"
#include "rbdgrad/fixed_point.hpp"

namespace rbdgrad::fpga {
namespace {

double value(std::int32_t raw) { return Q16_16::from_raw(raw).to_double(); }

std::int32_t status_code(const Status& s) {
  return static_cast<std::int32_t>(plugin::state_error_code(s.code(), RBDGRAD_PRECISION_FIXED_Q16_16));
}

// state_status is optional
void set_status(const rbdgrad_batch& b, std::size_t k, std::int32_t code) {
  if (b.state_status != nullptr) b.state_status[k] = code;
}

}  // namespace

unsigned kernel_columns(std::uint32_t outputs) {
  return ((outputs & RBDGRAD_OUTPUT_DQDD_DQ) ? kColumnsDq : 0u) |
         ((outputs & RBDGRAD_OUTPUT_DQDD_DQD) ? kColumnsDqd : 0u);
}

unsigned FpgaInstance::columns() const {
  return plan_ ? kernel_columns(plan_->outputs) : (kColumnsDq | kColumnsDqd);
}

void FpgaInstance::Failures::add(std::size_t k, Status s) {
  if (count++ == 0) {
    first = k;
    status = std::move(s);
  }
}

FpgaInstance::FpgaInstance(const Model& model, std::unique_ptr<KernelRunner> runner, std::size_t chunk_states,
                           std::optional<plugin::BatchPlan> plan)
    : model_(model), plan_(std::move(plan)), ws_(model_), runner_(std::move(runner)), chunk_states_(chunk_states) {
  const auto n = static_cast<std::size_t>(model.nv);
  for (auto& r : refused_) r.assign(chunk_states, 0);
  q_.assign(n, 0.0);
  qd_.assign(n, 0.0);
  u_.assign(n, 0.0);
  minv_.assign(n * n, 0.0);
  error_.reserve(256);
}

Status FpgaInstance::create(const Model& model, std::unique_ptr<KernelRunner> runner, std::size_t chunk_states,
                            std::unique_ptr<FpgaInstance>& out, std::optional<plugin::BatchPlan> plan) {
  if (plan && !plan->fext_bodies.empty())
    return unimplemented("the FPGA kernel takes no external forces, and the plan has forces on " +
                         std::to_string(plan->fext_bodies.size()) + " bodies: use the cpu or cuda backend");
  std::vector<DeviceWord> robot;
  std::string error;
  if (!pack_robot(model, robot, error)) return unimplemented("the FPGA kernel cannot take this model: " + error);
  if (Status s = runner->set_robot(robot); !s) return s;
  out.reset(new FpgaInstance(model, std::move(runner), chunk_states, std::move(plan)));
  return Status::ok();
}

Status FpgaInstance::compute(const rbdgrad_batch* batch) {
  if (Status s = plugin::validate_batch(batch, model_.nv, RBDGRAD_PRECISION_FIXED_Q16_16, kFpgaOutputs); !s) return s;
  if (plan_)
    if (Status s = plugin::check_batch_plan(*batch, *plan_); !s) return s;
  if (batch->fext != nullptr)
    return unimplemented("the FPGA kernel takes no external forces (batch.fext): use the cpu or cuda backend");
  const rbdgrad_batch& b = *batch;
  const std::size_t n = b.n;
  const std::size_t chunks = (n + chunk_states_ - 1) / chunk_states_;
  auto chunk_begin = [&](std::size_t c) { return c * chunk_states_; };
  auto chunk_size = [&](std::size_t c) { return std::min(chunk_states_, n - c * chunk_states_); };
  // the kernel's mode: the input kind, and the column datapaths the batch's outputs do not need
  // bypassed (a scene's skips)
  const unsigned columns = kernel_columns(b.outputs);
  const int mode = (b.input_kind == RBDGRAD_INPUT_TAU ? kModeTauInput : 0) | ((columns & kColumnsDq) ? 0 : kModeNoDq) |
                   ((columns & kColumnsDqd) ? 0 : kModeNoDqd);

  Failures failures;
  // double buffering: chunk c + 1 is packed and queued while chunk c computes; a slot is reused
  // only after its previous chunk has been waited for and read
  pack_chunk(b, 0, 0, chunk_size(0), failures);
  if (Status s = runner_->start(0, static_cast<int>(chunk_size(0)), mode); !s) return s;
  for (std::size_t c = 0; c < chunks; ++c) {
    const int slot = static_cast<int>(c % KernelRunner::kSlots);
    if (c + 1 < chunks) {
      const int next = static_cast<int>((c + 1) % KernelRunner::kSlots);
      pack_chunk(b, next, chunk_begin(c + 1), chunk_size(c + 1), failures);
      if (Status s = runner_->start(next, static_cast<int>(chunk_size(c + 1)), mode); !s) {
        static_cast<void>(runner_->wait(slot));  // leave no run behind
        return s;
      }
    }
    if (Status s = runner_->wait(slot); !s) {
      if (c + 1 < chunks) static_cast<void>(runner_->wait(static_cast<int>((c + 1) % KernelRunner::kSlots)));
      return s;
    }
    unpack_chunk(b, slot, chunk_begin(c), chunk_size(c), failures);
  }

  if (failures.count == 0) return Status::ok();
  std::string message = "state " + std::to_string(failures.first) + ": " + failures.status.message();
  if (failures.count > 1)
    message += " (and " + std::to_string(failures.count - 1) + " more failed states, see state_status)";
  return Status(failures.status.code(), std::move(message));
}

void FpgaInstance::pack_chunk(const rbdgrad_batch& b, int slot, std::size_t begin, std::size_t count,
                              Failures& failures) {
  const int nv = model_.nv;
  const auto n1 = static_cast<std::size_t>(nv);
  const auto in_words = static_cast<std::size_t>(AxiLayout::in_words(nv));
  DeviceWord* area = runner_->input(slot);
  const auto* q = static_cast<const std::int32_t*>(b.q);
  const auto* qd = static_cast<const std::int32_t*>(b.qd);
  const auto* u = static_cast<const std::int32_t*>(b.u);
  const auto* minv = static_cast<const std::int32_t*>(b.minv);
  auto* minv_out = static_cast<std::int32_t*>(b.minv_out);
  const bool want_minv = (b.outputs & RBDGRAD_OUTPUT_MINV) != 0;

  for (std::size_t j = 0; j < count; ++j) {
    const std::size_t k = begin + j;
    DeviceWord* words = area + j * in_words;
    refused_[slot][j] = 1;
    for (std::size_t i = 0; i < n1; ++i) {
      q_[i] = value(q[k * n1 + i]);
      qd_[i] = value(qd[k * n1 + i]);
      u_[i] = value(u[k * n1 + i]);
    }
    // M^-1(q) on the host, in double: for the kernel unless the caller brought one, and for the
    // MINV output, which is always the backend's own (plugin_api.h)
    if (minv == nullptr || want_minv) {
      if (Status s = minverse(model_, ws_, Eigen::Map<const Eigen::VectorXd>(q_.data(), nv)); !s) {
        set_status(b, k, status_code(s));
        failures.add(k, std::move(s));
        std::fill(words, words + in_words, 0);  // the kernel's run of it is ignored
        continue;
      }
    }
    bool minv_fits = true;
    for (std::size_t r = 0; r < n1; ++r)
      for (std::size_t c = 0; c < n1; ++c) {
        const double x = ws_.Minv(static_cast<Eigen::Index>(r), static_cast<Eigen::Index>(c));
        if (want_minv) minv_fits = to_device_word(x, minv_out[k * n1 * n1 + r * n1 + c]) && minv_fits;
        minv_[r * n1 + c] = minv != nullptr ? value(minv[k * n1 * n1 + r * n1 + c]) : x;
      }
    Status refused;
    if (!minv_fits) {
      refused = out_of_range("M^-1 leaves the Q16.16 range on the host (the MINV output cannot hold it)");
    } else if (!pack_state(nv, q_.data(), qd_.data(), u_.data(), minv_.data(), words, error_)) {
      refused = out_of_range("the FPGA kernel's input leaves the Q16.16 range on the host: " + error_);
    }
    if (!refused) {
      set_status(b, k, status_code(refused));
      failures.add(k, std::move(refused));
      std::fill(words, words + in_words, 0);
      continue;
    }
    refused_[slot][j] = 0;
  }
}

void FpgaInstance::unpack_chunk(const rbdgrad_batch& b, int slot, std::size_t begin, std::size_t count,
                                Failures& failures) {
  const int nv = model_.nv;
  const auto n1 = static_cast<std::size_t>(nv);
  const auto out_words = static_cast<std::size_t>(AxiLayout::out_words(nv));
  const DeviceWord* area = runner_->output(slot);
  for (std::size_t j = 0; j < count; ++j) {
    const std::size_t k = begin + j;
    if (refused_[slot][j]) continue;  // failed at the host; its status is set
    const DeviceWord* words = area + j * out_words;
    const DeviceWord status = words[n1 + 2 * n1 * n1];
    if (status != kStatusOk) {
      Status s = status == kStatusOverflow
                     ? out_of_range("the FPGA kernel left the Q16.16 range (fixed-point overflow in the gradient)")
                     : Status(StatusCode::kInternal, "the FPGA kernel did not write its results (status word " +
                                                         std::to_string(status) + "): the device did not compute");
      set_status(b, k, status_code(s));
      failures.add(k, std::move(s));
      continue;
    }
    // the kernel's words are the batch's Q16.16 values
    if (b.outputs & RBDGRAD_OUTPUT_QDD) std::copy_n(words, n1, static_cast<std::int32_t*>(b.qdd) + k * n1);
    if (b.outputs & RBDGRAD_OUTPUT_DQDD_DQ)
      std::copy_n(words + n1, n1 * n1, static_cast<std::int32_t*>(b.dqdd_dq) + k * n1 * n1);
    if (b.outputs & RBDGRAD_OUTPUT_DQDD_DQD)
      std::copy_n(words + n1 + n1 * n1, n1 * n1, static_cast<std::int32_t*>(b.dqdd_dqd) + k * n1 * n1);
    set_status(b, k, RBDGRAD_OK);
  }
}

}  // namespace rbdgrad::fpga
