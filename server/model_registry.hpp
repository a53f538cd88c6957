// The robot models the daemon serves: loaded once at start-up from the configuration (an embedded
// robot or a URDF file each, and the scenes made from them), immutable afterwards and shared by
// every request.
#pragma once

#include <cstddef>
#include <memory>
#include <optional>
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

  std::size_t index;     // position in the registry (= in the configuration): backends index by it
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
  /// Loads every configured model in order. An `embedded` name must be one of the robots compiled
  /// in; a `urdf` path is always read as a file (even when it equals an embedded name); gravity
  /// overrides the default (0, 0, -9.81). Fails on the first model that does not load, with the
  /// loader's code and a message naming the model: "model 'arm': ...". Duplicate or empty names
  /// and an empty list are invalid_argument. Then each scene, made from its model as served
  /// (make_scene); its name must differ from every model's and scene's. `out` is replaced only on
  /// success.
  static Status load(const std::vector<ModelConfig>& configs, const std::vector<SceneConfig>& scenes,
                     ModelRegistry& out);
  static Status load(const std::vector<ModelConfig>& configs, ModelRegistry& out) { return load(configs, {}, out); }

  /// The model called `name` (not a scene), or nullptr.
  const ServedModel* find(std::string_view name) const noexcept;
  /// The scene called `name`, or nullptr.
  const ServedModel* find_scene(std::string_view name) const noexcept;

  /// The models, then the scenes, in configuration order; index i holds the one with index i.
  const std::vector<std::unique_ptr<const ServedModel>>& models() const noexcept { return models_; }
  std::size_t size() const noexcept { return models_.size(); }

  /// "iiwa14, panda": the names, for messages about an unknown model.
  const std::string& names() const noexcept { return names_; }
  /// The scenes' names, the same way ("" when there are none).
  const std::string& scene_names() const noexcept { return scene_names_; }

 private:
  std::vector<std::unique_ptr<const ServedModel>> models_;
  std::string names_, scene_names_;
};

}  // namespace rbdgrad::server
