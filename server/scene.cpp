#include "scene.hpp"

#include <algorithm>
#include <array>
#include <charconv>
#include <cstring>
#include <set>

#include "rbdgrad/locked_joints.hpp"
#include "rbdgrad/plugin_api.h"
#include "request_batch.hpp"

namespace rbdgrad::server {
namespace {

namespace v1 = rbdgrad::v1;

struct NamedOutput {
  const char* name;
  std::uint32_t flag;
};
constexpr std::array<NamedOutput, 8> kOutputNames{{{"qdd", RBDGRAD_OUTPUT_QDD},
                                                   {"minv", RBDGRAD_OUTPUT_MINV},
                                                   {"dqdd_dq", RBDGRAD_OUTPUT_DQDD_DQ},
                                                   {"dqdd_dqd", RBDGRAD_OUTPUT_DQDD_DQD},
                                                   {"tau", RBDGRAD_OUTPUT_TAU},
                                                   {"dtau_dq", RBDGRAD_OUTPUT_DTAU_DQ},
                                                   {"dtau_dqd", RBDGRAD_OUTPUT_DTAU_DQD},
                                                   {"m", RBDGRAD_OUTPUT_M}}};

std::string joined(const std::vector<std::string>& names) {
  std::string out;
  for (const std::string& n : names) out += (out.empty() ? "" : ", ") + n;
  return out;
}

// "[text]"
std::string in_brackets(const std::string& text) {
  std::string out = "[";  // appended: g++ 12 warns falsely (-Wrestrict) on "[" + std::string
  out += text;
  out += "]";
  return out;
}

// "[a, b]"
std::string bracketed(const std::vector<std::string>& names) { return in_brackets(joined(names)); }

// "[head_1_joint=0, head_2_joint=0.1]", sorted by joint; each value in the shortest text that
// reads back as the same double, so that two definitions compare equal only when their values do
std::string locks_text(std::vector<std::pair<std::string, double>> locks) {
  std::sort(locks.begin(), locks.end());
  std::vector<std::string> items;
  for (const auto& [joint, value] : locks) {
    char text[32];
    const auto end = std::to_chars(text, text + sizeof text, value).ptr;
    items.push_back(joint + "=" + std::string(text, end));
  }
  return bracketed(items);
}

}  // namespace

Status scene_config_from_request(const v1::RegisterSceneRequest& request, SceneConfig& out) {
  SceneConfig cfg;
  cfg.name = request.name();
  cfg.model = request.model();
  if (request.locked_joints_size() != request.locked_values_size())
    return invalid_argument("scene '" + cfg.name + "': locked_values has " +
                            std::to_string(request.locked_values_size()) + " value(s) for " +
                            std::to_string(request.locked_joints_size()) +
                            " locked_joints: one value per locked joint");
  for (int i = 0; i < request.locked_joints_size(); ++i)
    cfg.locked_joints.emplace_back(request.locked_joints(i), request.locked_values(i));
  cfg.gravity = !request.has_gravity() || request.gravity();
  cfg.force_links.assign(request.force_links().begin(), request.force_links().end());
  if (request.outputs_size() > 0) {
    cfg.outputs.clear();
    for (int i = 0; i < request.outputs_size(); ++i) {
      const int o = request.outputs(i);
      // OUTPUT_UNSPECIFIED, or a value this server does not know: make_scene names it unknown
      cfg.outputs.push_back(o >= 1 && o <= 8 ? std::string(output_name(1u << (o - 1)))
                            : v1::Output_IsValid(o) ? v1::Output_Name(static_cast<v1::Output>(o))
                                                    : std::to_string(o));
    }
  }
  cfg.minv = request.minv_supplied() ? "supplied" : "computed";
  out = std::move(cfg);
  return Status::ok();
}

std::string scene_differences(const SceneInfo& have, const SceneConfig& cfg) {
  std::vector<std::string> diffs;
  const auto differ = [&](const char* field, const std::string& registered, const std::string& asked) {
    if (registered != asked) diffs.push_back(std::string(field) + ": registered " + registered + ", asked " + asked);
  };
  differ("model", "'" + have.model + "'", "'" + cfg.model + "'");
  differ("locked_joints", locks_text(have.locked_joints), locks_text(cfg.locked_joints));
  differ("gravity", have.gravity ? "on" : "off", cfg.gravity ? "on" : "off");
  differ("force_links", bracketed(have.force_links), bracketed(cfg.force_links));
  // outputs as a set; a name that is no output differs from every scene's
  std::uint32_t asked = 0;
  bool known = true;
  for (const std::string& name : cfg.outputs) {
    std::uint32_t flag = 0;
    known = known && output_from_name(name, flag);
    asked |= flag;
  }
  differ("outputs", in_brackets(output_names(have.outputs)),
         known ? in_brackets(output_names(asked)) : bracketed(cfg.outputs));
  differ("minv", have.minv_supplied ? "supplied" : "computed", cfg.minv);
  std::string out;
  for (const std::string& d : diffs) out += (out.empty() ? "" : "; ") + d;
  return out;
}

bool output_from_name(std::string_view name, std::uint32_t& flag) {
  for (const NamedOutput& o : kOutputNames)
    if (name == o.name) {
      flag = o.flag;
      return true;
    }
  return false;
}

const char* output_name(std::uint32_t flag) {
  for (const NamedOutput& o : kOutputNames)
    if (flag == o.flag) return o.name;
  return "?";
}

std::string output_names(std::uint32_t outputs) {
  std::string out;
  for (const NamedOutput& o : kOutputNames)
    if (outputs & o.flag) out += (out.empty() ? "" : ", ") + std::string(o.name);
  return out;
}

Status make_scene(const SceneConfig& cfg, const Model& base, Model& model, SceneInfo& info) {
  const std::string where = "scene '" + cfg.name + "'";
  SceneInfo made;
  made.model = cfg.model;
  made.locked_joints = cfg.locked_joints;
  made.gravity = cfg.gravity;
  made.minv_supplied = cfg.minv == "supplied";
  for (const std::string& name : cfg.outputs) {
    std::uint32_t flag = 0;
    if (!output_from_name(name, flag))
      return invalid_argument(where + ": unknown output '" + name + "' (outputs: " + output_names(0xff) + ")");
    if (made.outputs & flag) return invalid_argument(where + ": output '" + name + "' is listed twice");
    made.outputs |= flag;
  }
  if (made.outputs == 0) return invalid_argument(where + ": no outputs: a scene computes at least one");

  Model reduced = base;
  if (!cfg.locked_joints.empty()) {
    std::vector<LockedJoint> locked;
    for (const auto& [joint, value] : cfg.locked_joints) locked.push_back({joint, value});
    if (Status s = lock_joints(base, locked, reduced); !s) return {s.code(), where + ": " + s.message()};
  }
  if (!cfg.gravity) reduced.gravity.setZero();

  // forces act on the scene's bodies, each named by the link its joint moves
  std::vector<std::string> links;
  for (const JointInfo& j : reduced.joints) links.push_back(j.child_link);
  std::set<std::string> seen;
  for (const std::string& link : cfg.force_links) {
    if (!seen.insert(link).second) return invalid_argument(where + ": force link '" + link + "' is listed twice");
    int body = -1;
    for (std::size_t i = 0; i < links.size(); ++i)
      if (links[i] == link) body = static_cast<int>(i);
    if (body < 0)
      return invalid_argument(where + ": force link '" + link +
                              "' is not moved by a joint of the scene (a locked or fixed link takes no force of its "
                              "own; links: " +
                              joined(links) + ")");
    made.force_links.push_back(link);
    made.force_bodies.push_back(body);
  }
  model = std::move(reduced);
  info = std::move(made);
  return Status::ok();
}

Status apply_scene(const SceneInfo& scene, const std::string& name, int nv, v1::ComputeRequest& request) {
  const std::string where = "scene '" + name + "'";
  if (!request.model().empty() && request.model() != scene.model)
    return invalid_argument(where + " is made from model '" + scene.model + "', but the request names model '" +
                            request.model() + "' (leave model empty or name the scene's)");
  // outputs: the scene's, or a subset of them
  if (request.outputs_size() == 0) {
    for (std::uint32_t flag = 1; flag <= RBDGRAD_OUTPUT_M; flag <<= 1)
      if (scene.outputs & flag) request.add_outputs(output_enum(flag));
  } else {
    for (int i = 0; i < request.outputs_size(); ++i) {
      const int o = request.outputs(i);
      // unknown values are RequestBatch's to refuse
      if (o < 1 || o > 8) continue;
      if (!(scene.outputs & (1u << (o - 1))))
        return invalid_argument(where + ": output " + output_name(1u << (o - 1)) + " is not one the scene computes (" +
                                output_names(scene.outputs) + ")");
    }
  }
  const bool has_minv = !request.minv().data().empty();
  if (scene.minv_supplied && !has_minv)
    return invalid_argument(where + " takes M^-1 from each request, and minv is empty");
  if (!scene.minv_supplied && has_minv)
    return invalid_argument(where + " computes M^-1 itself: minv must be empty (a scene with minv: supplied takes it)");

  // fext: the force links' forces, spread over every body
  const std::string& compact = request.fext().data();
  if (compact.empty()) return Status::ok();
  if (scene.force_links.empty())
    return invalid_argument(where + " has no force links: fext must be empty");
  const v1::ScalarType type = request.fext().type();
  if (type != v1::SCALAR_TYPE_F64 && type != v1::SCALAR_TYPE_F32)
    return invalid_argument(where + ": fext has type " + v1::ScalarType_Name(type) + ", not F64 or F32");
  const std::size_t scalar = type == v1::SCALAR_TYPE_F64 ? sizeof(double) : sizeof(float);
  const std::size_t n = request.num_states(), links = scene.force_links.size();
  const std::size_t per_link = 6 * scalar;
  if (compact.size() != n * links * per_link)
    return invalid_argument(where + ": fext holds " + std::to_string(compact.size() / scalar) +
                            " values; the scene takes " + std::to_string(n) + " states x " + std::to_string(links) +
                            " force links (" + joined(scene.force_links) + ") x 6 = " + std::to_string(n * links * 6));
  const auto bodies = static_cast<std::size_t>(nv);
  std::string full(n * bodies * per_link, '\0');  // zero bits are 0.0 in f64 and f32
  for (std::size_t k = 0; k < n; ++k)
    for (std::size_t l = 0; l < links; ++l) {
      const auto body = static_cast<std::size_t>(scene.force_bodies[l]);
      std::memcpy(full.data() + (k * bodies + body) * per_link, compact.data() + (k * links + l) * per_link, per_link);
    }
  request.mutable_fext()->set_data(std::move(full));
  return Status::ok();
}

}  // namespace rbdgrad::server
