// Loading the configured models (rbdgrad::cli::load_model does the embedded/URDF lookup).
#include "model_registry.hpp"

#include <Eigen/Core>
#include <algorithm>
#include <optional>
#include <set>
#include <utility>

#include "model_source.hpp"
#include "rbdgrad/embedded_robots.hpp"
#include "rbdgrad/locked_joints.hpp"

namespace rbdgrad::server {

ServedModel::ServedModel(std::size_t index_in, std::string name_in, std::string origin_in, std::string source_in,
                         Model model_in, std::optional<SceneInfo> scene_in)
    : index(index_in),
      name(std::move(name_in)),
      origin(std::move(origin_in)),
      source(std::move(source_in)),
      model(std::move(model_in)),
      desc(model),
      summary(model_summary(model)),
      scene(std::move(scene_in)) {
  // a scene's backends get its plan (ABI 1.3) and may build code without what it excludes
  if (scene) {
    std::vector<std::uint32_t> bodies(scene->force_bodies.begin(), scene->force_bodies.end());
    std::sort(bodies.begin(), bodies.end());
    desc.set_plan(scene->outputs, scene->minv_supplied, std::move(bodies));
  }
}

namespace {

Status load_one(const ModelConfig& cfg, std::size_t index, std::unique_ptr<const ServedModel>& out) {
  const std::string where = "model '" + cfg.name + "'";
  std::optional<Eigen::Vector3d> gravity;
  if (cfg.gravity) gravity = Eigen::Vector3d((*cfg.gravity)[0], (*cfg.gravity)[1], (*cfg.gravity)[2]);

  std::string spec;
  std::string origin;
  std::string source = "<embedded>";
  if (!cfg.embedded.empty()) {
    // load_model would fall back to a file of that name: an embedded source must be embedded
    if (embedded_robot_urdf(cfg.embedded).empty()) {
      return not_found(where + ": '" + cfg.embedded + "' is not an embedded robot (" + cli::embedded_robot_list() +
                       ")");
    }
    spec = cfg.embedded;
    origin = "embedded " + cfg.embedded;
  } else if (!cfg.urdf.empty()) {
    // and a path must be a file, even one called "iiwa14"
    spec = cfg.urdf;
    if (!embedded_robot_urdf(spec).empty()) spec = "./" + spec;
    origin = "urdf " + cfg.urdf;
    source = cfg.urdf;
  } else {
    return invalid_argument(where + " needs exactly one of 'urdf' or 'embedded'");
  }

  Model model;
  if (Status s = cli::load_model(spec, gravity, model); !s) return {s.code(), where + ": " + s.message()};
  if (!cfg.locked_joints.empty()) {
    std::vector<LockedJoint> locked;
    for (const auto& [joint, value] : cfg.locked_joints) locked.push_back({joint, value});
    Model reduced;
    if (Status s = lock_joints(model, locked, reduced); !s) return {s.code(), where + ": " + s.message()};
    model = std::move(reduced);
    origin += " with " + std::to_string(locked.size()) + " joint(s) locked";
  }
  out = std::make_unique<const ServedModel>(index, cfg.name, std::move(origin), std::move(source), std::move(model));
  return Status::ok();
}

}  // namespace

ModelRegistry& ModelRegistry::operator=(ModelRegistry&& other) noexcept {
  models_ = std::move(other.models_);
  size_.store(other.size_.load());
  loaded_ = other.loaded_;
  names_ = std::move(other.names_);
  other.size_.store(0);
  other.loaded_ = 0;
  return *this;
}

Status ModelRegistry::load(const std::vector<ModelConfig>& configs, const std::vector<SceneConfig>& scenes,
                           ModelRegistry& out, std::size_t registered) {
  if (configs.empty()) return invalid_argument("no models configured: the daemon needs at least one");
  ModelRegistry loaded;
  std::set<std::string> names;
  for (std::size_t i = 0; i < configs.size(); ++i) {
    const ModelConfig& cfg = configs[i];
    if (cfg.name.empty()) return invalid_argument("models[" + std::to_string(i) + "] has no name");
    if (!names.insert(cfg.name).second) return invalid_argument("model name '" + cfg.name + "' is used twice");
    std::unique_ptr<const ServedModel> model;
    if (Status s = load_one(cfg, i, model); !s) return s;
    if (!loaded.names_.empty()) loaded.names_ += ", ";
    loaded.names_ += cfg.name;
    loaded.models_.push_back(std::move(model));
    loaded.size_.store(loaded.models_.size());
  }
  for (const SceneConfig& cfg : scenes) {
    if (cfg.name.empty()) return invalid_argument("a scene has no name");
    if (!names.insert(cfg.name).second)
      return invalid_argument("scene name '" + cfg.name + "' is used twice, or by a model");
    std::unique_ptr<const ServedModel> scene;
    if (Status s = loaded.make_served_scene(cfg, loaded.models_.size(), scene); !s) return s;
    loaded.models_.push_back(std::move(scene));
    loaded.size_.store(loaded.models_.size());
  }
  // the places of the scenes registered later: the vector never grows again, so readers may walk it
  loaded.loaded_ = loaded.models_.size();
  loaded.models_.resize(loaded.loaded_ + registered);
  out = std::move(loaded);
  return Status::ok();
}

Status ModelRegistry::make_served_scene(const SceneConfig& cfg, std::size_t index,
                                        std::unique_ptr<const ServedModel>& out) const {
  const ServedModel* base = find(cfg.model);
  if (base == nullptr)
    return not_found("scene '" + cfg.name + "': model '" + cfg.model + "' is not configured (models: " + names_ + ")");
  Model model;
  SceneInfo info;
  if (Status s = make_scene(cfg, base->model, model, info); !s) return s;
  const std::string origin = "scene of " + cfg.model + ", " + std::to_string(model.nv) + " of " +
                             std::to_string(base->model.nv) + " joints";
  out = std::make_unique<const ServedModel>(index, cfg.name, origin, base->source, std::move(model), std::move(info));
  return Status::ok();
}

Status ModelRegistry::append(std::unique_ptr<const ServedModel> model) {
  std::lock_guard lock(append_);
  const std::size_t n = size_.load(std::memory_order_relaxed);
  if (n >= models_.size()) return failed_precondition("no place left for model '" + model->name + "'");
  if (model->index != n)
    return failed_precondition("model '" + model->name + "' was made for place " + std::to_string(model->index) +
                               ", the next is " + std::to_string(n));
  models_[n] = std::move(model);
  // readers that see the new size see the model, and whatever was made for it before (its pools)
  size_.store(n + 1, std::memory_order_release);
  return Status::ok();
}

const ServedModel* ModelRegistry::find(std::string_view name) const noexcept {
  // a handful of models: a linear scan beats hashing the name
  for (const auto& m : models()) {
    if (!m->scene && m->name == name) return m.get();
  }
  return nullptr;
}

const ServedModel* ModelRegistry::find_scene(std::string_view name) const noexcept {
  for (const auto& m : models()) {
    if (m->scene && m->name == name) return m.get();
  }
  return nullptr;
}

std::string ModelRegistry::scene_names() const {
  std::string out;
  for (const auto& m : models())
    if (m->scene) out += (out.empty() ? "" : ", ") + m->name;
  return out;
}

}  // namespace rbdgrad::server
