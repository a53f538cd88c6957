// Scenes registered while the daemon serves (RegisterScene, issue 8). A definition is checked as a
// configured scene's (ModelRegistry::make_served_scene: make_scene's checks, the same messages),
// each ready backend creates its instances with the scene's plan (BackendPool::add_model, the
// start-up's code path), the scheduler gets its latency models (Scheduler::calibrate_model, the
// start-up's rules), and only then is the scene published in the registry, where requests find
// it. Registrations run one at a time; requests on every other model and scene go on meanwhile.
// A scene stays until the daemon stops: unregistering would have to wait for every request,
// queued batch and split share that holds its model or pools, which nothing counts today.
#pragma once

#include <cstddef>
#include <functional>
#include <mutex>
#include <string>

#include "backend_pool.hpp"
#include "config.hpp"
#include "model_registry.hpp"
#include "scheduler.hpp"
#include "rbdgrad/status.hpp"

namespace rbdgrad::server {

enum class RegistrationOutcome {
  kRegistered,         // a new scene, now served
  kAlreadyRegistered,  // a scene of that name and the same definition was served already: unchanged
  kRefused,            // `status` says why: invalid_argument, not_found (the model), failed_precondition
  kNameTaken,          // a model has the name, or a scene defined otherwise (ALREADY_EXISTS)
  kLimitReached,       // limits.max_registered_scenes scenes are registered (RESOURCE_EXHAUSTED)
};

struct SceneRegistration {
  RegistrationOutcome outcome = RegistrationOutcome::kRefused;
  Status status;                       // the reason when not registered (its code for kRefused)
  const ServedModel* scene = nullptr;  // the scene served under the name, when registered (either way)
};

class SceneRegistrar {
 public:
  /// `models`, `backends` and `scheduler` must outlive the registrar; `models` holds places for
  /// at least `max_registered` scenes (ModelRegistry::load's `registered`).
  SceneRegistrar(ModelRegistry& models, BackendPool& backends, Scheduler& scheduler, std::size_t max_registered)
      : models_(models), backends_(backends), scheduler_(scheduler), max_registered_(max_registered) {}

  /// Registers the scene `cfg` (see the file's comment), or says why not. Blocks while the
  /// backends create their instances and the scheduler calibrates the scene (with calibrate
  /// "start" and nothing in the calibration file: the sweep of calibration_sizes on each backend).
  /// Each step is reported through `log`, a line each (which backend cannot serve it, each latency
  /// model). Thread-safe: a second registration waits for the first.
  SceneRegistration register_scene(const SceneConfig& cfg, const std::function<void(const std::string&)>& log);

 private:
  ModelRegistry& models_;
  BackendPool& backends_;
  Scheduler& scheduler_;
  const std::size_t max_registered_;
  std::mutex registering_;  // one registration at a time
};

}  // namespace rbdgrad::server
