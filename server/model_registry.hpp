// The robot models the daemon serves: loaded at start-up from the configuration (an embedded
// robot or a URDF file each, and the scenes made from them) and shared by every request. Scenes
// registered at run time (RegisterScene, scene_registrar.hpp) are appended while requests are
// served: a loaded model never moves or changes, and readers find models without a lock.
#pragma once

#include <atomic>
#include <cstddef>
#include <memory>
#include <mutex>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "common/model_desc.hpp"
#include "config.hpp"
#include "rbdgrad/model.hpp"
#include "scene.hpp"
#include "rbdgrad/status.hpp"

namespace rbdgrad::server {

// One served model. Never moves once loaded (the registry holds it by pointer), so the plugin
// description's arrays stay where the backends' instances were created from.
struct ServedModel {
  ServedModel(std::size_t index_in, std::string name_in, std::string origin_in, std::string source_in,
              Model model_in, std::optional<SceneInfo> scene_in = std::nullopt);

  std::size_t index;     // position in the registry (configuration order, then registration order):
                         // backends index by it
  std::string name;      // the name clients use (ModelConfig::name); may differ from model.name
  std::string origin;    // "embedded iiwa14" or "urdf /path/robot.urdf", for logs
  std::string source;    // "<embedded>" or the URDF path, for ListModels
  Model model;           // the core model; model.joints gives GetModel its joint table
  plugin::ModelDesc desc;  // the same model as the plugin ABI describes it (points into desc's own arrays)
  std::string summary;   // model_summary(model): multi-line, for logs and GetModel
  std::optional<SceneInfo> scene;  // set for a scene: requests name it by ComputeRequest.scene
};

class ModelRegistry {
 public:
  ModelRegistry() = default;
  // only before the registry is shared (the daemon moves a loaded one into place)
  ModelRegistry(ModelRegistry&& other) noexcept { *this = std::move(other); }
  ModelRegistry& operator=(ModelRegistry&& other) noexcept;

  /// Loads every configured model in order. An `embedded` name must be one of the robots compiled
  /// in; a `urdf` path is always read as a file (even when it equals an embedded name); gravity
  /// overrides the default (0, 0, -9.81). Fails on the first model that does not load, with the
  /// loader's code and a message naming the model: "model 'arm': ...". Duplicate or empty names
  /// and an empty list are invalid_argument. Then each scene, made from its model as served
  /// (make_served_scene); its name must differ from every model's and scene's. `registered`
  /// places are kept for scenes registered later (append). `out` is replaced only on success.
  static Status load(const std::vector<ModelConfig>& configs, const std::vector<SceneConfig>& scenes,
                     ModelRegistry& out, std::size_t registered = 0);
  static Status load(const std::vector<ModelConfig>& configs, ModelRegistry& out) { return load(configs, {}, out); }

  /// A scene made from `cfg`, to be served at `index` (not added): its model must be one of the
  /// registry's models (not_found "scene 's': model 'm' is not configured (models: ...)"), then
  /// make_scene's checks (invalid_argument naming the scene and the field). Thread-safe.
  Status make_served_scene(const SceneConfig& cfg, std::size_t index, std::unique_ptr<const ServedModel>& out) const;

  /// Publishes `model` (its index must be size()) to every reader. One caller at a time (the
  /// scene registrar); readers run meanwhile. failed_precondition when every place is taken.
  Status append(std::unique_ptr<const ServedModel> model);

  /// The model called `name` (not a scene), or nullptr. Thread-safe, lock-free.
  const ServedModel* find(std::string_view name) const noexcept;
  /// The scene called `name`, or nullptr. Thread-safe, lock-free.
  const ServedModel* find_scene(std::string_view name) const noexcept;

  /// The models, then the scenes, in configuration then registration order; index i holds the one
  /// with index i. A snapshot: a scene registered later is not in it, and each entry stays valid.
  std::span<const std::unique_ptr<const ServedModel>> models() const noexcept {
    return {models_.data(), size_.load(std::memory_order_acquire)};
  }
  std::size_t size() const noexcept { return size_.load(std::memory_order_acquire); }
  /// How many models and scenes the registry can hold: what was loaded plus the places kept for
  /// registered scenes. Backends size their per-model tables by it.
  std::size_t capacity() const noexcept { return models_.size(); }
  /// The scenes registered at run time (append) so far.
  std::size_t registered() const noexcept { return size() - loaded_; }

  /// "iiwa14, panda": the names of the models (scenes are never models), for messages about an
  /// unknown model.
  const std::string& names() const noexcept { return names_; }
  /// The scenes' names, the same way ("" when there are none).
  std::string scene_names() const;

 private:
  // (capacity) the published ones first, then empty places; never reallocated once loaded
  std::vector<std::unique_ptr<const ServedModel>> models_;
  std::atomic<std::size_t> size_{0};  // published; release on append, acquire by readers
  std::size_t loaded_ = 0;            // from the configuration
  std::string names_;
  std::mutex append_;  // one writer at a time
};

}  // namespace rbdgrad::server
