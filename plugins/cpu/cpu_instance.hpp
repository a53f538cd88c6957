// One model on the CPU backend: the model in the three scalar types, one set of workspaces per
// worker thread and precision (all sized here, so compute never allocates), and the thread pool.
#pragma once

#include <chrono>
#include <cstddef>
#include <memory>
#include <optional>
#include <vector>

#include "common/batch_plan.hpp"
#include "rbdgrad/model.hpp"
#include "rbdgrad/plugin_api.h"
#include "rbdgrad/status.hpp"
#include "state_evaluator.hpp"
#include "thread_pool.hpp"

namespace rbdgrad::plugin {

class CpuInstance {
 public:
  /// \param[in] model a validated model (model_from_desc), cast here once to f32 and Q16.16.
  /// \param[in] threads workers, the calling thread included (>= 1).
  /// \param[out] out set on success; errors: thread creation failure (internal).
  /// \param[in] idle_poll how long idle workers poll for the next batch before sleeping (ThreadPool).
  /// \param[in] plan what every batch computes (a scene's), checked by plan_from_desc; none = each
  /// batch's own.
  static Status create(const Model& model, std::size_t threads, std::unique_ptr<CpuInstance>& out,
                       std::chrono::microseconds idle_poll = ThreadPool::kDefaultIdlePoll,
                       std::optional<BatchPlan> plan = std::nullopt);

  /// Validates `batch` (validate_batch, and check_batch_plan under a plan) and computes it: the states are split into contiguous chunks,
  /// one per worker. Every state is attempted; state_status says which failed, and the error names
  /// the first of them: "state 3: fd_derivatives: result is not finite (NaN or Inf)".
  /// Not reentrant (the ABI never calls compute concurrently on one instance).
  Status compute(const rbdgrad_batch* batch);

  std::size_t threads() const { return pool_.size(); }
  int nv() const { return model_.nv; }

 private:
  // one worker's evaluators, one per precision
  struct Worker {
    explicit Worker(const CpuInstance& instance);
    template <class S> StateEvaluator<S>& get();
    StateEvaluator<double> f64;
    StateEvaluator<float> f32;
    StateEvaluator<Q16_16> fixed;
  };
  // the outcome of one chunk of states; on its own cache line, as workers write them concurrently
  struct alignas(64) ChunkResult {
    std::size_t failures = 0;
    std::size_t first_failed = 0;
    Status status;  // of first_failed
  };

  CpuInstance(const Model& model, std::size_t threads, std::chrono::microseconds idle_poll,
              std::optional<BatchPlan> plan);
  template <class S> const ModelTpl<S>& model() const;
  template <class S> Status compute_typed(const rbdgrad_batch& batch);

  Model model_;
  std::optional<BatchPlan> plan_;  // a scene's: its force bodies are the only ones read
  ModelTpl<float> model_f32_;
  ModelTpl<Q16_16> model_fixed_;
  std::vector<std::unique_ptr<Worker>> workers_;  // (threads) separate allocations: no shared cache lines
  std::vector<ChunkResult> chunks_;               // (threads) at most one chunk per worker
  ThreadPool pool_;                               // last: its threads stop before the rest goes
};

}  // namespace rbdgrad::plugin
