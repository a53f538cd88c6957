// Tests for server/scene.cpp and the registry's scenes: a scene's model and description from its
// configuration (and every bad scene refused, naming what is wrong), and a request that names a
// scene turned into a request of the scene's model.
#include "scene.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>

#include "model_registry.hpp"
#include "rbdgrad/locked_joints.hpp"
#include "rbdgrad/plugin_api.h"

namespace rbdgrad::server {
namespace {

using ::testing::HasSubstr;
namespace v1 = rbdgrad::v1;

ModelConfig embedded(const std::string& name, const std::string& robot) { return {name, "", robot, std::nullopt}; }

// the humanoid as the paper's 28-joint HRP-2 set-up: hands (grippers) and head locked
SceneConfig humanoid_scene() {
  SceneConfig s;
  s.name = "walk";
  s.model = "talos";
  s.locked_joints = {{"head_1_joint", 0.0}, {"head_2_joint", 0.1}, {"gripper_left_joint", 0.0}, {"gripper_right_joint", 0.0}};
  return s;
}

Status load_with(const SceneConfig& scene, ModelRegistry& registry) {
  return ModelRegistry::load({embedded("talos", "talos_reduced"), embedded("hyq", "hyq")}, {scene}, registry);
}

TEST(Scene, TheHumanoidWithHandsAndHeadLockedHas28Joints) {
  ModelRegistry registry;
  const Status s = load_with(humanoid_scene(), registry);
  ASSERT_TRUE(s.is_ok()) << s.to_string();
  const ServedModel* scene = registry.find_scene("walk");
  ASSERT_NE(scene, nullptr);
  ASSERT_TRUE(scene->scene);
  EXPECT_EQ(scene->model.nv, 28);
  EXPECT_EQ(scene->scene->model, "talos");
  EXPECT_EQ(scene->scene->outputs, static_cast<std::uint32_t>(RBDGRAD_OUTPUT_DQDD_DQ | RBDGRAD_OUTPUT_DQDD_DQD));
  EXPECT_EQ(scene->index, 2u) << "scenes follow the models";
  // the scene is no model, and the model no scene
  EXPECT_EQ(registry.find("walk"), nullptr);
  EXPECT_EQ(registry.find_scene("talos"), nullptr);
  EXPECT_EQ(registry.scene_names(), "walk");
  EXPECT_EQ(registry.names(), "talos, hyq");
  // the same reduction as lock_joints on the model
  Model reduced;
  std::vector<LockedJoint> locked;
  for (const auto& [j, v] : humanoid_scene().locked_joints) locked.push_back({j, v});
  ASSERT_TRUE(lock_joints(registry.find("talos")->model, locked, reduced).is_ok());
  ASSERT_EQ(reduced.nv, scene->model.nv);
  for (int i = 0; i < reduced.nv; ++i) {
    EXPECT_EQ(reduced.joints[i].name, scene->model.joints[i].name);
    EXPECT_EQ(reduced.mass[i], scene->model.mass[i]) << i;
  }
  EXPECT_EQ(scene->model.gravity, reduced.gravity);
}

TEST(Scene, GravityOffAndForceLinksOnTheQuadruped) {
  SceneConfig trot;
  trot.name = "trot";
  trot.model = "hyq";
  trot.gravity = false;
  trot.force_links = {"rh_lowerleg", "lf_lowerleg"};
  trot.outputs = {"dqdd_dq"};
  ModelRegistry registry;
  const Status s = load_with(trot, registry);
  ASSERT_TRUE(s.is_ok()) << s.to_string();
  const ServedModel* scene = registry.find_scene("trot");
  ASSERT_NE(scene, nullptr);
  EXPECT_EQ(scene->model.nv, 12);
  EXPECT_TRUE(scene->model.gravity.isZero());
  EXPECT_FALSE(registry.find("hyq")->model.gravity.isZero()) << "the model keeps its gravity";
  ASSERT_EQ(scene->scene->force_bodies.size(), 2u);
  EXPECT_EQ(scene->model.joints[scene->scene->force_bodies[0]].child_link, "rh_lowerleg");
  EXPECT_EQ(scene->model.joints[scene->scene->force_bodies[1]].child_link, "lf_lowerleg");
  EXPECT_EQ(scene->scene->outputs, static_cast<std::uint32_t>(RBDGRAD_OUTPUT_DQDD_DQ));
  // the backends get the scene's plan with its description (ABI 1.3): the force bodies ascending
  const rbdgrad_plan* plan = scene->desc.desc().plan;
  ASSERT_NE(plan, nullptr);
  EXPECT_EQ(plan->outputs, static_cast<std::uint32_t>(RBDGRAD_OUTPUT_DQDD_DQ));
  EXPECT_EQ(plan->minv_supplied, 0u);
  ASSERT_EQ(plan->fext_body_count, 2u);
  const int first_body = std::min(scene->scene->force_bodies[0], scene->scene->force_bodies[1]);
  EXPECT_EQ(plan->fext_bodies[0], static_cast<std::uint32_t>(first_body));
  EXPECT_LT(plan->fext_bodies[0], plan->fext_bodies[1]);
  EXPECT_EQ(registry.find("hyq")->desc.desc().plan, nullptr) << "a model has no plan";
}

// Every bad scene is refused with the scene's name and the reason.
TEST(Scene, BadScenesAreRefused) {
  const auto refused = [](SceneConfig scene, const std::string& why) {
    ModelRegistry registry;
    const Status s = load_with(scene, registry);
    EXPECT_FALSE(s.is_ok()) << why;
    EXPECT_THAT(s.message(), HasSubstr("scene '" + scene.name + "'")) << why;
    EXPECT_THAT(s.message(), HasSubstr(why));
  };
  SceneConfig s = humanoid_scene();
  s.locked_joints.push_back({"elbow", 0.0});
  refused(s, "elbow");
  s = humanoid_scene();
  s.locked_joints[0].second = 10.0;  // far outside the head's limits
  refused(s, "head_1_joint");
  s = humanoid_scene();
  s.model = "hyq";
  s.locked_joints.clear();
  for (const char* leg : {"lf", "rf", "lh", "rh"})
    for (const char* j : {"haa", "hfe", "kfe"}) {  // within the limits: front knees bend back, hind forward
      const double knee = leg[1] == 'f' ? -1.0 : 1.0;
      s.locked_joints.push_back({std::string(leg) + "_" + j + "_joint", std::string(j) == "kfe" ? knee : 0.0});
    }
  refused(s, "locking every joint");
  s = humanoid_scene();
  s.outputs = {"dqdd_dq", "jacobian"};
  refused(s, "unknown output 'jacobian'");
  s.outputs = {};
  refused(s, "no outputs");
  s.outputs = {"qdd", "qdd"};
  refused(s, "listed twice");
  s = humanoid_scene();
  s.force_links = {"no_such_link"};
  refused(s, "force link 'no_such_link' is not moved by a joint of the scene");
  s.force_links = {"head_2_link"};  // locked: folded into the torso
  refused(s, "force link 'head_2_link'");
  s = humanoid_scene();
  s.model = "atlas";
  refused(s, "model 'atlas' is not configured");
  // a scene's name is no model's
  ModelRegistry registry;
  s = humanoid_scene();
  s.name = "hyq";
  EXPECT_THAT(load_with(s, registry).message(), HasSubstr("'hyq' is used twice"));
}

// --- apply_scene -------------------------------------------------------------------------------

SceneInfo forces_on(std::vector<int> bodies) {
  SceneInfo info;
  info.model = "hyq";
  info.outputs = RBDGRAD_OUTPUT_DQDD_DQ | RBDGRAD_OUTPUT_QDD;
  for (int b : bodies) {
    info.force_links.push_back("link" + std::to_string(b));
    info.force_bodies.push_back(b);
  }
  return info;
}

template <class S>
void set(v1::Tensor* t, const std::vector<S>& values) {
  t->set_type(sizeof(S) == 8 ? v1::SCALAR_TYPE_F64 : v1::SCALAR_TYPE_F32);
  t->set_data(std::string(reinterpret_cast<const char*>(values.data()), values.size() * sizeof(S)));
}

template <class S>
std::vector<S> values(const v1::Tensor& t) {
  std::vector<S> out(t.data().size() / sizeof(S));
  std::memcpy(out.data(), t.data().data(), t.data().size());
  return out;
}

TEST(Scene, ARegisterSceneRequestIsReadAsAConfiguredScene) {
  v1::RegisterSceneRequest req;
  req.set_name("walk");
  req.set_model("talos");
  SceneConfig cfg;
  ASSERT_TRUE(scene_config_from_request(req, cfg).is_ok());
  // unset gravity is on, no outputs are the configured default
  EXPECT_EQ(cfg, (SceneConfig{"walk", "talos", {}, true, {}, {"dqdd_dq", "dqdd_dqd"}, "computed"}));
  req.add_locked_joints("head_1_joint");
  req.add_locked_values(0.5);
  req.set_gravity(false);
  req.add_force_links("leg_left_6_link");
  req.add_outputs(v1::OUTPUT_QDD);
  req.add_outputs(v1::OUTPUT_UNSPECIFIED);
  req.set_minv_supplied(true);
  ASSERT_TRUE(scene_config_from_request(req, cfg).is_ok());
  EXPECT_EQ(cfg, (SceneConfig{"walk", "talos", {{"head_1_joint", 0.5}}, false, {"leg_left_6_link"},
                              {"qdd", "OUTPUT_UNSPECIFIED"}, "supplied"}));
  // which make_scene refuses, as in a configuration
  ModelRegistry registry;
  Status s = load_with(cfg, registry);
  EXPECT_EQ(s.code(), StatusCode::kInvalidArgument);
  EXPECT_THAT(s.message(), HasSubstr("scene 'walk': unknown output 'OUTPUT_UNSPECIFIED'"));

  req.add_locked_joints("head_2_joint");
  s = scene_config_from_request(req, cfg);
  EXPECT_EQ(s.code(), StatusCode::kInvalidArgument);
  EXPECT_EQ(s.message(), "scene 'walk': locked_values has 1 value(s) for 2 locked_joints: one value per locked joint");
}

TEST(Scene, DifferencesNameEachFieldThatDiffers) {
  ModelRegistry registry;
  ASSERT_TRUE(load_with(humanoid_scene(), registry).is_ok());
  const SceneInfo& have = *registry.find_scene("walk")->scene;
  SceneConfig same = humanoid_scene();
  EXPECT_EQ(scene_differences(have, same), "");
  // the locks as a set, the outputs as a set
  std::reverse(same.locked_joints.begin(), same.locked_joints.end());
  std::reverse(same.outputs.begin(), same.outputs.end());
  EXPECT_EQ(scene_differences(have, same), "");

  SceneConfig other = humanoid_scene();
  other.locked_joints[1].second = 0.2;
  other.gravity = false;
  other.force_links = {"leg_left_6_link"};
  other.outputs = {"qdd"};
  other.minv = "supplied";
  EXPECT_EQ(scene_differences(have, other),
            "locked_joints: registered [gripper_left_joint=0, gripper_right_joint=0, head_1_joint=0, "
            "head_2_joint=0.1], asked [gripper_left_joint=0, gripper_right_joint=0, head_1_joint=0, "
            "head_2_joint=0.2]; "
            "gravity: registered on, asked off; force_links: registered [], asked [leg_left_6_link]; "
            "outputs: registered [dqdd_dq, dqdd_dqd], asked [qdd]; minv: registered computed, asked supplied");
  other = humanoid_scene();
  other.model = "hyq";
  EXPECT_EQ(scene_differences(have, other), "model: registered 'talos', asked 'hyq'");
  // a lock value that differs in its last bits is another definition, and says so in full
  other = humanoid_scene();
  other.locked_joints[1].second = std::nextafter(0.1, 1.0);
  EXPECT_EQ(scene_differences(have, other),
            "locked_joints: registered [gripper_left_joint=0, gripper_right_joint=0, head_1_joint=0, "
            "head_2_joint=0.1], asked [gripper_left_joint=0, gripper_right_joint=0, head_1_joint=0, "
            "head_2_joint=0.10000000000000002]");
}

TEST(ApplyScene, TheScenesOutputsWhenNoneAreListedElseASubset) {
  const SceneInfo scene = forces_on({});
  v1::ComputeRequest r;
  r.set_num_states(1);
  ASSERT_TRUE(apply_scene(scene, "s", 12, r).is_ok());
  ASSERT_EQ(r.outputs_size(), 2);
  EXPECT_EQ(r.outputs(0), v1::OUTPUT_QDD);
  EXPECT_EQ(r.outputs(1), v1::OUTPUT_DQDD_DQ);
  r.clear_outputs();
  r.add_outputs(v1::OUTPUT_DQDD_DQ);
  ASSERT_TRUE(apply_scene(scene, "s", 12, r).is_ok());
  EXPECT_EQ(r.outputs_size(), 1);
  r.add_outputs(v1::OUTPUT_DQDD_DQD);
  const Status s = apply_scene(scene, "s", 12, r);
  EXPECT_THAT(s.message(), HasSubstr("scene 's': output dqdd_dqd is not one the scene computes (qdd, dqdd_dq)"));
}

TEST(ApplyScene, MinvIsThereExactlyWhenTheSceneSaysSupplied) {
  SceneInfo scene = forces_on({});
  v1::ComputeRequest r;
  r.set_num_states(1);
  set<double>(r.mutable_minv(), std::vector<double>(144, 1.0));
  EXPECT_THAT(apply_scene(scene, "s", 12, r).message(), HasSubstr("computes M^-1 itself: minv must be empty"));
  scene.minv_supplied = true;
  EXPECT_TRUE(apply_scene(scene, "s", 12, r).is_ok());
  r.clear_minv();
  EXPECT_THAT(apply_scene(scene, "s", 12, r).message(), HasSubstr("takes M^-1 from each request, and minv is empty"));
}

TEST(ApplyScene, TheRequestsModelIsEmptyOrTheScenes) {
  v1::ComputeRequest r;
  r.set_num_states(1);
  r.set_model("hyq");
  EXPECT_TRUE(apply_scene(forces_on({}), "s", 12, r).is_ok());
  r.set_model("iiwa14");
  EXPECT_THAT(apply_scene(forces_on({}), "s", 12, r).message(),
              HasSubstr("scene 's' is made from model 'hyq', but the request names model 'iiwa14'"));
}

template <class S>
void check_spread() {
  // 2 states, forces on bodies 5 and 2 (in that order) of 6
  const SceneInfo scene = forces_on({5, 2});
  v1::ComputeRequest r;
  r.set_num_states(2);
  std::vector<S> compact(2 * 2 * 6);
  for (std::size_t e = 0; e < compact.size(); ++e) compact[e] = static_cast<S>(e + 1);
  set<S>(r.mutable_fext(), compact);
  ASSERT_TRUE(apply_scene(scene, "s", 6, r).is_ok());
  const std::vector<S> full = values<S>(r.fext());
  ASSERT_EQ(full.size(), 2u * 6 * 6);
  for (std::size_t k = 0; k < 2; ++k)
    for (std::size_t b = 0; b < 6; ++b)
      for (std::size_t c = 0; c < 6; ++c) {
        const S got = full[(k * 6 + b) * 6 + c];
        const S want = b == 5 ? compact[(k * 2 + 0) * 6 + c] : b == 2 ? compact[(k * 2 + 1) * 6 + c] : S(0);
        EXPECT_EQ(got, want) << "state " << k << " body " << b << " component " << c;
      }
}

TEST(ApplyScene, ForcesOnTheForceLinksAreSpreadOverEveryBody) {
  check_spread<double>();
  check_spread<float>();
}

TEST(ApplyScene, BadForcesAreRefused) {
  v1::ComputeRequest r;
  r.set_num_states(2);
  set<double>(r.mutable_fext(), std::vector<double>(2 * 6 * 6, 0.0));  // every body's: not this scene's shape
  EXPECT_THAT(apply_scene(forces_on({5, 2}), "s", 6, r).message(),
              HasSubstr("fext holds 72 values; the scene takes 2 states x 2 force links (link5, link2) x 6 = 24"));
  EXPECT_THAT(apply_scene(forces_on({}), "s", 6, r).message(), HasSubstr("scene 's' has no force links: fext must be empty"));
  r.mutable_fext()->set_type(v1::SCALAR_TYPE_UNSPECIFIED);
  EXPECT_THAT(apply_scene(forces_on({5, 2}), "s", 6, r).message(), HasSubstr("fext has type SCALAR_TYPE_UNSPECIFIED"));
}

}  // namespace
}  // namespace rbdgrad::server
