#include "cpu_instance.hpp"

#include <algorithm>
#include <string>
#include <system_error>

#include "common/batch_view.hpp"
#include "common/error.hpp"

namespace rbdgrad::plugin {

CpuInstance::Worker::Worker(const CpuInstance& instance)
    : f64(instance.model_), f32(instance.model_f32_), fixed(instance.model_fixed_) {}

template <> StateEvaluator<double>& CpuInstance::Worker::get<double>() { return f64; }
template <> StateEvaluator<float>& CpuInstance::Worker::get<float>() { return f32; }
template <> StateEvaluator<Q16_16>& CpuInstance::Worker::get<Q16_16>() { return fixed; }

template <> const ModelTpl<double>& CpuInstance::model<double>() const { return model_; }
template <> const ModelTpl<float>& CpuInstance::model<float>() const { return model_f32_; }
template <> const ModelTpl<Q16_16>& CpuInstance::model<Q16_16>() const { return model_fixed_; }

CpuInstance::CpuInstance(const Model& model, std::size_t threads, std::chrono::microseconds idle_poll,
                         std::optional<BatchPlan> plan)
    : model_(model), plan_(std::move(plan)), model_f32_(model.cast<float>()), model_fixed_(model.cast<Q16_16>()),
      chunks_(std::max<std::size_t>(threads, 1)), pool_(threads, idle_poll) {
  for (std::size_t w = 0; w < pool_.size(); ++w) workers_.push_back(std::make_unique<Worker>(*this));
}

Status CpuInstance::create(const Model& model, std::size_t threads, std::unique_ptr<CpuInstance>& out,
                           std::chrono::microseconds idle_poll, std::optional<BatchPlan> plan) {
  try {
    out.reset(new CpuInstance(model, threads, idle_poll, std::move(plan)));
  } catch (const std::system_error& e) {
    return Status(StatusCode::kInternal, "cannot start " + std::to_string(threads) + " worker threads: " + e.what());
  }
  return Status::ok();
}

Status CpuInstance::compute(const rbdgrad_batch* batch) {
  if (Status s = validate_batch(batch, model_.nv, kAllPrecisions, kAllOutputs); !s) return s;
  if (plan_)
    if (Status s = check_batch_plan(*batch, *plan_); !s) return s;
  switch (batch->precision) {
    case RBDGRAD_PRECISION_F64: return compute_typed<double>(*batch);
    case RBDGRAD_PRECISION_F32: return compute_typed<float>(*batch);
    case RBDGRAD_PRECISION_FIXED_Q16_16: return compute_typed<Q16_16>(*batch);
  }
  return Status(StatusCode::kInternal, "validated batch with an unknown precision");
}

template <class S>
Status CpuInstance::compute_typed(const rbdgrad_batch& batch) {
  const BatchView<S> view(batch, model_.nv);
  const ModelTpl<S>& m = model<S>();
  const std::size_t n = batch.n;
  const std::size_t tasks = std::min(n, pool_.size());
  // chunk t holds states [t * base + min(t, extra), ...): sizes differ by one at most
  const std::size_t base = n / tasks, extra = n % tasks;
  // what the batch's outputs, fext and M^-1 need (and a scene's forces, on its bodies only): every
  // state runs the same specialized path
  const ExecutionPlan plan =
      plan_ ? plan_->execution_plan(StateEvaluator<S>::plan(m, batch)) : StateEvaluator<S>::plan(m, batch);
  pool_.run(tasks, [&](std::size_t task, std::size_t worker) {
    ChunkResult& result = chunks_[task];
    result.failures = 0;
    StateEvaluator<S>& evaluator = workers_[worker]->template get<S>();
    const std::size_t begin = task * base + std::min(task, extra);
    const std::size_t end = begin + base + (task < extra ? 1 : 0);
    for (std::size_t k = begin; k < end; ++k) {
      Status s = evaluator.evaluate(m, view, k, plan);
      view.set_status(k, s ? 0 : static_cast<std::int32_t>(state_error_code(s.code(), batch.precision)));
      if (!s && result.failures++ == 0) {
        result.first_failed = k;
        result.status = std::move(s);
      }
    }
  });

  // chunks are contiguous and in state order: the first chunk with a failure has the first failure
  std::size_t failures = 0;
  const ChunkResult* first = nullptr;
  for (std::size_t t = 0; t < tasks; ++t) {
    failures += chunks_[t].failures;
    if (!first && chunks_[t].failures > 0) first = &chunks_[t];
  }
  if (first == nullptr) return Status::ok();
  std::string message = "state " + std::to_string(first->first_failed) + ": " + first->status.message();
  if (failures > 1) message += " (and " + std::to_string(failures - 1) + " more failed states, see state_status)";
  return Status(first->status.code(), std::move(message));
}

}  // namespace rbdgrad::plugin
