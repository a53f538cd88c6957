// Tests for plugins/cuda through the C ABI (librbdgrad_cuda.so loaded with dlopen, as the daemon
// loads it). Without a GPU: the plugin loads, describes itself, and reports UNAVAILABLE with the
// reason; the GPU tests skip with that reason. With a GPU: every embedded robot, f64 and f32,
// every output case, both input kinds, external forces and a caller's M^-1, batch sizes 1 to
// 65536, outputs poisoned with NaN before each run, against the core library (which the CPU
// plugin equals bit for bit) and the Pinocchio reference data; per-state failures as the core's.
#include <gtest/gtest.h>

#include <cmath>
#include <cstddef>
#include <cstdio>
#include <limits>
#include <optional>
#include <string>

#include "../support/plugin_harness.hpp"
#include "common/error.hpp"
#include "common/model_desc.hpp"
#include "cuda_test_support.hpp"
#include "rbdgrad/io/state_file.hpp"

namespace rbdgrad::testing {
namespace {

const rbdgrad_plugin_api* api() {
  static const rbdgrad_plugin_api* table =
      load_plugin_entry(RBDGRAD_CUDA_PLUGIN_PATH)(RBDGRAD_PLUGIN_API_MAJOR, RBDGRAD_PLUGIN_API_MINOR);
  return table;
}

const plugin::ModelDesc& iiwa() {
  static const plugin::ModelDesc desc(load_embedded("iiwa14"));
  return desc;
}

// Why this machine cannot run the plugin (the message of the instance it refused), or nothing.
const std::optional<std::string>& no_gpu_reason() {
  static const std::optional<std::string> reason = []() -> std::optional<std::string> {
    std::optional<PluginError> error;
    InstancePtr instance = create(api(), iiwa().desc(), {}, &error);
    if (error && error->code == RBDGRAD_ERROR_UNAVAILABLE) return error->message;
    return std::nullopt;
  }();
  return reason;
}

#define SKIP_WITHOUT_GPU()                                                   \
  do {                                                                       \
    if (no_gpu_reason()) GTEST_SKIP() << "no GPU: " << *no_gpu_reason();     \
  } while (0)

TEST(CudaPlugin, LoadsAndDescribesItself) {
  ASSERT_NE(api(), nullptr);
  EXPECT_EQ(api()->api_major, static_cast<std::uint32_t>(RBDGRAD_PLUGIN_API_MAJOR));
  rbdgrad_plugin_info info{};
  info.struct_size = sizeof(info);
  ASSERT_FALSE(take(api(), api()->get_info(&info)));
  EXPECT_STREQ(info.name, "cuda");
  EXPECT_EQ(info.precisions, static_cast<std::uint32_t>(RBDGRAD_PRECISION_F64 | RBDGRAD_PRECISION_F32));
  EXPECT_EQ(info.outputs, kEveryOutput);
  EXPECT_EQ(info.max_nv, 64u);
}

TEST(CudaPlugin, ReportsUnavailableWithoutGpu) {
  if (!no_gpu_reason()) GTEST_SKIP() << "a GPU is present: this checks the machines without one";
  EXPECT_EQ(no_gpu_reason()->rfind("no CUDA device: ", 0), 0u) << *no_gpu_reason();
  EXPECT_GT(no_gpu_reason()->size(), std::string("no CUDA device: cudaGetDeviceCount: ").size()) << *no_gpu_reason();
  // the scheduler hears the same when it asks
  const std::optional<PluginError> e =
      take(api(), api()->can_run(&iiwa().desc(), RBDGRAD_PRECISION_F64, kEveryOutput, 16));
  ASSERT_TRUE(e);
  EXPECT_EQ(e->code, RBDGRAD_ERROR_UNAVAILABLE);
  EXPECT_EQ(e->message, *no_gpu_reason());
}

TEST(CudaPlugin, FixedPointAndLargeModelsAreUnsupported) {
  std::optional<PluginError> e =
      take(api(), api()->can_run(&iiwa().desc(), RBDGRAD_PRECISION_FIXED_Q16_16, kEveryOutput, 16));
  ASSERT_TRUE(e);
  EXPECT_EQ(e->code, RBDGRAD_ERROR_UNSUPPORTED) << e->message;
  const plugin::ModelDesc large(random_model(5, 65, TreeShape::kBranching));
  create(api(), large.desc(), {}, &e);
  ASSERT_TRUE(e);
  EXPECT_EQ(e->code, RBDGRAD_ERROR_UNSUPPORTED) << e->message;
  EXPECT_NE(e->message.find("more than the 64"), std::string::npos) << e->message;
}

TEST(CudaPlugin, OptionsAreChecked) {
  std::optional<PluginError> e;
  create(api(), iiwa().desc(), {{"threads", "2"}}, &e);
  ASSERT_TRUE(e);
  EXPECT_EQ(e->code, RBDGRAD_ERROR_INVALID_ARGUMENT) << e->message;
  create(api(), iiwa().desc(), {{"device", "first"}}, &e);
  ASSERT_TRUE(e);
  EXPECT_EQ(e->code, RBDGRAD_ERROR_INVALID_ARGUMENT) << e->message;
  for (const char* bad : {"0", "-1", "lots", "1048577"}) {
    create(api(), iiwa().desc(), {{"workspace_mib", bad}}, &e);
    ASSERT_TRUE(e) << bad;
    EXPECT_EQ(e->code, RBDGRAD_ERROR_INVALID_ARGUMENT) << bad << ": " << e->message;
    EXPECT_NE(e->message.find("option 'workspace_mib'"), std::string::npos) << e->message;
  }
  create(api(), iiwa().desc(), {{"states_per_block", "0"}}, &e);
  ASSERT_TRUE(e);
  EXPECT_EQ(e->code, RBDGRAD_ERROR_INVALID_ARGUMENT) << e->message;
  // invalid combinations, each with what its message must say
  struct Invalid {
    std::vector<std::pair<std::string, std::string>> options;
    const char* says;
  };
  for (const Invalid& bad : std::vector<Invalid>{
           {{{"threads_per_state", "512"}, {"states_per_block", "4"}}, "a block holds 1 to 1024 threads"},
           {{{"specialize", "yes"}}, "option 'specialize' is 'yes'"},
           {{{"block_compact", "true"}, {"specialize", "false"}}, "option 'block_compact' needs 'specialize'"},
           {{{"block_lean", "true"}, {"specialize", "false"}}, "option 'block_lean' needs 'specialize'"},
           {{{"block_lean", "true"}, {"block_compact", "false"}}, "block_lean without block_compact"},
           {{{"block_tree_chains", "true"}, {"block_lean", "false"}}, "option 'block_tree_chains' needs 'block_lean'"},
           {{{"block_tree_columns", "true"}, {"block_tree_chains", "false"}},
            "option 'block_tree_columns' needs 'block_tree_chains'"},
           {{{"block_tree_columns", "true"}, {"block_compact", "false"}},
            "option 'block_tree_columns' needs 'block_tree_chains'"},
       }) {
    create(api(), iiwa().desc(), bad.options, &e);
    ASSERT_TRUE(e) << bad.says;
    EXPECT_EQ(e->code, RBDGRAD_ERROR_INVALID_ARGUMENT) << e->message;
    EXPECT_NE(e->message.find(bad.says), std::string::npos) << e->message;
  }
  for (const auto& [name, value] : {std::pair{"max_chunks", "9"}, {"max_chunks", "0"}, {"chunk_min_states", "-1"}, {"f32_compute", "f16"}, {"mapped_pinned_max_kib", "-1"},
                                     {"warp_kernel", "maybe"}, {"block_compact", "sometimes"}, {"block_lean", "2"},
                                     {"block_tree_chains", "on"}, {"block_tree_columns", "1"}}) {
    create(api(), iiwa().desc(), {{name, value}}, &e);
    ASSERT_TRUE(e) << name << "=" << value;
    EXPECT_EQ(e->code, RBDGRAD_ERROR_INVALID_ARGUMENT) << e->message;
    EXPECT_NE(e->message.find("option '" + std::string(name) + "'"), std::string::npos) << e->message;
  }
  // the compact kernel with its lean working set is the default, which the generic kernels
  // (specialize off) leave aside, and the dense kernel turns the lean working set off with it: no
  // error of the options, whether or not a GPU is there to create the instance
  for (const auto& options : {std::vector<std::pair<std::string, std::string>>{{"specialize", "false"}},
                              {{"specialize", "false"}, {"block_compact", "false"}},
                              {{"block_compact", "false"}},
                              {{"block_lean", "false"}, {"specialize", "false"}},
                              {{"block_tree_columns", "true"}},
                              {{"block_tree_chains", "false"}},
                              {{"block_lean", "false"}}}) {
    e.reset();
    create(api(), iiwa().desc(), options, &e);
    if (e) {
      EXPECT_NE(e->code, RBDGRAD_ERROR_INVALID_ARGUMENT) << e->message;
    }
  }
  SKIP_WITHOUT_GPU();
  // a small workspace still computes, with fewer resident thread slots
  EXPECT_NE(create(api(), iiwa().desc(), {{"workspace_mib", "1"}}, &e), nullptr) << (e ? e->message : "");
  create(api(), iiwa().desc(), {{"device", "1000"}}, &e);
  ASSERT_TRUE(e);
  EXPECT_EQ(e->code, RBDGRAD_ERROR_UNAVAILABLE) << e->message;
  EXPECT_NE(e->message.find("CUDA device 1000 not present"), std::string::npos) << e->message;
}

TEST(CudaPlugin, FixedPointBatchIsUnsupported) {
  SKIP_WITHOUT_GPU();
  InstancePtr instance = create(api(), iiwa().desc(), {});
  ASSERT_TRUE(instance);
  BatchArrays<std::int32_t> a(4, 7);
  const rbdgrad_batch b = a.batch(RBDGRAD_PRECISION_FIXED_Q16_16, RBDGRAD_INPUT_TAU, kEveryOutput, false, false);
  const std::optional<PluginError> e = take(api(), api()->compute(instance.get(), &b));
  ASSERT_TRUE(e);
  EXPECT_EQ(e->code, RBDGRAD_ERROR_UNSUPPORTED) << e->message;
}

template <class S>
rbdgrad_precision precision() {
  return std::is_same_v<S, double> ? RBDGRAD_PRECISION_F64 : RBDGRAD_PRECISION_F32;
}

// Runs one poisoned batch through the plugin and compares it with the core.
template <class S>
void run_and_compare(rbdgrad_instance* instance, const Model& model, const std::vector<StateInputs>& states,
                     const OutputCase& c, bool tau_input, const std::string& where) {
  CudaBatch<S> a(states, model.nv, tau_input);
  a.poison();
  const rbdgrad_batch b = a.batch(precision<S>(), c, tau_input);
  const std::optional<PluginError> e = take(api(), api()->compute(instance, &b));
  ASSERT_FALSE(e) << where << ": " << e->message;
  for (std::size_t k = 0; k < a.n; ++k) ASSERT_EQ(a.status[k], 0) << where << " state " << k;
  const Comparison cmp = compare_with_core(model, a, c, tau_input);
  ASSERT_TRUE(cmp.message.empty()) << where << ": " << cmp.message;
  EXPECT_TRUE(cmp.within_bounds<S>()) << where << ":" << cmp.summary();
  if (&c == &kOutputCases[0] && a.n >= 1000) std::printf("%s:%s\n", where.c_str(), cmp.summary().c_str());
}

constexpr std::size_t kBatchSizes[] = {1, 7, 32, 33, 1000};

template <class S>
void check_robot(const std::string& robot) {
  const Model model = robot_model(robot);
  const plugin::ModelDesc desc(model);
  std::optional<PluginError> error;
  // one instance for every size and precision (its buffers grow and are reused), with the default
  // kernel choice (the warp kernel for gradient requests computed in f64), one with the block
  // kernel instead, and one with the one-thread kernel only
  InstancePtr instance = create(api(), desc.desc(), {{"device", "0"}}, &error);
  ASSERT_FALSE(error) << error->message;
  InstancePtr block_only = create(api(), desc.desc(), {{"warp_kernel", "false"}}, &error);
  ASSERT_FALSE(error) << error->message;
  InstancePtr thread_only = create(api(), desc.desc(), {{"block_max_states", "0"}}, &error);
  ASSERT_FALSE(error) << error->message;
  const std::vector<StateInputs> all = random_inputs(model, kBatchSizes[4], 7);
  for (const std::size_t n : kBatchSizes) {
    const std::vector<StateInputs> states(all.begin(), all.begin() + static_cast<long>(n));
    for (const bool tau_input : {true, false}) {
      auto run = [&](rbdgrad_instance* on, const OutputCase& c, const char* kernel) {
        const std::string where = robot + " " + scalar_name<S>() + " n=" + std::to_string(n) + " " + c.name +
                                  (tau_input ? ", tau input" : ", qdd input") + kernel;
        run_and_compare<S>(on, model, states, c, tau_input, where);
      };
      for (const OutputCase& c : kOutputCases) run(instance.get(), c, "");
      for (const OutputCase& c : kBlockCases) {
        run(instance.get(), c, " (default kernel)");
        run(block_only.get(), c, " (block kernel)");
        run(thread_only.get(), c, " (one-thread kernel)");
      }
      if (::testing::Test::HasFatalFailure()) return;
    }
  }
}

class CudaConformance : public ::testing::TestWithParam<const char*> {};

TEST_P(CudaConformance, F64MatchesCore) {
  SKIP_WITHOUT_GPU();
  check_robot<double>(GetParam());
}
TEST_P(CudaConformance, F32MatchesCore) {
  SKIP_WITHOUT_GPU();
  check_robot<float>(GetParam());
}

INSTANTIATE_TEST_SUITE_P(Robots, CudaConformance,
                         ::testing::Values("iiwa14", "panda", "talos_reduced", "hyq", "random_tree"),
                         [](const auto& param_info) { return std::string(param_info.param); });

// A small batch, every case: the target of compute-sanitizer (memcheck, racecheck) runs.
TEST(CudaPlugin, InstanceNamesItsGpu) {
  SKIP_WITHOUT_GPU();
  InstancePtr instance = create(api(), iiwa().desc(), {{"device", "0"}});
  ASSERT_TRUE(instance);
  rbdgrad_instance_info info{};
  info.struct_size = sizeof(info);
  ASSERT_FALSE(take(api(), api()->describe_instance(instance.get(), &info)));
  EXPECT_STREQ(info.mode, "");  // the GPU itself
  const std::string device = info.device;
  EXPECT_GT(device.size(), std::string(" (device 0)").size()) << device;
  EXPECT_EQ(device.substr(device.size() - 11), " (device 0)") << device;
  // the kernel: "kernel compiled for this robot (f64: compiled, 0.9 s; f32: ...)", or "generic
  // kernel (f64: generic kernel, NVRTC is not installed ...)" without NVRTC
  ASSERT_NE(info.detail, nullptr);
  const std::string detail = info.detail;
  const bool specific = detail.rfind("kernel compiled for this robot (f64: ", 0) == 0;
  const bool generic = detail.rfind("generic kernel (f64: generic kernel, ", 0) == 0;
  EXPECT_TRUE(specific || generic) << detail;
  std::printf("%s; %s\n", device.c_str(), detail.c_str());
  // without the robot-specific kernel
  InstancePtr plain = create(api(), iiwa().desc(), {{"device", "0"}, {"specialize", "false"}});
  ASSERT_TRUE(plain);
  ASSERT_FALSE(take(api(), api()->describe_instance(plain.get(), &info)));
  EXPECT_STREQ(info.detail, "generic kernel; gradient batches computed in f64 on the warp kernel");
  InstancePtr block_only = create(api(), iiwa().desc(), {{"specialize", "false"}, {"warp_kernel", "false"}});
  ASSERT_TRUE(block_only);
  ASSERT_FALSE(take(api(), api()->describe_instance(block_only.get(), &info)));
  EXPECT_STREQ(info.detail, "generic kernel");
  // a 1.1 host's shorter struct: accepted, detail left alone
  rbdgrad_instance_info old{};
  old.struct_size = offsetof(rbdgrad_instance_info, detail);
  old.detail = "untouched";
  ASSERT_FALSE(take(api(), api()->describe_instance(plain.get(), &old)));
  EXPECT_STREQ(old.detail, "untouched");
}

TEST(CudaSmallBatch, Iiwa14F64SevenStates) {
  SKIP_WITHOUT_GPU();
  const Model model = load_embedded("iiwa14");
  InstancePtr instance = create(api(), iiwa().desc(), {});
  ASSERT_TRUE(instance);
  const std::vector<StateInputs> states = random_inputs(model, 7, 5);
  for (const bool tau_input : {true, false}) {
    for (const OutputCase& c : kOutputCases)
      run_and_compare<double>(instance.get(), model, states, c, tau_input,
                              std::string("iiwa14 f64 n=7 ") + c.name + (tau_input ? ", tau input" : ", qdd input"));
    for (const OutputCase& c : kBlockCases)
      run_and_compare<float>(instance.get(), model, states, c, tau_input,
                             std::string("iiwa14 f32 n=7 ") + c.name + (tau_input ? ", tau input" : ", qdd input"));
  }
}

// The block kernel in other shapes: one warp per state, several states per warp or per block, and
// groups that are not whole warps (block-wide syncs); odd batch sizes leave groups idle.
TEST(CudaBlockShapes, EveryShapeMatchesTheCore) {
  SKIP_WITHOUT_GPU();
  const std::pair<const char*, const char*> shapes[] = {{"32", "1"}, {"8", "4"}, {"16", "2"}, {"96", "1"},
                                                        {"128", "2"}, {"16", "3"}, {"256", "1"}};
  for (const char* robot : {"iiwa14", "talos_reduced", "random_tree"}) {
    const Model model = robot_model(robot);
    const plugin::ModelDesc desc(model);
    const std::vector<StateInputs> states = random_inputs(model, 33, 19);
    for (const auto& [tps, spb] : shapes) {
      std::optional<PluginError> error;
      InstancePtr instance = create(
          api(), desc.desc(), {{"threads_per_state", tps}, {"states_per_block", spb}, {"warp_kernel", "false"}}, &error);
      ASSERT_FALSE(error) << error->message;
      for (const bool tau_input : {true, false}) {
        const std::string where = std::string(robot) + " " + tps + " threads x " + spb + " states" +
                                  (tau_input ? ", tau input" : ", qdd input");
        run_and_compare<double>(instance.get(), model, states, kBlockCases[1], tau_input, where + " f64");
        run_and_compare<float>(instance.get(), model, states, kBlockCases[1], tau_input, where + " f32");
      }
    }
  }
}

// A large batch: more states than workspace slots for the larger robots, so threads loop.
template <class S>
void check_large_batch(const std::string& robot) {
  const Model model = robot_model(robot);
  const plugin::ModelDesc desc(model);
  InstancePtr instance = create(api(), desc.desc(), {});
  ASSERT_TRUE(instance);
  const std::vector<StateInputs> states = random_inputs(model, 65536, 11);
  for (const bool tau_input : {true, false})
    for (const OutputCase* c : {&kOutputCases[1], &kBlockCases[1]})
      run_and_compare<S>(instance.get(), model, states, *c, tau_input,
                         robot + " " + scalar_name<S>() + " n=65536 " + c->name +
                             (tau_input ? ", tau input" : ", qdd input"));
}

TEST(CudaLargeBatch, Iiwa14F64) {
  SKIP_WITHOUT_GPU();
  check_large_batch<double>("iiwa14");
}
TEST(CudaLargeBatch, Iiwa14F32) {
  SKIP_WITHOUT_GPU();
  check_large_batch<float>("iiwa14");
}
TEST(CudaLargeBatch, TalosReducedF64) {
  SKIP_WITHOUT_GPU();
  check_large_batch<double>("talos_reduced");
}

// A batch large enough to be pipelined in chunks (chunk_states), of a size that does
// not split evenly, with every input array (external forces, a caller's M^-1) and every output.
TEST(CudaLargeBatch, UnevenChunksWithEveryInputAndOutput) {
  SKIP_WITHOUT_GPU();
  const Model model = robot_model("iiwa14");
  const plugin::ModelDesc desc(model);
  InstancePtr instance = create(api(), desc.desc(), {});
  ASSERT_TRUE(instance);
  const std::vector<StateInputs> states = random_inputs(model, 3 * 8192 + 5, 13);
  run_and_compare<double>(instance.get(), model, states, kOutputCases[2], true,
                          "iiwa14 f64 n=24581 " + std::string(kOutputCases[2].name));
}

// The most chunks the pipeline takes, each small and the last one shorter, with every input and
// output: each chunk's kernel waits for its own upload only and each download for its own
// kernel, so a wrong order shows as outputs of another chunk or the poison left in place.
// A scene's instance (issue 8, ABI 1.3): its kernel is compiled with the plan's stages fixed, says
// so, matches the core on the plan's outputs, and refuses a batch outside the plan.
TEST(CudaScenePlan, FixedStageKernelsMatchTheCore) {
  SKIP_WITHOUT_GPU();
  for (const char* robot : {"iiwa14", "hyq"}) {
    const Model model = robot_model(robot);
    const std::vector<StateInputs> states = random_inputs(model, 33, 17);
    struct Plan {
      OutputCase batch;
      bool minv;
      bool forces;
      const char* stages;
    };
    const Plan plans[] = {
        {{"d qdd/d q", RBDGRAD_OUTPUT_DQDD_DQ, false, false}, false, false, "stages fixed: d/dq, M^-1 computed"},
        {{"qdd and d qdd/d qd, forces", RBDGRAD_OUTPUT_QDD | RBDGRAD_OUTPUT_DQDD_DQD, true, false}, false, true,
         "stages fixed: d/dqd, M^-1 computed"},
        {{"d qdd, M^-1 supplied, forces", kOutputDqdd, true, true}, true, true,
         "stages fixed: d/dq d/dqd, M^-1 supplied"},
    };
    for (const Plan& p : plans) {
      plugin::ModelDesc desc(model);
      std::vector<std::uint32_t> bodies;
      if (p.forces)
        for (int i = 0; i < model.nv; ++i) bodies.push_back(static_cast<std::uint32_t>(i));
      desc.set_plan(p.batch.outputs, p.minv, bodies);
      std::optional<PluginError> error;
      InstancePtr instance = create(api(), desc.desc(), {}, &error);
      ASSERT_TRUE(instance) << error->message;
      rbdgrad_instance_info info{};
      info.struct_size = sizeof(info);
      ASSERT_FALSE(take(api(), api()->describe_instance(instance.get(), &info)));
      const std::string detail = info.detail;
      std::printf("%s %s: %s\n", robot, p.batch.name, detail.c_str());
      if (detail.rfind("kernel compiled for this robot", 0) == 0) {
        EXPECT_NE(detail.find(p.stages), std::string::npos) << detail;
      }
      for (const bool tau_input : {true, false}) {
        const std::string where = std::string(robot) + " " + p.batch.name + (tau_input ? ", tau" : ", qdd");
        run_and_compare<double>(instance.get(), model, states, p.batch, tau_input, where + " f64");
        run_and_compare<float>(instance.get(), model, states, p.batch, tau_input, where + " f32");
      }
      CudaBatch<double> a(states, model.nv, true);
      const OutputCase outside{"M", RBDGRAD_OUTPUT_M, false, p.minv};
      const rbdgrad_batch b = a.batch(RBDGRAD_PRECISION_F64, outside, true);
      const std::optional<PluginError> e = take(api(), api()->compute(instance.get(), &b));
      ASSERT_TRUE(e);
      EXPECT_NE(e->message.find("outside the instance's plan"), std::string::npos) << e->message;
    }
  }
}

TEST(CudaLargeBatch, EightSmallChunks) {
  SKIP_WITHOUT_GPU();
  const Model model = robot_model("iiwa14");
  const plugin::ModelDesc desc(model);
  InstancePtr instance =
      create(api(), desc.desc(), {{"chunk_min_states", "100"}, {"max_chunks", "8"}, {"mapped_io_max_kib", "0"}});
  ASSERT_TRUE(instance);
  const std::vector<StateInputs> states = random_inputs(model, 8 * 125 + 3, 19);
  for (const OutputCase& outputs : kOutputCases)
    run_and_compare<double>(instance.get(), model, states, outputs, true,
                            "iiwa14 f64 n=1003 in 8 chunks " + std::string(outputs.name));
  run_and_compare<float>(instance.get(), model, states, kOutputCases[2], true, "iiwa14 f32 n=1003 in 8 chunks");
}

// A small workspace: few resident thread slots, so each thread runs many states and a large batch
// goes in chunks of whole passes (chunk_states).
TEST(CudaLargeBatch, SmallWorkspaceManyPassesPerThread) {
  SKIP_WITHOUT_GPU();
  const Model model = robot_model("iiwa14");
  const plugin::ModelDesc desc(model);
  InstancePtr instance = create(api(), desc.desc(), {{"workspace_mib", "1"}});
  ASSERT_TRUE(instance);
  for (const std::size_t n : {1000u, 20000u}) {
    const std::vector<StateInputs> states = random_inputs(model, n, 17);
    run_and_compare<double>(instance.get(), model, states, kOutputCases[2], true,
                            "iiwa14 f64 workspace 1 MiB n=" + std::to_string(n));
  }
}

// States the core refuses fail the same way, with the core's message, and the others compute.
TEST(CudaPerState, FailuresMatchTheCore) {
  SKIP_WITHOUT_GPU();
  // the model as the plugin sees it: the ABI carries no joint names, messages say "joint_<i>"
  Model model;
  ASSERT_TRUE(plugin::model_from_desc(iiwa().desc(), model));
  InstancePtr instance = create(api(), iiwa().desc(), {});
  ASSERT_TRUE(instance);
  std::vector<StateInputs> states = random_inputs(model, 7, 3);
  states[3].q(2) = std::numeric_limits<double>::quiet_NaN();
  states[5].qd(4) = std::numeric_limits<double>::infinity();
  std::vector<OutputCase> cases(std::begin(kOutputCases), std::end(kOutputCases));
  cases.insert(cases.end(), std::begin(kBlockCases), std::end(kBlockCases));
  for (const OutputCase& c : cases) {
    CudaBatch<double> a(states, model.nv, true);
    a.poison();
    const rbdgrad_batch b = a.batch(RBDGRAD_PRECISION_F64, c, true);
    const std::optional<PluginError> e = take(api(), api()->compute(instance.get(), &b));
    Workspace ws(model);
    std::string expected;
    for (std::size_t k = 0; k < states.size(); ++k) {
      std::map<std::uint32_t, Eigen::MatrixXd> ref;
      const Status s = reference_state(model, ws, reference_inputs(a, k, c), true, c.outputs, ref);
      const std::int32_t code = s ? 0 : static_cast<std::int32_t>(plugin::error_code_from_status(s.code()));
      EXPECT_EQ(a.status[k], code) << c.name << " state " << k << ": " << s.message();
      if (!s && expected.empty()) expected = "state " + std::to_string(k) + ": " + s.message();
    }
    ASSERT_FALSE(expected.empty()) << c.name;
    ASSERT_TRUE(e) << c.name;
    EXPECT_EQ(e->code, RBDGRAD_ERROR_NUMERICAL) << c.name;
    EXPECT_EQ(e->message.substr(0, expected.size()), expected) << c.name;
  }
}

// The Pinocchio 3.7.0 reference (tests/data/reference): the bounds of the core's own test
// (tests/core/reference_accuracy_test.cpp): f64 within 1e-10, f32 median 1e-4 and worst 1e-3.
template <class S>
void check_reference(const std::string& robot) {
  io::StateFile file;
  std::string read_error;
  ASSERT_TRUE(io::read_state_file(std::string(RBDGRAD_TEST_DATA_DIR) + "/reference/" + robot + ".jsonl", file, read_error))
      << read_error;
  const Model model = load_embedded(robot);
  const plugin::ModelDesc desc(model);
  InstancePtr instance = create(api(), desc.desc(), {});
  ASSERT_TRUE(instance);
  std::vector<StateInputs> tau_states, qdd_states;
  for (const io::StateRecord& r : file.states) {
    StateInputs s;
    auto vec = [&](const char* field) { return Eigen::Map<const Eigen::VectorXd>(r.at(field).data(), model.nv).eval(); };
    s.q = vec("q");
    s.qd = vec("qd");
    s.tau = vec("tau");
    s.qdd = vec("qdd");
    s.fext = Eigen::VectorXd::Zero(6 * model.nv);
    s.minv = Eigen::MatrixXd::Zero(model.nv, model.nv);
    tau_states.push_back(s);
  }
  // forward side from tau; inverse side at the reference qdd, as the core's test does
  const OutputCase forward{"forward", RBDGRAD_OUTPUT_QDD | RBDGRAD_OUTPUT_M | RBDGRAD_OUTPUT_MINV |
                                          RBDGRAD_OUTPUT_DQDD_DQ | RBDGRAD_OUTPUT_DQDD_DQD, false, false};
  const OutputCase inverse{"inverse", RBDGRAD_OUTPUT_TAU | RBDGRAD_OUTPUT_DTAU_DQ | RBDGRAD_OUTPUT_DTAU_DQD, false, false};
  // the gradient request without M: the block kernel's
  const OutputCase gradient{"gradient", RBDGRAD_OUTPUT_QDD | RBDGRAD_OUTPUT_MINV | kOutputDqdd, false, false};
  const std::pair<std::uint32_t, const char*> fields[] = {
      {RBDGRAD_OUTPUT_QDD, "qdd"},         {RBDGRAD_OUTPUT_M, "M"},          {RBDGRAD_OUTPUT_MINV, "Minv"},
      {RBDGRAD_OUTPUT_DQDD_DQ, "dqdd_dq"}, {RBDGRAD_OUTPUT_DQDD_DQD, "dqdd_dqd"}, {RBDGRAD_OUTPUT_TAU, "tau_id"},
      {RBDGRAD_OUTPUT_DTAU_DQ, "dtau_dq"}, {RBDGRAD_OUTPUT_DTAU_DQD, "dtau_dqd"}};
  for (const OutputCase* run : {&forward, &gradient, &inverse}) {
    const OutputCase& c = *run;
    const bool tau_input = run != &inverse;
    CudaBatch<S> a(tau_states, model.nv, tau_input);
    a.poison();
    const rbdgrad_batch b = a.batch(precision<S>(), c, tau_input);
    const std::optional<PluginError> e = take(api(), api()->compute(instance.get(), &b));
    ASSERT_FALSE(e) << e->message;
    for (const auto& [flag, field] : fields) {
      if (!(c.outputs & flag)) continue;
      const int f = cuda::output_index(flag);
      const bool matrix = CudaBatch<S>::is_matrix(flag);
      const std::size_t per = matrix ? a.nv * a.nv : a.nv;
      std::vector<double> errors;
      for (std::size_t k = 0; k < a.n; ++k) {
        const std::vector<double>& ref = file.states[k].at(field);
        ASSERT_EQ(ref.size(), per) << field;
        Eigen::VectorXd got(static_cast<Eigen::Index>(per));
        for (std::size_t i = 0; i < per; ++i) got(static_cast<Eigen::Index>(i)) = a.out[f][k * per + i];
        ASSERT_TRUE(got.allFinite()) << robot << " " << field << " (" << c.name << ")" << " state " << k;
        errors.push_back(relative_error(got, Eigen::Map<const Eigen::VectorXd>(ref.data(), static_cast<Eigen::Index>(per))));
      }
      const double median = median_of(errors), worst = worst_of(errors);
      std::printf("%s %s %s (%s) median %.1e worst %.1e\n", robot.c_str(), scalar_name<S>(), field, c.name, median, worst);
      if constexpr (std::is_same_v<S, double>) {
        EXPECT_LE(worst, 1e-10) << robot << " " << field << " (" << c.name << ")";
      } else {
        EXPECT_LE(median, 1e-4) << robot << " " << field << " (" << c.name << ")";
        EXPECT_LE(worst, 1e-3) << robot << " " << field << " (" << c.name << ")";
      }
    }
  }
}

class CudaReference : public ::testing::TestWithParam<const char*> {};

TEST_P(CudaReference, F64Within1e10) {
  SKIP_WITHOUT_GPU();
  check_reference<double>(GetParam());
}
TEST_P(CudaReference, F32Within1e4MedianAnd1e3Worst) {
  SKIP_WITHOUT_GPU();
  check_reference<float>(GetParam());
}

INSTANTIATE_TEST_SUITE_P(Robots, CudaReference, ::testing::Values("iiwa14", "panda", "talos_reduced", "hyq"),
                         [](const auto& param_info) { return std::string(param_info.param); });

}  // namespace
}  // namespace rbdgrad::testing
