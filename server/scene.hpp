// Scenes (issue 8): a configured model reduced for one fixed problem, registered at start-up and
// served as a model of its own. Locked joints are folded away (lock_joints), gravity may be off,
// only the named links receive external forces, and the scene says which outputs it computes and
// whether M^-1 comes with each request. A request that names the scene is turned into a request of
// the scene's model (apply_scene), so routing, batching and every backend treat it as any other.
#pragma once

#include <cstdint>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "config.hpp"
#include "rbdgrad/model.hpp"
#include "rbdgrad/status.hpp"
#include "rbdgrad/v1/dynamics.pb.h"

namespace rbdgrad::server {

struct SceneInfo {
  std::string model;                                         // the configured model it is made from
  std::vector<std::pair<std::string, double>> locked_joints;  // on top of the model's own
  bool gravity = true;
  std::vector<std::string> force_links;  // in the order of a request's fext
  std::vector<int> force_bodies;         // each force link's body in the scene's model
  std::uint32_t outputs = 0;             // rbdgrad_output flags
  bool minv_supplied = false;
};

/// The scene's model, made from `base` (the configured model's, as served), and its description.
/// Errors (invalid_argument, naming the scene and what is wrong): those of lock_joints (an unknown
/// joint, a value outside its limits, every joint locked), an unknown or repeated output, no
/// outputs, a force link that is not the child link of one of the scene's joints, or is named
/// twice.
Status make_scene(const SceneConfig& cfg, const Model& base, Model& model, SceneInfo& info);

/// Turns `request`, which names the scene `name` (whose model has nv joints), into a request of the
/// scene's model: the scene's outputs when it lists none, else each must be one of them; fext,
/// given for the force links only (N x links x 6), spread over every body with zeros elsewhere;
/// minv present exactly when the scene says it is supplied. Errors (invalid_argument) say which
/// field and why.
Status apply_scene(const SceneInfo& scene, const std::string& name, int nv, v1::ComputeRequest& request);

/// RegisterScene's request as a SceneConfig, so that a registered scene is checked as a configured
/// one (make_scene): unset gravity is on, no outputs are SceneConfig's default, an output value
/// the API does not have becomes a name make_scene refuses. invalid_argument when locked_values
/// does not give one value per locked joint.
Status scene_config_from_request(const v1::RegisterSceneRequest& request, SceneConfig& out);

/// What `cfg` defines otherwise than the scene `have` (made from a definition of the same name):
/// "gravity: registered on, asked off; force_links: registered [lf_foot], asked []", "" when the
/// definitions are the same. Locked joints compare as a set of (joint, value), outputs as a set;
/// force links in order (they are fext's order).
std::string scene_differences(const SceneInfo& have, const SceneConfig& cfg);

/// The output names of SceneConfig and GetScene ("dqdd_dq") and their flags.
bool output_from_name(std::string_view name, std::uint32_t& flag);
const char* output_name(std::uint32_t flag);
/// "dqdd_dq, dqdd_dqd": the names of the flags set in `outputs`, for messages.
std::string output_names(std::uint32_t outputs);

}  // namespace rbdgrad::server
