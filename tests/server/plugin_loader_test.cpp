// Tests for server/plugin_loader.cpp, against the fake backends in tests/server/fakes/.
#include <dlfcn.h>
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <memory>
#include <string>
#include <vector>

#include "plugin_loader.hpp"

namespace rbdgrad::server {
namespace {

// this host's plugin API version, as the loader's messages write it
const std::string kHostApi =
    std::to_string(RBDGRAD_PLUGIN_API_MAJOR) + "." + std::to_string(RBDGRAD_PLUGIN_API_MINOR);

using ::testing::HasSubstr;
using ::testing::StartsWith;

constexpr uint32_t kNv = 2;

// the fake reads only nv
rbdgrad_model_desc two_joint_model() {
  rbdgrad_model_desc model{};
  model.struct_size = sizeof(model);
  model.name = "two";
  model.nv = kNv;
  return model;
}

// An f64 qdd batch of n states with its own buffers; state_status starts at -1 (untouched).
struct F64Batch {
  explicit F64Batch(uint64_t n)
      : q(n * kNv, 0.0), qd(n * kNv, 0.0), u(n * kNv, 0.0), qdd(n * kNv, 0.0), state_status(n, -1) {
    raw.struct_size = sizeof(raw);
    raw.n = n;
    raw.precision = RBDGRAD_PRECISION_F64;
    raw.input_kind = RBDGRAD_INPUT_TAU;
    raw.outputs = RBDGRAD_OUTPUT_QDD;
    raw.q = q.data();
    raw.qd = qd.data();
    raw.u = u.data();
    raw.qdd = qdd.data();
    raw.state_status = state_status.data();
  }
  F64Batch(const F64Batch&) = delete;  // raw points into this object's vectors

  std::vector<double> q, qd, u, qdd;
  std::vector<int32_t> state_status;
  rbdgrad_batch raw{};
};

// Whether the library at path is loaded in this process. RTLD_NOLOAD never loads it by itself; the
// handle it returns holds a reference, given back at once.
bool is_loaded(const char* path) {
  void* handle = dlopen(path, RTLD_NOW | RTLD_NOLOAD);
  if (handle != nullptr) dlclose(handle);
  return handle != nullptr;
}

// The fake's error counters, through a second handle on the already loaded library.
struct ErrorCounts {
  int made = -1;
  int deleted = -1;
};
ErrorCounts fake_error_counts() {
  ErrorCounts counts;
  void* handle = dlopen(FAKE_OK_PATH, RTLD_NOW | RTLD_NOLOAD);
  if (handle == nullptr) return counts;
  using CountsFn = void (*)(int*, int*);
  if (auto fn = reinterpret_cast<CountsFn>(dlsym(handle, "fake_ok_error_counts"))) fn(&counts.made, &counts.deleted);
  dlclose(handle);
  return counts;
}

std::unique_ptr<Plugin> load_fake() {
  std::unique_ptr<Plugin> plugin;
  const Status status = Plugin::load(FAKE_OK_PATH, plugin);
  EXPECT_TRUE(status.is_ok()) << status.to_string();
  return plugin;
}

std::unique_ptr<PluginInstance> fake_instance(const Plugin& plugin) {
  std::unique_ptr<PluginInstance> instance;
  const Status status = plugin.create_instance(two_joint_model(), {{"threads", "2"}}, instance);
  EXPECT_TRUE(status.is_ok()) << status.to_string();
  return instance;
}

// --- loading a valid plugin ---

TEST(Plugin, LoadsAValidPluginAndCopiesItsInfo) {
  const std::unique_ptr<Plugin> plugin = load_fake();
  ASSERT_NE(plugin, nullptr);
  const PluginInfo& info = plugin->info();
  EXPECT_EQ(info.name, "fake");
  EXPECT_EQ(info.version, "0.1.0");
  EXPECT_EQ(info.precisions, uint32_t{RBDGRAD_PRECISION_F64});
  EXPECT_EQ(info.outputs, uint32_t{RBDGRAD_OUTPUT_QDD});
  EXPECT_EQ(info.max_batch, 1000u);
  EXPECT_EQ(info.max_nv, 8u);
  EXPECT_EQ(info.api_major, uint32_t{RBDGRAD_PLUGIN_API_MAJOR});
  EXPECT_EQ(info.api_minor, uint32_t{RBDGRAD_PLUGIN_API_MINOR});
  EXPECT_EQ(plugin->path(), FAKE_OK_PATH);
}

TEST(Plugin, ComputeFillsTheCallersBuffers) {
  const std::unique_ptr<Plugin> plugin = load_fake();
  ASSERT_NE(plugin, nullptr);
  const std::unique_ptr<PluginInstance> instance = fake_instance(*plugin);
  ASSERT_NE(instance, nullptr);
  F64Batch batch(2);
  const Status status = instance->compute(batch.raw);
  EXPECT_TRUE(status.is_ok()) << status.to_string();
  EXPECT_EQ(batch.qdd, std::vector<double>(2 * kNv, 1.0));
}

TEST(Plugin, ComputeErrorBecomesOutOfRangeNamingPluginAndStateAndIsFreed) {
  const std::unique_ptr<Plugin> plugin = load_fake();
  ASSERT_NE(plugin, nullptr);
  const std::unique_ptr<PluginInstance> instance = fake_instance(*plugin);
  ASSERT_NE(instance, nullptr);
  const ErrorCounts before = fake_error_counts();
  F64Batch batch(3);
  const Status status = instance->compute(batch.raw);
  EXPECT_EQ(status.code(), StatusCode::kOutOfRange);
  EXPECT_EQ(status.message(), "fake: state 2: boom");
  // the other states are computed, and state_status says which failed
  EXPECT_EQ(batch.qdd, std::vector<double>(3 * kNv, 1.0));
  EXPECT_EQ(batch.state_status[2], RBDGRAD_ERROR_NUMERICAL);
  const ErrorCounts after = fake_error_counts();
  EXPECT_EQ(after.made, before.made + 1);
  EXPECT_EQ(after.deleted, before.deleted + 1);
}

// every code the ABI defines, and one it does not (6, as a later minor might add), through the one
// conversion
TEST(Plugin, MapsEveryPluginErrorCodeAndFreesTheError) {
  const std::unique_ptr<Plugin> plugin = load_fake();
  ASSERT_NE(plugin, nullptr);
  const std::unique_ptr<PluginInstance> instance = fake_instance(*plugin);
  ASSERT_NE(instance, nullptr);
  const struct {
    int plugin_code;
    StatusCode expected;
  } cases[] = {
      {RBDGRAD_ERROR_INVALID_ARGUMENT, StatusCode::kInvalidArgument},
      {RBDGRAD_ERROR_UNSUPPORTED, StatusCode::kUnimplemented},
      {RBDGRAD_ERROR_NUMERICAL, StatusCode::kOutOfRange},
      {RBDGRAD_ERROR_UNAVAILABLE, StatusCode::kUnavailable},
      {RBDGRAD_ERROR_INTERNAL, StatusCode::kInternal},
      {RBDGRAD_ERROR_OUT_OF_RANGE, StatusCode::kOutOfRange},
      {7, StatusCode::kInternal},
  };
  for (const auto& c : cases) {
    const ErrorCounts before = fake_error_counts();
    F64Batch batch(100 + c.plugin_code);  // the fake's script: fail with code n - 100
    const Status status = instance->compute(batch.raw);
    EXPECT_EQ(status.code(), c.expected) << "plugin code " << c.plugin_code;
    EXPECT_THAT(status.message(), StartsWith("fake: scripted"));
    EXPECT_EQ(fake_error_counts().deleted, before.deleted + 1) << "plugin code " << c.plugin_code;
  }
}

TEST(Plugin, UnknownErrorCodeIsKeptInTheMessage) {
  const std::unique_ptr<Plugin> plugin = load_fake();
  ASSERT_NE(plugin, nullptr);
  const std::unique_ptr<PluginInstance> instance = fake_instance(*plugin);
  ASSERT_NE(instance, nullptr);
  F64Batch batch(107);
  EXPECT_EQ(instance->compute(batch.raw).message(), "fake: scripted (unknown plugin error code 7)");
}

TEST(Plugin, CanRunPassesOnThePluginsAnswer) {
  const std::unique_ptr<Plugin> plugin = load_fake();
  ASSERT_NE(plugin, nullptr);
  const rbdgrad_model_desc model = two_joint_model();
  EXPECT_TRUE(plugin->can_run(model, RBDGRAD_PRECISION_F64, RBDGRAD_OUTPUT_QDD, 16).is_ok());
  const Status no = plugin->can_run(model, RBDGRAD_PRECISION_F32, RBDGRAD_OUTPUT_QDD, 16);
  EXPECT_EQ(no.code(), StatusCode::kUnimplemented);
  EXPECT_EQ(no.message(), "fake: f64 only");
}

TEST(Plugin, CreateInstancePassesOptionsAndReportsUnknownOnes) {
  const std::unique_ptr<Plugin> plugin = load_fake();
  ASSERT_NE(plugin, nullptr);
  std::unique_ptr<PluginInstance> instance;
  EXPECT_TRUE(plugin->create_instance(two_joint_model(), {}, instance).is_ok());
  EXPECT_NE(instance, nullptr);
  std::unique_ptr<PluginInstance> refused;
  const Status status = plugin->create_instance(two_joint_model(), {{"threads", "2"}, {"bogus", "1"}}, refused);
  EXPECT_EQ(status.code(), StatusCode::kInvalidArgument);
  EXPECT_EQ(status.message(), "fake: unknown option 'bogus'");
  EXPECT_EQ(refused, nullptr);
  const ErrorCounts counts = fake_error_counts();
  EXPECT_EQ(counts.made, counts.deleted);
}

// --- lifetime ---

TEST(Plugin, InstanceOutlivingThePluginKeepsTheLibraryLoaded) {
  std::unique_ptr<Plugin> plugin = load_fake();
  ASSERT_NE(plugin, nullptr);
  std::unique_ptr<PluginInstance> instance = fake_instance(*plugin);
  ASSERT_NE(instance, nullptr);
  plugin.reset();
  EXPECT_TRUE(is_loaded(FAKE_OK_PATH));
  F64Batch batch(1);
  EXPECT_TRUE(instance->compute(batch.raw).is_ok());
  EXPECT_EQ(batch.qdd, std::vector<double>(kNv, 1.0));
  // the last owner gone, the library is closed
  instance.reset();
  EXPECT_FALSE(is_loaded(FAKE_OK_PATH));
}

TEST(Plugin, MovedInstanceComputesAndTheMovedFromOneRefuses) {
  const std::unique_ptr<Plugin> plugin = load_fake();
  ASSERT_NE(plugin, nullptr);
  std::unique_ptr<PluginInstance> first = fake_instance(*plugin);
  ASSERT_NE(first, nullptr);
  PluginInstance second = std::move(*first);
  F64Batch batch(1);
  EXPECT_TRUE(second.compute(batch.raw).is_ok());
  EXPECT_EQ(first->compute(batch.raw).code(), StatusCode::kFailedPrecondition);
  // move-assigning over a live instance destroys it first (the fake's delete; ASan would see a leak)
  std::unique_ptr<PluginInstance> third = fake_instance(*plugin);
  ASSERT_NE(third, nullptr);
  second = std::move(*third);
  EXPECT_TRUE(second.compute(batch.raw).is_ok());
}

// --- broken plugins are refused with a reason, and closed again ---

Status load_expecting_failure(const char* path) {
  std::unique_ptr<Plugin> plugin;
  Status status = Plugin::load(path, plugin);
  EXPECT_FALSE(status.is_ok()) << path;
  EXPECT_EQ(plugin, nullptr) << path;
  EXPECT_FALSE(is_loaded(path)) << path;
  return status;
}

TEST(Plugin, RefusesATableOfAnotherMajorNamingBothVersions) {
  const Status status = load_expecting_failure(FAKE_WRONG_MAJOR_PATH);
  EXPECT_EQ(status.code(), StatusCode::kFailedPrecondition);
  EXPECT_EQ(status.message(), std::string("plugin ") + FAKE_WRONG_MAJOR_PATH +
                                  " is built for plugin API 99.0, host plugin API is " + kHostApi + " (the majors must match)");
}

TEST(Plugin, ReportsAPluginThatRefusesTheHost) {
  const Status status = load_expecting_failure(FAKE_REFUSES_PATH);
  EXPECT_EQ(status.code(), StatusCode::kFailedPrecondition);
  EXPECT_EQ(status.message(),
            std::string("plugin ") + FAKE_REFUSES_PATH + " refused host plugin API " + kHostApi + " (it needs another version)");
}

TEST(Plugin, RefusesALibraryWithoutTheEntryPoint) {
  const Status status = load_expecting_failure(FAKE_NO_ENTRY_PATH);
  EXPECT_EQ(status.code(), StatusCode::kFailedPrecondition);
  EXPECT_EQ(status.message(), std::string("plugin ") + FAKE_NO_ENTRY_PATH + " does not export rbdgrad_plugin_entry");
}

TEST(Plugin, RefusesATableWithANullFunction) {
  const Status status = load_expecting_failure(FAKE_NULL_FN_PATH);
  EXPECT_EQ(status.code(), StatusCode::kFailedPrecondition);
  EXPECT_EQ(status.message(), std::string("plugin ") + FAKE_NULL_FN_PATH + ": function table entry 'compute' is NULL");
}

TEST(Plugin, RefusesATableShorterThanVersion1_0) {
  const Status status = load_expecting_failure(FAKE_SMALL_TABLE_PATH);
  EXPECT_EQ(status.code(), StatusCode::kFailedPrecondition);
  EXPECT_THAT(status.message(), StartsWith(std::string("plugin ") + FAKE_SMALL_TABLE_PATH + ": function table is "));
  EXPECT_THAT(status.message(), HasSubstr("plugin API " + kHostApi + " needs at least"));
}

TEST(Plugin, ReportsAMissingFileAsNotFound) {
  const char* path = "/nonexistent/librbdgrad_nope.so";
  const Status status = load_expecting_failure(path);
  EXPECT_EQ(status.code(), StatusCode::kNotFound);
  EXPECT_THAT(status.message(), StartsWith("plugin /nonexistent/librbdgrad_nope.so: cannot load: "));
  EXPECT_THAT(status.message(), HasSubstr("No such file"));
}

TEST(Plugin, ReportsAFileThatIsNoSharedLibrary) {
  const Status status = load_expecting_failure(__FILE__);
  EXPECT_EQ(status.code(), StatusCode::kFailedPrecondition);
  EXPECT_THAT(status.message(), StartsWith(std::string("plugin ") + __FILE__ + ": cannot load: "));
}

// --- registry ---

TEST(PluginRegistry, KeepsTheGoodPluginAndRecordsWhyTheOthersAreUnavailable) {
  const std::vector<std::string> broken = {FAKE_WRONG_MAJOR_PATH, FAKE_REFUSES_PATH, FAKE_NO_ENTRY_PATH,
                                           FAKE_NULL_FN_PATH, FAKE_SMALL_TABLE_PATH, "/nonexistent/lib.so"};
  std::vector<std::string> paths = broken;
  paths.insert(paths.begin() + 2, FAKE_OK_PATH);
  const PluginRegistry registry = PluginRegistry::load(paths);

  ASSERT_EQ(registry.available().size(), 1u);
  EXPECT_EQ(registry.available()[0]->info().name, "fake");
  ASSERT_EQ(registry.unavailable().size(), broken.size());
  for (size_t i = 0; i < broken.size(); ++i) {
    const UnavailablePlugin& entry = registry.unavailable()[i];
    EXPECT_EQ(entry.path, broken[i]);
    EXPECT_FALSE(entry.reason.is_ok());
    EXPECT_THAT(entry.reason.message(), StartsWith("plugin " + broken[i]));
  }
  EXPECT_EQ(registry.unavailable()[5].reason.code(), StatusCode::kNotFound);

  const Plugin* fake = registry.find("fake");
  ASSERT_NE(fake, nullptr);
  EXPECT_EQ(fake->path(), FAKE_OK_PATH);
  EXPECT_EQ(registry.find("cpu"), nullptr);
}

TEST(PluginRegistry, RefusesASecondPluginWithATakenName) {
  PluginRegistry registry;
  EXPECT_TRUE(registry.add(FAKE_OK_PATH).is_ok());
  const Status second = registry.add(FAKE_OK_PATH);
  EXPECT_EQ(second.code(), StatusCode::kFailedPrecondition);
  EXPECT_EQ(second.message(), std::string("plugin ") + FAKE_OK_PATH + ": name 'fake' is already taken by " +
                                  FAKE_OK_PATH + " (the same library): give each plugins entry of it its own `name:` "
                                  "(e.g. fake0, fake1)");
  EXPECT_EQ(registry.available().size(), 1u);
  ASSERT_EQ(registry.unavailable().size(), 1u);
  EXPECT_EQ(registry.unavailable()[0].reason.message(), second.message());
}

// One library under two names (one backend per GPU): two plugins of one kind, each its own name.
TEST(PluginRegistry, LoadsOneLibraryTwiceUnderTwoNames) {
  PluginRegistry registry;
  ASSERT_TRUE(registry.add(FAKE_CUDA_PATH, "cuda0").is_ok());
  ASSERT_TRUE(registry.add(FAKE_CUDA_PATH, "cuda1").is_ok());
  ASSERT_EQ(registry.available().size(), 2u);
  EXPECT_EQ(registry.available()[0]->name(), "cuda0");
  EXPECT_EQ(registry.available()[1]->name(), "cuda1");
  EXPECT_EQ(registry.available()[0]->info().name, "cuda") << "the kind stays the plugin's own name";
  EXPECT_EQ(registry.available()[1]->info().name, "cuda");
  EXPECT_EQ(registry.find("cuda1"), registry.available()[1].get());
  EXPECT_EQ(registry.find("cuda"), nullptr) << "find takes names, not kinds";
  // the same name again is refused, saying what to do
  const Status again = registry.add(FAKE_CUDA_PATH, "cuda1");
  EXPECT_EQ(again.code(), StatusCode::kFailedPrecondition);
  EXPECT_THAT(again.message(), ::testing::HasSubstr("name 'cuda1' is already taken"));
  EXPECT_THAT(again.message(), ::testing::HasSubstr("`name:`"));
  // the plugin's own name is taken only once as well
  EXPECT_TRUE(registry.add(FAKE_CUDA_PATH).is_ok());
  EXPECT_FALSE(registry.add(FAKE_CUDA_PATH).is_ok());
  EXPECT_EQ(registry.available().size(), 3u);
}

TEST(PluginRegistry, EmptyListLoadsNothing) {
  const PluginRegistry registry = PluginRegistry::load({});
  EXPECT_TRUE(registry.available().empty());
  EXPECT_TRUE(registry.unavailable().empty());
  EXPECT_EQ(registry.find("fake"), nullptr);
}

}  // namespace
}  // namespace rbdgrad::server
