// One backend plugin's instance for one model, loaded through the plugin ABI as rbdgradd loads it:
// computes a StateSet in any precision the backend has (inputs converted from double, outputs back
// to double) and times batches of it.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "accuracy_states.hpp"
#include "gradients.hpp"
#include "plugin_loader.hpp"

namespace rbdgrad::bench {

class PluginRunner {
 public:
  /// Loads the plugin at `path` and creates its instance for `model` with `options`.
  /// Errors: the loader's and the plugin's (e.g. unavailable: no GPU), naming the path.
  static Status open(const std::string& path, const Model& model, const std::map<std::string, std::string>& options,
                     std::unique_ptr<PluginRunner>& out);

  const std::string& name() const noexcept { return plugin_->info().name; }
  std::uint32_t precisions() const noexcept { return plugin_->info().precisions; }
  /// How the instance runs ("csim" for the FPGA kernel's C simulation; "" as itself).
  const std::string& mode() const noexcept { return mode_; }

  /// q̈, ∂q̈/∂q and ∂q̈/∂q̇ of `states` from tau in `precision`. A state the backend flags (its
  /// state_status) is no error here; an error of the whole batch is.
  Status compute(const StateSet& states, std::uint32_t precision, Gradients& out);

  /// The median time of one call on `states`, in microseconds, over calls repeated for at least
  /// `min_seconds` (and at least 3, after one untimed call).
  Status time(const StateSet& states, std::uint32_t precision, double min_seconds, double& median_us);

  /// The plugin's own prediction of a batch of n (estimate_latency), in microseconds; unimplemented
  /// when it has none (it is then timed).
  Status model_us(std::uint32_t precision, std::uint64_t n, double& us) const;

 private:
  PluginRunner(std::unique_ptr<server::Plugin> plugin, std::unique_ptr<server::PluginInstance> instance, int nv)
      : plugin_(std::move(plugin)), instance_(std::move(instance)), nv_(nv) {}

  std::unique_ptr<server::Plugin> plugin_;
  std::unique_ptr<server::PluginInstance> instance_;
  int nv_;
  std::string mode_;
};

}  // namespace rbdgrad::bench
