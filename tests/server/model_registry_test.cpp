// Tests for server/model_registry.cpp.
#include "model_registry.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>

#include "rbdgrad/embedded_robots.hpp"

namespace rbdgrad::server {
namespace {

using ::testing::HasSubstr;
using ::testing::StartsWith;

ModelConfig embedded(const std::string& name, const std::string& robot) { return {name, "", robot, std::nullopt}; }

TEST(ModelRegistry, LoadsEmbeddedRobotsInOrderWithTheirDescriptions) {
  ModelRegistry registry;
  ModelConfig panda = embedded("arm", "panda");
  panda.gravity = std::array<double, 3>{0.0, 0.0, -1.62};
  const Status s = ModelRegistry::load({embedded("iiwa14", "iiwa14"), panda}, registry);
  ASSERT_TRUE(s.is_ok()) << s.to_string();
  ASSERT_EQ(registry.size(), 2u);
  EXPECT_EQ(registry.names(), "iiwa14, arm");

  const ServedModel* arm = registry.find("arm");
  ASSERT_NE(arm, nullptr);
  EXPECT_EQ(arm->index, 1u);
  EXPECT_EQ(arm->origin, "embedded panda");
  EXPECT_EQ(arm->source, "<embedded>");
  EXPECT_EQ(arm->model.name, "panda");
  EXPECT_EQ(arm->model.gravity.z(), -1.62);
  // the ABI description is the same model, and points into the registry's own storage
  EXPECT_EQ(arm->desc.desc().nv, static_cast<uint32_t>(arm->model.nv));
  EXPECT_EQ(arm->desc.desc().gravity[2], -1.62);
  EXPECT_THAT(arm->summary, StartsWith("model 'panda'"));

  EXPECT_EQ(registry.find("iiwa14")->model.nv, 7);
  EXPECT_EQ(registry.find("panda"), nullptr);  // only the served name counts
}

TEST(ModelRegistry, LoadsAUrdfFileEvenWhenNamedLikeAnEmbeddedRobot) {
  const std::filesystem::path dir = std::filesystem::temp_directory_path() /
                                    ("rbdgrad_model_registry_" + std::to_string(getpid()));
  std::filesystem::create_directories(dir);
  const std::filesystem::path file = dir / "arm.urdf";
  std::ofstream(file) << embedded_robot_urdf("iiwa14");

  ModelRegistry registry;
  Status s = ModelRegistry::load({{"arm", file.string(), "", std::nullopt}}, registry);
  ASSERT_TRUE(s.is_ok()) << s.to_string();
  EXPECT_EQ(registry.find("arm")->source, file.string());
  EXPECT_EQ(registry.find("arm")->origin, "urdf " + file.string());

  // "iiwa14" as a urdf path is a file in the working directory, which does not exist
  s = ModelRegistry::load({{"x", "iiwa14", "", std::nullopt}}, registry);
  EXPECT_EQ(s.code(), StatusCode::kNotFound);
  EXPECT_THAT(s.message(), StartsWith("model 'x': "));
  std::filesystem::remove_all(dir);
}

// A model with locked joints is served reduced (core lock_joints), its description too.
TEST(ModelRegistry, LocksTheConfiguredJoints) {
  ModelRegistry registry;
  ModelConfig wristless = embedded("wristless", "iiwa14");
  wristless.locked_joints = {{"iiwa_joint_6", 0.5}, {"iiwa_joint_7", -1.0}};
  ASSERT_TRUE(ModelRegistry::load({wristless}, registry).is_ok());
  const ServedModel* m = registry.find("wristless");
  ASSERT_NE(m, nullptr);
  EXPECT_EQ(m->model.nv, 5);
  EXPECT_EQ(m->desc.desc().nv, 5u);
  EXPECT_EQ(m->model.joints.back().name, "iiwa_joint_5");
  EXPECT_EQ(m->origin, "embedded iiwa14 with 2 joint(s) locked");
  // the wrist's mass now belongs to joint 5's body
  ModelRegistry full;
  ASSERT_TRUE(ModelRegistry::load({embedded("iiwa14", "iiwa14")}, full).is_ok());
  const Model& f = full.find("iiwa14")->model;
  EXPECT_NEAR(m->model.mass[4], f.mass[4] + f.mass[5] + f.mass[6], 1e-12);

  wristless.locked_joints = {{"wrist", 0.0}};
  const Status s = ModelRegistry::load({wristless}, registry);
  EXPECT_EQ(s.code(), StatusCode::kInvalidArgument);
  EXPECT_EQ(s.message(), "model 'wristless': locked joint 'wrist': model 'iiwa14' has no such joint");
}

TEST(ModelRegistry, ErrorsNameTheModelAndKeepTheOldContents) {
  ModelRegistry registry;
  ASSERT_TRUE(ModelRegistry::load({embedded("iiwa14", "iiwa14")}, registry).is_ok());

  Status s = ModelRegistry::load({embedded("a", "no_such_robot")}, registry);
  EXPECT_EQ(s.code(), StatusCode::kNotFound);
  EXPECT_EQ(s.message(), "model 'a': 'no_such_robot' is not an embedded robot (hyq, iiwa14, panda, talos_reduced)");

  s = ModelRegistry::load({{"b", "/nonexistent/robot.urdf", "", std::nullopt}}, registry);
  EXPECT_EQ(s.code(), StatusCode::kNotFound);
  EXPECT_THAT(s.message(), StartsWith("model 'b': "));
  EXPECT_THAT(s.message(), HasSubstr("/nonexistent/robot.urdf"));

  s = ModelRegistry::load({embedded("a", "iiwa14"), embedded("a", "panda")}, registry);
  EXPECT_EQ(s.code(), StatusCode::kInvalidArgument);
  EXPECT_EQ(s.message(), "model name 'a' is used twice");

  EXPECT_EQ(ModelRegistry::load({}, registry).code(), StatusCode::kInvalidArgument);
  EXPECT_EQ(ModelRegistry::load({{"c", "", "", std::nullopt}}, registry).code(), StatusCode::kInvalidArgument);

  // failed loads left the registry as it was
  EXPECT_EQ(registry.names(), "iiwa14");
}

TEST(ModelRegistry, RegisteredScenesAreAppendedInTheirKeptPlaces) {
  ModelRegistry registry;
  ASSERT_TRUE(ModelRegistry::load({embedded("iiwa14", "iiwa14")}, {}, registry, 2).is_ok());
  EXPECT_EQ(registry.size(), 1u);
  EXPECT_EQ(registry.capacity(), 3u);
  const ServedModel* iiwa = registry.find("iiwa14");
  SceneConfig cfg;
  cfg.model = "iiwa14";
  for (const char* name : {"a", "b", "c"}) {
    cfg.name = name;
    std::unique_ptr<const ServedModel> scene;
    ASSERT_TRUE(registry.make_served_scene(cfg, registry.size(), scene).is_ok());
    const Status s = registry.append(std::move(scene));
    // the third has no place: the registry never grows past what load kept
    EXPECT_EQ(s.is_ok(), cfg.name != "c") << s.to_string();
  }
  EXPECT_EQ(registry.size(), 3u);
  EXPECT_EQ(registry.registered(), 2u);
  EXPECT_EQ(registry.find("iiwa14"), iiwa) << "a model never moves";
  ASSERT_NE(registry.find_scene("b"), nullptr);
  EXPECT_EQ(registry.find_scene("b")->index, 2u);
  EXPECT_EQ(registry.find("b"), nullptr) << "a scene is no model";
  EXPECT_EQ(registry.scene_names(), "a, b");

  // a scene made for another place is refused; so is one of an unknown model
  ASSERT_TRUE(ModelRegistry::load({embedded("iiwa14", "iiwa14")}, {}, registry, 2).is_ok());
  std::unique_ptr<const ServedModel> scene;
  ASSERT_TRUE(registry.make_served_scene(cfg, 2, scene).is_ok());
  EXPECT_EQ(registry.append(std::move(scene)).code(), StatusCode::kFailedPrecondition);
  cfg.model = "panda";
  const Status s = registry.make_served_scene(cfg, 1, scene);
  EXPECT_EQ(s.code(), StatusCode::kNotFound);
  EXPECT_EQ(s.message(), "scene 'c': model 'panda' is not configured (models: iiwa14)");
}

}  // namespace
}  // namespace rbdgrad::server
