// Tests for server/backend_pool.cpp: loading (the real CPU plugin, the fake "cuda" backend, a
// missing plugin) and the routing of requests by backend hint and precision.
#include "backend_pool.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <filesystem>
#include <string>

namespace rbdgrad::server {
namespace {

using ::testing::HasSubstr;
using ::testing::StartsWith;

const char* kMissingFpga = "/nonexistent/librbdgrad_fpga.so";

class BackendPoolTest : public ::testing::Test {
 protected:
  void SetUp() override {
    ASSERT_TRUE(ModelRegistry::load({{"iiwa14", "", "iiwa14", std::nullopt, {}}, {"hyq", "", "hyq", std::nullopt, {}}},
                                    models_).is_ok());
  }

  std::unique_ptr<BackendPool> make(std::vector<PluginConfig> plugins, std::string cpu = RBDGRAD_CPU_PLUGIN_PATH) {
    BackendPool::Options options;
    options.cpu_plugin_path = std::move(cpu);
    options.plugins = std::move(plugins);
    options.workers = 2;
    return BackendPool::create(options, models_);
  }

  const BackendState* state(const BackendPool& pool, const std::string& name) {
    for (const BackendState& s : pool.backends()) {
      if (s.name == name) return &s;
    }
    return nullptr;
  }

  ModelRegistry models_;
};

TEST_F(BackendPoolTest, LoadsTheConfiguredPluginsAndTheCpuBackendRecordingFailures) {
  auto pool = make({{FAKE_CUDA_PATH, {{"device", "0"}}, 0, ""}, {kMissingFpga, {}, 0, ""}});
  ASSERT_EQ(pool->backends().size(), 3u);
  EXPECT_EQ(pool->ready_count(), 2u);

  const BackendState* cpu = state(*pool, "cpu");
  ASSERT_NE(cpu, nullptr);
  EXPECT_TRUE(cpu->ready);
  EXPECT_EQ(cpu->path, RBDGRAD_CPU_PLUGIN_PATH);
  EXPECT_EQ(cpu->options, "threads=2");  // from workers
  EXPECT_EQ(cpu->info.precisions, 7u);

  const BackendState* cuda = state(*pool, "cuda");
  ASSERT_NE(cuda, nullptr);
  EXPECT_TRUE(cuda->ready);
  EXPECT_EQ(cuda->options, "device=0");  // no threads: that is the CPU backend's

  const BackendState* fpga = state(*pool, "fpga");  // named after the file
  ASSERT_NE(fpga, nullptr);
  EXPECT_FALSE(fpga->ready);
  EXPECT_THAT(fpga->reason, StartsWith(std::string("plugin ") + kMissingFpga + ": cannot load"));
}

// One library under two names (a backend per GPU): two backends of kind "cuda"; a route names
// either, or the kind (the first that serves the model).
TEST_F(BackendPoolTest, OneLibraryUnderTwoNamesIsTwoBackendsOfOneKind) {
  PluginConfig gpu0{FAKE_CUDA_PATH, {{"device", "0"}}, 0, ""};
  gpu0.name = "cuda0";
  PluginConfig gpu1{FAKE_CUDA_PATH, {{"device", "1"}}, 0, ""};
  gpu1.name = "cuda1";
  gpu1.instances = 2;
  auto pool = make({gpu0, gpu1, {kMissingFpga, {}, 0, "fpga7"}});
  ASSERT_EQ(pool->backends().size(), 4u);
  EXPECT_EQ(pool->ready_count(), 3u);
  const BackendState* first = state(*pool, "cuda0");
  const BackendState* second = state(*pool, "cuda1");
  ASSERT_NE(first, nullptr);
  ASSERT_NE(second, nullptr);
  EXPECT_TRUE(first->ready && second->ready);
  EXPECT_EQ(first->kind, "cuda");
  EXPECT_EQ(second->kind, "cuda");
  EXPECT_EQ(second->options, "device=1");
  EXPECT_EQ(second->instances_per_model, 2u);
  EXPECT_EQ(state(*pool, "cpu")->kind, "cpu");
  const BackendState* fpga = state(*pool, "fpga7");  // a configured name, also when it fails
  ASSERT_NE(fpga, nullptr);
  EXPECT_EQ(fpga->kind, "fpga");
  EXPECT_FALSE(fpga->ready);

  const ServedModel& iiwa = *models_.find("iiwa14");
  EXPECT_NE(pool->pool("cuda0", iiwa), pool->pool("cuda1", iiwa));
  EXPECT_EQ(pool->pool("cuda", iiwa), nullptr) << "pools go by name";
  EXPECT_EQ(pool->resolve("cuda"), (std::vector<std::string>{"cuda0", "cuda1"}));
  EXPECT_EQ(pool->resolve("cuda1"), (std::vector<std::string>{"cuda1"}));
  EXPECT_TRUE(pool->resolve("fpga").empty());
  Route route;
  ASSERT_TRUE(pool->route(iiwa, "cuda1", RBDGRAD_PRECISION_F64, route).is_ok());
  EXPECT_EQ(route.backend->name, "cuda1");
  EXPECT_EQ(route.pool->size(), 2u);
  ASSERT_TRUE(pool->route(iiwa, "cuda", 0, route).is_ok());
  EXPECT_EQ(route.backend->name, "cuda0");
  const Status none = pool->route(iiwa, "fpga", 0, route);
  EXPECT_EQ(none.code(), StatusCode::kUnavailable);
  EXPECT_THAT(none.message(), HasSubstr("cannot load"));
}

TEST_F(BackendPoolTest, APluginEntrySetsItsInstancesPerModel) {
  PluginConfig cuda{FAKE_CUDA_PATH, {}, 0, ""};
  cuda.instances = 3;
  auto pool = make({cuda});
  const BackendState* fake = state(*pool, "cuda");
  ASSERT_NE(fake, nullptr);
  ASSERT_TRUE(fake->ready) << fake->reason;
  EXPECT_EQ(fake->instances_per_model, 3u);
  EXPECT_EQ(state(*pool, "cpu")->instances_per_model, 1u) << "the others keep the default";
  Route route;
  ASSERT_TRUE(pool->route(*models_.find("iiwa14"), "cuda", RBDGRAD_PRECISION_F64, route).is_ok());
  EXPECT_EQ(route.pool->size(), 3u);
}

TEST_F(BackendPoolTest, RoutesAutoToCpuAndResolvesAutoPrecisionToF64) {
  auto pool = make({{FAKE_CUDA_PATH, {}, 0, ""}});
  Route route;
  ASSERT_TRUE(pool->route(*models_.find("hyq"), "", 0, route).is_ok());
  EXPECT_EQ(route.backend->name, "cpu");
  EXPECT_EQ(route.precision, RBDGRAD_PRECISION_F64);
  EXPECT_NE(route.pool, nullptr);

  ASSERT_TRUE(pool->route(*models_.find("hyq"), "cpu", RBDGRAD_PRECISION_FIXED_Q16_16, route).is_ok());
  EXPECT_EQ(route.precision, RBDGRAD_PRECISION_FIXED_Q16_16);

  Route cuda;
  ASSERT_TRUE(pool->route(*models_.find("iiwa14"), "cuda", RBDGRAD_PRECISION_F32, cuda).is_ok());
  EXPECT_EQ(cuda.backend->name, "cuda");
  EXPECT_EQ(cuda.precision, RBDGRAD_PRECISION_F32);
  // one pool per (model, backend)
  Route cuda_hyq;
  ASSERT_TRUE(pool->route(*models_.find("hyq"), "cuda", 0, cuda_hyq).is_ok());
  EXPECT_NE(cuda.pool, cuda_hyq.pool);
}

TEST_F(BackendPoolTest, RefusesAPrecisionTheHintedBackendLacks) {
  auto pool = make({{FAKE_CUDA_PATH, {}, 0, ""}});
  Route route;
  const Status s = pool->route(*models_.find("iiwa14"), "cuda", RBDGRAD_PRECISION_FIXED_Q16_16, route);
  EXPECT_EQ(s.code(), StatusCode::kInvalidArgument);
  EXPECT_EQ(s.message(), "backend cuda does not support precision fixed (it supports f64, f32)");
}

TEST_F(BackendPoolTest, AMissingBackendIsUnavailableWithTheReason) {
  auto pool = make({{kMissingFpga, {}, 0, ""}});
  Route route;
  Status s = pool->route(*models_.find("iiwa14"), "cuda", 0, route);
  EXPECT_EQ(s.code(), StatusCode::kUnavailable);
  EXPECT_EQ(s.message(), "backend cuda is not available: not configured");

  s = pool->route(*models_.find("iiwa14"), "fpga", 0, route);
  EXPECT_EQ(s.code(), StatusCode::kUnavailable);
  EXPECT_THAT(s.message(),
              StartsWith(std::string("backend fpga is not available: plugin ") + kMissingFpga + ": cannot load:"));
}

// A scene registered while serving (add_model): every ready backend makes its instances as at
// start-up, and one that cannot serve it (the fake takes at most 8 joints) is reported as then.
TEST_F(BackendPoolTest, AModelAddedLaterGetsInstancesOnEveryReadyBackendThatCanServeIt) {
  ASSERT_TRUE(ModelRegistry::load({{"iiwa14", "", "iiwa14", std::nullopt, {}}, {"hyq", "", "hyq", std::nullopt, {}}},
                                  {}, models_, 2)
                  .is_ok());
  auto pool = make({{FAKE_OK_PATH, {}, 0, ""}, {kMissingFpga, {}, 0, ""}});
  const BackendState* fake = state(*pool, "fake");
  ASSERT_NE(fake, nullptr);
  ASSERT_EQ(fake->model_problems.size(), 1u);  // hyq, at start-up

  SceneConfig cfg;
  cfg.name = "arm";
  cfg.model = "iiwa14";
  std::unique_ptr<const ServedModel> arm;
  ASSERT_TRUE(models_.make_served_scene(cfg, models_.size(), arm).is_ok());
  EXPECT_EQ(pool->pool("cpu", *arm), nullptr) << "nothing before add_model";
  EXPECT_TRUE(pool->add_model(*arm).empty());
  EXPECT_NE(pool->pool("cpu", *arm), nullptr);
  EXPECT_NE(pool->pool("fake", *arm), nullptr);
  ASSERT_TRUE(models_.append(std::move(arm)).is_ok());

  cfg.name = "legs";
  cfg.model = "hyq";
  std::unique_ptr<const ServedModel> legs;
  ASSERT_TRUE(models_.make_served_scene(cfg, models_.size(), legs).is_ok());
  const std::vector<std::string> problems = pool->add_model(*legs);
  ASSERT_EQ(problems.size(), 1u);
  EXPECT_EQ(problems[0], "backend fake: the model has nv 12, the backend takes at most 8");
  ASSERT_EQ(fake->model_problems.size(), 2u);
  EXPECT_EQ(fake->model_problems[1], "model 'legs': the model has nv 12, the backend takes at most 8");
  EXPECT_TRUE(pool->serves(*legs));
  EXPECT_EQ(pool->pool("fake", *legs), nullptr);
  Route route;
  const Status s = pool->route(*legs, "fake", 0, route);
  EXPECT_EQ(s.code(), StatusCode::kUnavailable);
  EXPECT_EQ(s.message(),
            "backend fake is not available for model 'legs': the model has nv 12, the backend takes at most 8");
  ASSERT_TRUE(pool->route(*legs, "", 0, route).is_ok());
  EXPECT_EQ(route.backend->name, "cpu");
}

// The start-up line shows what a backend's first instance says of how it runs; the instances of
// the other models say it where it differs (a scene's CUDA kernel with its stages fixed).
TEST_F(BackendPoolTest, EachModelsInstancesSayHowTheyRunWhereTheyDifferFromTheFirst) {
  auto pool = make({{FAKE_CUDA_PATH, {{"device", "0"}}, 0, ""}});
  const BackendState* cuda = state(*pool, "cuda");
  ASSERT_NE(cuda, nullptr);
  EXPECT_EQ(cuda->description.detail, "kernel for nv 7");  // iiwa14's, the first model
  EXPECT_TRUE(pool->model_details(*models_.find("iiwa14")).empty());
  EXPECT_THAT(pool->model_details(*models_.find("hyq")), ::testing::ElementsAre("backend cuda: kernel for nv 12"));
}

TEST_F(BackendPoolTest, ABackendThatCannotCreateInstancesIsUnavailableNamingTheModel) {
  auto pool = make({{FAKE_CUDA_PATH, {{"bogus", "1"}}, 0, ""}});
  const BackendState* cuda = state(*pool, "cuda");
  ASSERT_NE(cuda, nullptr);
  EXPECT_FALSE(cuda->ready);
  EXPECT_THAT(cuda->reason, HasSubstr("unknown option 'bogus'"));
  ASSERT_EQ(cuda->model_problems.size(), 2u);
  EXPECT_EQ(cuda->model_problems[0], "model 'iiwa14': cuda: unknown option 'bogus'");

  Route route;
  const Status s = pool->route(*models_.find("iiwa14"), "cuda", 0, route);
  EXPECT_EQ(s.code(), StatusCode::kUnavailable);
  EXPECT_EQ(s.message(), "backend cuda is not available for model 'iiwa14': cuda: unknown option 'bogus'");
}

TEST_F(BackendPoolTest, AConfiguredCpuPluginReplacesTheBuiltInOne) {
  auto pool = make({{RBDGRAD_CPU_PLUGIN_PATH, {{"threads", "1"}}, 0, ""}}, "/nonexistent/librbdgrad_cpu.so");
  ASSERT_EQ(pool->backends().size(), 1u);  // the built-in path was never tried
  EXPECT_TRUE(pool->backends()[0].ready);
  EXPECT_EQ(pool->backends()[0].options, "threads=1");
}

TEST_F(BackendPoolTest, OptionalBuiltInPluginsLoadWhenPresentAndYieldToConfiguredOnes) {
  // the fake "cuda" backend under the built-in plugin's file name
  const std::filesystem::path dir = std::filesystem::temp_directory_path() /
                                    ("rbdgrad-backend-pool-" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  const std::filesystem::path cuda_path = dir / "librbdgrad_cuda.so";
  std::filesystem::copy_file(FAKE_CUDA_PATH, cuda_path, std::filesystem::copy_options::overwrite_existing);

  // the FPGA plugin is absent (a build without it): nothing is listed for it
  BackendPool::Options options;
  options.cpu_plugin_path = RBDGRAD_CPU_PLUGIN_PATH;
  options.optional_plugin_paths = {kMissingFpga, cuda_path.string()};
  options.workers = 2;
  auto pool = BackendPool::create(options, models_);
  EXPECT_EQ(state(*pool, "fpga"), nullptr);
  ASSERT_NE(state(*pool, "cuda"), nullptr);
  EXPECT_TRUE(state(*pool, "cuda")->ready) << state(*pool, "cuda")->reason;
  EXPECT_EQ(pool->backends().back().name, "cuda");  // after the CPU backend

  // a configured plugin named cuda, even one that fails to load, is not replaced
  options.plugins = {{"/nonexistent/librbdgrad_cuda.so", {}, 0, ""}};
  pool = BackendPool::create(options, models_);
  const auto cuda = std::count_if(pool->backends().begin(), pool->backends().end(),
                                  [](const BackendState& s) { return s.name == "cuda"; });
  EXPECT_EQ(cuda, 1);
  ASSERT_NE(state(*pool, "cuda"), nullptr);
  EXPECT_FALSE(state(*pool, "cuda")->ready);
  EXPECT_EQ(state(*pool, "cuda")->path, "/nonexistent/librbdgrad_cuda.so");
  pool.reset();
  std::filesystem::remove_all(dir);
}

TEST_F(BackendPoolTest, NothingReadyWithoutAnyLoadablePlugin) {
  auto pool = make({}, "/nonexistent/librbdgrad_cpu.so");
  EXPECT_EQ(pool->ready_count(), 0u);
  Route route;
  EXPECT_EQ(pool->route(*models_.find("iiwa14"), "", 0, route).code(), StatusCode::kUnavailable);
  EXPECT_THAT(pool->route(*models_.find("iiwa14"), "cpu", 0, route).message(),
              StartsWith("backend cpu is not available: plugin /nonexistent/librbdgrad_cpu.so: cannot load: "));
}

TEST(BackendNames, FromPathsAndPrecisionLists) {
  EXPECT_EQ(backend_name_from_path("/usr/lib/rbdgrad/librbdgrad_cuda.so"), "cuda");
  EXPECT_EQ(backend_name_from_path("librbdgrad_fpga.so.1"), "fpga");
  EXPECT_EQ(backend_name_from_path("/x/fake_thing.so"), "fake_thing");
  EXPECT_EQ(precision_list(RBDGRAD_PRECISION_F64 | RBDGRAD_PRECISION_F32), "f64, f32");
  EXPECT_EQ(precision_list(7), "f64, f32, fixed");
  EXPECT_EQ(precision_list(0), "none");
}

}  // namespace
}  // namespace rbdgrad::server
