#include "scene_registrar.hpp"

#include <memory>
#include <utility>

#include "scene.hpp"

namespace rbdgrad::server {

SceneRegistration SceneRegistrar::register_scene(const SceneConfig& cfg,
                                                 const std::function<void(const std::string&)>& log) {
  std::lock_guard lock(registering_);
  SceneRegistration out;
  const std::string where = "scene '" + cfg.name + "'";
  if (cfg.name.empty()) {
    out.status = invalid_argument("a scene needs a name");
    return out;
  }
  // the name: a model's is taken; a scene's is the same scene when defined the same way
  if (models_.find(cfg.name) != nullptr) {
    out.outcome = RegistrationOutcome::kNameTaken;
    out.status = failed_precondition(where + ": '" + cfg.name + "' is the name of a model (models: " +
                                     models_.names() + ")");
    return out;
  }
  if (const ServedModel* existing = models_.find_scene(cfg.name)) {
    const std::string differences = scene_differences(*existing->scene, cfg);
    if (differences.empty()) {
      out.outcome = RegistrationOutcome::kAlreadyRegistered;
      out.scene = existing;
      return out;
    }
    out.outcome = RegistrationOutcome::kNameTaken;
    out.status = failed_precondition(where + " is served already, defined otherwise: " + differences);
    return out;
  }
  if (models_.registered() >= max_registered_) {
    out.outcome = RegistrationOutcome::kLimitReached;
    out.status = failed_precondition(where + ": " + std::to_string(models_.registered()) +
                                     " scenes are registered already (limits.max_registered_scenes = " +
                                     std::to_string(max_registered_) + ")");
    return out;
  }

  // checked and made as a configured scene, in the next place
  std::unique_ptr<const ServedModel> scene;
  if (Status s = models_.make_served_scene(cfg, models_.size(), scene); !s) {
    out.status = s;
    return out;
  }
  // its instances on every ready backend, as at start-up; a backend that cannot is reported
  std::string problems;
  for (const std::string& problem : backends_.add_model(*scene)) {
    log(where + ": " + problem);
    problems += (problems.empty() ? "" : "; ") + problem;
  }
  if (!backends_.serves(*scene)) {
    out.status = failed_precondition(where + ": no backend can serve it (" + problems + ")");
    return out;
  }
  for (const std::string& line : backends_.model_details(*scene)) log(where + " on " + line);
  // its latency models, while its pools are still idle: nothing can reach them before append
  scheduler_.calibrate_model(*scene, log);
  const ServedModel* published = scene.get();
  const std::string origin = scene->origin;
  if (Status s = models_.append(std::move(scene)); !s) {
    out.status = s;
    return out;
  }
  log(where + " registered (" + origin + "); " + std::to_string(models_.registered()) + " of " +
      std::to_string(max_registered_) + " registered scenes");
  out.outcome = RegistrationOutcome::kRegistered;
  out.scene = published;
  return out;
}

}  // namespace rbdgrad::server
