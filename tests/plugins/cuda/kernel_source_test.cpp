// Tests for the robot-specific block and warp kernels' generation and compilation (kernel_source.cpp,
// nvrtc_compiler.cpp, kernel_cache.cpp). NVRTC needs no GPU: every shipped robot's kernel is
// compiled here for the H200's architecture (sm_90), in CI too. Where NVRTC is not installed the
// tests skip and say so. Running the compiled kernels needs a GPU (cuda_plugin_test.cpp).
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>

#include "../../support/test_models.hpp"
#include "kernel_cache.hpp"
#include "kernel_source.hpp"
#include "ptxas_report.hpp"
#include "specialized_kernel.hpp"
#include "warp_launch.hpp"
#include "rbdgrad/embedded_robots.hpp"

namespace rbdgrad::testing {
namespace {

using ::testing::HasSubstr;
using ::testing::Not;

#define SKIP_WITHOUT_NVRTC()                                         \
  do {                                                               \
    std::string version;                                             \
    if (Status s = cuda::nvrtc_version(version); !s)                 \
      GTEST_SKIP() << "no NVRTC on this machine: " << s.message();   \
  } while (0)

// a fresh directory under the system's temporary one, removed at the end of the test
struct TempDir {
  std::filesystem::path path;
  TempDir() {
    path = std::filesystem::temp_directory_path() /
           ("rbdgrad-kernel-cache-" + std::to_string(::getpid()) + "-" +
            std::to_string(std::chrono::steady_clock::now().time_since_epoch().count()));
  }
  ~TempDir() {
    std::error_code ec;
    std::filesystem::remove_all(path, ec);
  }
};

// a small program of its own (fast to compile), made unique by `tag` so that no other test has
// put it in the process's memory cache
cuda::NvrtcProgram tiny_program(const std::string& tag) {
  cuda::NvrtcProgram p;
  p.name = "tiny_" + tag + ".cu";
  p.source = "// " + tag + "\ntemplate <class S> __global__ void scale(S* x, S a) { x[threadIdx.x] *= a; }\n";
  p.options = {"-std=c++17", "--gpu-architecture=sm_90"};
  p.name_expressions = {"scale<float>"};
  return p;
}

TEST(KernelSource, FixesTheRobotsSizesAndIncludesOnlyEmbeddedHeaders) {
  const Model model = load_embedded("iiwa14");
  const cuda::NvrtcProgram f64 = cuda::block_kernel_program(model, cuda::KernelScalars::kF64, 90);
  EXPECT_THAT(f64.name_expressions,
              ::testing::ElementsAre(
                  "rbdgrad::cuda::block_fused_kernel<double, rbdgrad::cuda::FixedSizeModelView<double, 7, 7>>"));
  EXPECT_THAT(f64.source, HasSubstr("#include \"block_kernel_entry.hpp\""));
  EXPECT_THAT(f64.options, ::testing::Contains("--gpu-architecture=sm_90"));
  const cuda::NvrtcProgram f32 = cuda::block_kernel_program(load_embedded("talos_reduced"), cuda::KernelScalars::kF32, 90);
  EXPECT_EQ(f32.name_expressions.at(0),
            "rbdgrad::cuda::block_fused_kernel<float, rbdgrad::cuda::FixedSizeModelView<float, 32, " +
                std::to_string(load_embedded("talos_reduced").max_depth()) + ">>");
  // an f32 batch computed in f64: the batch's scalars as the third argument
  EXPECT_EQ(cuda::block_kernel_program(model, cuda::KernelScalars::kF64ForF32, 90).name_expressions.at(0),
            "rbdgrad::cuda::block_fused_kernel<double, rbdgrad::cuda::FixedSizeModelView<double, 7, 7>, float>");
  // a scene's stages (block_stages) follow the batch's scalars
  EXPECT_EQ(cuda::block_kernel_program(model, cuda::KernelScalars::kF64, 90, cuda::block_stages::kDq).name_expressions.at(0),
            "rbdgrad::cuda::block_fused_kernel<double, rbdgrad::cuda::FixedSizeModelView<double, 7, 7>, double, 1>");
  EXPECT_EQ(cuda::block_kernel_program(model, cuda::KernelScalars::kF64ForF32, 90, 6).name_expressions.at(0),
            "rbdgrad::cuda::block_fused_kernel<double, rbdgrad::cuda::FixedSizeModelView<double, 7, 7>, float, 6>");
  EXPECT_THAT(cuda::block_kernel_program(model, cuda::KernelScalars::kF64, 90, 6).source,
              HasSubstr("stages fixed: d/dqd, M^-1 supplied"));
  // the compact kernel: the batch's scalars and the stages named before it; its register cap an
  // option of the compiler
  const cuda::NvrtcProgram compact =
      cuda::block_kernel_program(model, cuda::KernelScalars::kF64, 90, cuda::block_stages::kPerBatch, {true, 64});
  EXPECT_EQ(compact.name_expressions.at(0),
            "rbdgrad::cuda::block_fused_kernel<double, rbdgrad::cuda::FixedSizeModelView<double, 7, 7>, double, -1, true>");
  EXPECT_THAT(compact.options, ::testing::Contains("--maxrregcount=64"));
  EXPECT_THAT(compact.source, HasSubstr("compact block kernel"));
  EXPECT_THAT(compact.source, HasSubstr("at most 64 registers a thread"));
  EXPECT_EQ(compact.name, "block_kernel_iiwa14_f64_compact.cu");
  EXPECT_EQ(cuda::block_kernel_program(model, cuda::KernelScalars::kF64, 90, 6).name, "block_kernel_iiwa14_f64.cu");
  EXPECT_EQ(cuda::block_kernel_program(model, cuda::KernelScalars::kF64ForF32, 90, 6, {true, 0}).name_expressions.at(0),
            "rbdgrad::cuda::block_fused_kernel<double, rbdgrad::cuda::FixedSizeModelView<double, 7, 7>, float, 6, true>");
  // the lean working set: after compact, named in the file and the comment, its packed matrices'
  // size a constant (iiwa14's one block: 49) and its tree too, written into the source (a chain:
  // each joint's parent the joint before, every subtree ending at the last); nothing without compact
  const cuda::NvrtcProgram lean =
      cuda::block_kernel_program(model, cuda::KernelScalars::kF64, 90, cuda::block_stages::kPerBatch, {true, 64, true});
  EXPECT_EQ(lean.name_expressions.at(0),
            "rbdgrad::cuda::block_fused_kernel<double, rbdgrad::cuda::TreeModelView<double, 7, 7, 49, rbdgrad_robot_tree>, "
            "double, -1, true, true>");
  EXPECT_EQ(lean.name, "block_kernel_iiwa14_f64_compact_lean.cu");
  EXPECT_THAT(lean.source, HasSubstr("compact block kernel with a lean working set"));
  EXPECT_THAT(lean.source, HasSubstr("struct rbdgrad_robot_tree {"));
  EXPECT_THAT(lean.source, HasSubstr("constexpr int v[] = {-1, 0, 1, 2, 3, 4, 5};"));
  EXPECT_THAT(lean.source, HasSubstr("constexpr int v[] = {7, 7, 7, 7, 7, 7, 7};"));
  EXPECT_THAT(compact.source, ::testing::Not(HasSubstr("rbdgrad_robot_tree")));
  EXPECT_EQ(cuda::block_kernel_program(model, cuda::KernelScalars::kF64, 90, cuda::block_stages::kPerBatch, {false, 0, true})
                .name_expressions.at(0),
            f64.name_expressions.at(0));
  EXPECT_THAT(f64.options, ::testing::Not(::testing::Contains(::testing::StartsWith("--maxrregcount"))));
  bool entry = false;
  for (const cuda::EmbeddedHeader& h : f64.headers) entry |= std::string(h.name) == "block_kernel_entry.hpp";
  EXPECT_TRUE(entry) << "the entry header is not embedded";
  // a robot's name from a URDF cannot end the source's comment line
  Model odd = model;
  odd.name = "evil\n#error injected";
  EXPECT_THAT(cuda::block_kernel_program(odd, cuda::KernelScalars::kF64, 90).source, ::testing::Not(HasSubstr("\n#error")));
}

// RBDGRAD_CUDA_LINEINFO=1 (for a profiler by source line) adds -lineinfo to both kernels' options,
// which the kernel cache keys on; any other value adds nothing
TEST(KernelSource, LineInfoOnlyWhenAsked) {
  const Model model = load_embedded("iiwa14");
  const char* before = std::getenv("RBDGRAD_CUDA_LINEINFO");
  const std::string saved = before ? before : "";
  ::setenv("RBDGRAD_CUDA_LINEINFO", "0", 1);
  EXPECT_THAT(cuda::block_kernel_program(model, cuda::KernelScalars::kF64, 90).options,
              ::testing::Not(::testing::Contains("-lineinfo")));
  ::setenv("RBDGRAD_CUDA_LINEINFO", "1", 1);
  EXPECT_THAT(cuda::block_kernel_program(model, cuda::KernelScalars::kF64, 90).options, ::testing::Contains("-lineinfo"));
  EXPECT_THAT(cuda::warp_kernel_program(model, true, 90).options, ::testing::Contains("-lineinfo"));
  if (before) ::setenv("RBDGRAD_CUDA_LINEINFO", saved.c_str(), 1);
  else ::unsetenv("RBDGRAD_CUDA_LINEINFO");
}

// The warp kernel's program: the robot's sizes and tree fixed (parent + 1 and subtree end - 1, 4
// bits a joint: iiwa14 is a chain), one name per entry point (WarpEntry's order), f32 batches'
// after f64's.
TEST(KernelSource, WarpProgramNamesEveryEntryPoint) {
  const Model model = load_embedded("iiwa14");
  const cuda::NvrtcProgram f64 = cuda::warp_kernel_program(model, false, 90);
  const std::string head = "<8, rbdgrad::cuda::FixedTreeModelView<double, 7, 7, 0x6543210ull, 0x6666666ull>, ";
  EXPECT_THAT(f64.name_expressions,
              ::testing::ElementsAre("rbdgrad::cuda::warp_fused_kernel" + head + "double, false>",
                                     "rbdgrad::cuda::warp_fused_kernel" + head + "double, true>",
                                     "rbdgrad::cuda::warp_fused_inline_kernel" + head + "double, 2048>",
                                     "rbdgrad::cuda::warp_fused_inline_kernel" + head + "double, 4096>",
                                     "rbdgrad::cuda::warp_fused_inline_kernel" + head + "double, 8192>"));
  EXPECT_THAT(f64.source, HasSubstr("#include \"warp_kernel_entry.hpp\""));
  const cuda::NvrtcProgram both = cuda::warp_kernel_program(model, true, 90);
  ASSERT_EQ(both.name_expressions.size(), 2u * cuda::kWarpEntries);
  EXPECT_EQ(both.name_expressions[cuda::kWarpEntries + 1], "rbdgrad::cuda::warp_fused_kernel" + head + "float, true>");
  const Model hyq = load_embedded("hyq");
  EXPECT_THAT(cuda::warp_kernel_program(hyq, false, 90).name_expressions[0],
              HasSubstr("<16, rbdgrad::cuda::FixedTreeModelView<double, 12, " + std::to_string(hyq.max_depth()) +
                        ", 0xba0870540210ull, 0xbbb888555222ull>"));
  EXPECT_NE(cuda::kernel_cache_key(f64, "13.0"), cuda::kernel_cache_key(both, "13.0"));
}

// Every robot the warp kernel takes compiles its entry points, f64 and f32 batches, with NVRTC
// for sm_90.
TEST(KernelSource, EveryWarpRobotCompiles) {
  SKIP_WITHOUT_NVRTC();
  for (std::string_view name : embedded_robot_names()) {
    const Model model = load_embedded(std::string(name));
    if (model.nv > cuda::kMaxWarpNv) continue;
    const auto start = std::chrono::steady_clock::now();
    cuda::NvrtcOutput out;
    const Status s = cuda::nvrtc_compile(cuda::warp_kernel_program(model, true, 90), out);
    ASSERT_TRUE(s.is_ok()) << name << ": " << s.message();
    ASSERT_EQ(out.kernel_symbols.size(), 2u * cuda::kWarpEntries) << name;
    for (const std::string& symbol : out.kernel_symbols) EXPECT_THAT(symbol, HasSubstr("warp_fused")) << name;
    std::printf("%s warp kernel: cubin %zu bytes, compiled in %.1f s\n", std::string(name).c_str(), out.cubin.size(),
                std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count());
  }
}

// Every shipped robot's kernel, both precisions and f32 batches in f64, compiles with NVRTC for
// sm_90.
TEST(KernelSource, EveryRobotCompilesInBothPrecisions) {
  SKIP_WITHOUT_NVRTC();
  for (std::string_view name : embedded_robot_names()) {
    const Model model = load_embedded(std::string(name));
    for (const cuda::KernelScalars scalars :
         {cuda::KernelScalars::kF64, cuda::KernelScalars::kF32, cuda::KernelScalars::kF64ForF32}) {
      const auto start = std::chrono::steady_clock::now();
      cuda::NvrtcOutput out;
      const Status s = cuda::nvrtc_compile(cuda::block_kernel_program(model, scalars, 90), out);
      ASSERT_TRUE(s.is_ok()) << name << " " << cuda::kernel_scalars_name(scalars) << ": " << s.message();
      EXPECT_GT(out.cubin.size(), 1000u) << name;
      ASSERT_EQ(out.kernel_symbols.size(), 1u) << name;
      EXPECT_THAT(out.kernel_symbols[0], HasSubstr("block_fused_kernel")) << name;
      std::printf("%s %s: cubin %zu bytes, compiled in %.1f s\n", std::string(name).c_str(),
                  cuda::kernel_scalars_name(scalars),
                  out.cubin.size(), std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count());
    }
  }
}

// `model`'s `scalars` build of `build` compiled with NVRTC holds its register cap (if any) without
// spilling, by ptxas's own report
void expect_build_holds_its_cap(const Model& model, cuda::KernelScalars scalars, const cuda::BlockBuild& build,
                                const std::string& label) {
  cuda::NvrtcProgram p = cuda::block_kernel_program(model, scalars, 90, cuda::block_stages::kPerBatch, build);
  if (build.register_cap > 0) {
    EXPECT_THAT(p.options, ::testing::Contains("--maxrregcount=" + std::to_string(build.register_cap))) << label;
  }
  p.options.push_back("--ptxas-options=--verbose");
  cuda::NvrtcOutput out;
  const Status s = cuda::nvrtc_compile(p, out);
  ASSERT_TRUE(s.is_ok()) << label << ": " << s.message();
  const cuda::PtxasFunction r = cuda::ptxas_entry(out.log);
  std::printf("%s: cap %d, %d registers, %d bytes spill stores, %d bytes spill loads\n", label.c_str(),
              build.register_cap, r.registers, r.spill_stores, r.spill_loads);
  EXPECT_GT(r.registers, 0) << label << "\n" << out.log;
  if (build.register_cap > 0) {
    EXPECT_LE(r.registers, build.register_cap) << label << "\n" << out.log;
  }
  EXPECT_EQ(r.spill_stores, 0) << label << "\n" << out.log;
  EXPECT_EQ(r.spill_loads, 0) << label << "\n" << out.log;
}

// talos_reduced's f64 builds of `build` (compact, at its register cap) hold that cap without
// spilling; `text` is in their source; its f32 build (no cap) compiles.
void expect_talos_build_holds_its_cap(const cuda::BlockBuild& build, const char* label, const char* text) {
  const Model model = load_embedded("talos_reduced");
  for (const cuda::KernelScalars scalars : {cuda::KernelScalars::kF64, cuda::KernelScalars::kF64ForF32}) {
    EXPECT_THAT(cuda::block_kernel_program(model, scalars, 90, cuda::block_stages::kPerBatch, build).source,
                HasSubstr(text))
        << cuda::kernel_scalars_name(scalars);
    expect_build_holds_its_cap(model, scalars, build,
                               std::string("talos_reduced ") + label + " " + cuda::kernel_scalars_name(scalars));
  }
  cuda::BlockBuild f32 = build;
  f32.register_cap = 0;
  cuda::NvrtcOutput out;
  const Status s = cuda::nvrtc_compile(
      cuda::block_kernel_program(model, cuda::KernelScalars::kF32, 90, cuda::block_stages::kPerBatch, f32), out);
  ASSERT_TRUE(s.is_ok()) << s.message();
  EXPECT_EQ(out.kernel_symbols.size(), 1u);
}

// Every embedded robot's lean build (the default compact kernel's working set), compiled as the
// plugin compiles it on an H100 or H200 (compact_register_cap, specialized_kernel.hpp: the cap
// that the lean blocks of its automatic shape for large launches get from an SM's shared
// memory), holds that cap without spilling: the cap follows the working set, and a smaller set
// means a lower one (or none, where even one block fewer than shared memory allows would need
// fewer than 64: the smaller robots).
TEST(KernelSource, EveryRobotsLeanBuildHoldsItsRegisterCapWithoutSpills) {
  SKIP_WITHOUT_NVRTC();
  const cuda::SmLimits hopper = cuda::hopper_sm_limits();
  for (std::string_view name : embedded_robot_names()) {
    const Model model = load_embedded(std::string(name));
    // (M^-1 by the tree's chains where they fit, its columns by the tree's blocks, as the plugin's
    // defaults, block_tree_chains and block_tree_columns)
    const cuda::BlockBuild build{true, cuda::compact_register_cap(model, true, {}, hopper), true, true, true};
    for (const cuda::KernelScalars scalars : {cuda::KernelScalars::kF64, cuda::KernelScalars::kF64ForF32})
      expect_build_holds_its_cap(model, scalars, build,
                                 std::string(name) + " lean " + cuda::kernel_scalars_name(scalars));
  }
}

// The compact kernel (device/block_kernel_entry.hpp) for talos_reduced, the robot it is for: at
// the register cap an H200 gives it (register_cap.hpp: 64, four blocks an SM; left to itself it
// takes 72; a change that makes it spill at 64 needs measuring against the fourth state it buys).
TEST(KernelSource, CompactTalosKernelHoldsItsRegisterCapWithoutSpills) {
  SKIP_WITHOUT_NVRTC();
  expect_talos_build_holds_its_cap({true, 64}, "compact", "compact block kernel");
}

// The lean working set (block_workspace.hpp) of the compact kernel for talos_reduced: at the cap
// that eight blocks of 128 threads an SM give it, 64 (RegisterCap's tests; CUDA 13.0: 80
// registers uncapped; 72 with seven blocks before I, v and a left the working set after the
// subtree sums; with the packed matrices' size known only at run time it spilled 8 bytes at 72;
// the products' tiles of 5 rows spill 4 bytes here, so this build keeps tiles of 4:
// kTreeTileRowsOf, block_tree_products.hpp).
TEST(KernelSource, LeanTalosKernelHoldsItsRegisterCapWithoutSpills) {
  SKIP_WITHOUT_NVRTC();
  expect_talos_build_holds_its_cap({true, 64, true}, "lean", "lean working set");
}

// The same with M^-1 by the tree's chains (device/block_tree_chains.hpp; the option
// block_tree_chains, the plugin's default; the test above has it off): without spills at 64
// registers once the outputs' pointers were taken after M^-1 (with them taken before, 8 to 52
// bytes of spills in the forms tried).
TEST(KernelSource, LeanTalosKernelByChainsHoldsItsRegisterCapWithoutSpills) {
  SKIP_WITHOUT_NVRTC();
  expect_talos_build_holds_its_cap({true, 64, true, true}, "lean, M^-1 by the tree's chains",
                                   "static constexpr bool chains = true;");
}

// With M^-1's columns by the tree's blocks too (device/block_tree_columns.hpp; BlockBuild's
// tree_columns, the plugin's default with the chains): talos_reduced's lean builds, with the
// columns' code (its name and source say so), without spills at 64 registers (CUDA 13.0: with the
// products' tiles of 4 rows they spilled 12 bytes for f64, 8 for f32 batches; of 5, none).
TEST(KernelSource, LeanTalosKernelByTreeColumnsHoldsItsRegisterCapWithoutSpills) {
  SKIP_WITHOUT_NVRTC();
  const Model model = load_embedded("talos_reduced");
  const cuda::BlockBuild build{true, 64, true, true, true};
  for (const cuda::KernelScalars scalars : {cuda::KernelScalars::kF64, cuda::KernelScalars::kF64ForF32}) {
    const cuda::NvrtcProgram p = cuda::block_kernel_program(model, scalars, 90, cuda::block_stages::kPerBatch, build);
    EXPECT_THAT(p.name, HasSubstr("_chains_columns")) << cuda::kernel_scalars_name(scalars);
    EXPECT_THAT(p.source, HasSubstr("its columns by the tree's blocks")) << cuda::kernel_scalars_name(scalars);
  }
  expect_talos_build_holds_its_cap(build, "lean, M^-1's columns by the tree", "static constexpr bool columns = true;");
  // without the chains the flag is ignored: the columns are the level passes' own
  const cuda::NvrtcProgram levels =
      cuda::block_kernel_program(model, cuda::KernelScalars::kF64, 90, cuda::block_stages::kPerBatch,
                                 {true, 64, true, false, true});
  EXPECT_THAT(levels.source, HasSubstr("static constexpr bool columns = false;"));
  EXPECT_THAT(levels.name, Not(HasSubstr("columns")));
}

// A scene's kernels (issue 8): each stage set compiles, and leaving stages out makes less code.
TEST(KernelSource, SceneStagesCompileToLessCode) {
  SKIP_WITHOUT_NVRTC();
  namespace st = cuda::block_stages;
  const Model model = load_embedded("iiwa14");
  std::size_t per_batch_bytes = 0;
  for (const int stages : {st::kPerBatch, st::kDq | st::kDqd, st::kDq, st::kDqd | st::kMinvSupplied}) {
    for (const cuda::KernelScalars scalars : {cuda::KernelScalars::kF64, cuda::KernelScalars::kF32}) {
      cuda::NvrtcOutput out;
      const Status s = cuda::nvrtc_compile(cuda::block_kernel_program(model, scalars, 90, stages), out);
      ASSERT_TRUE(s.is_ok()) << cuda::block_stages_text(stages) << ": " << s.message();
      if (scalars != cuda::KernelScalars::kF64) continue;
      std::printf("iiwa14 f64, %s: cubin %zu bytes\n", cuda::block_stages_text(stages).c_str(), out.cubin.size());
      if (stages == st::kPerBatch) {
        per_batch_bytes = out.cubin.size();
      } else if (stages != (st::kDq | st::kDqd)) {
        EXPECT_LT(out.cubin.size(), per_batch_bytes) << cuda::block_stages_text(stages);
      }
    }
  }
}

TEST(KernelSource, CompileErrorsCarryNvrtcsLog) {
  SKIP_WITHOUT_NVRTC();
  cuda::NvrtcProgram p = tiny_program("broken");
  p.source += "this is not C++;\n";
  cuda::NvrtcOutput out;
  const Status s = cuda::nvrtc_compile(p, out);
  EXPECT_EQ(s.code(), StatusCode::kInternal);
  EXPECT_THAT(s.message(), HasSubstr("compiling tiny_broken.cu with NVRTC"));
  EXPECT_THAT(s.message(), HasSubstr("error"));
}

TEST(KernelCache, KeysDifferWithEveryInput) {
  const Model model = load_embedded("iiwa14");
  const cuda::NvrtcProgram p = cuda::block_kernel_program(model, cuda::KernelScalars::kF64, 90);
  const std::string key = cuda::kernel_cache_key(p, "13.0");
  EXPECT_EQ(key.size(), 16u);
  EXPECT_EQ(key, cuda::kernel_cache_key(cuda::block_kernel_program(model, cuda::KernelScalars::kF64, 90), "13.0"));
  EXPECT_NE(key, cuda::kernel_cache_key(p, "13.1"));
  EXPECT_NE(key, cuda::kernel_cache_key(cuda::block_kernel_program(model, cuda::KernelScalars::kF32, 90), "13.0"));
  EXPECT_NE(key, cuda::kernel_cache_key(cuda::block_kernel_program(model, cuda::KernelScalars::kF64ForF32, 90), "13.0"));
  EXPECT_NE(key, cuda::kernel_cache_key(cuda::block_kernel_program(model, cuda::KernelScalars::kF64, 100), "13.0"));
  EXPECT_NE(key, cuda::kernel_cache_key(cuda::block_kernel_program(load_embedded("panda"), cuda::KernelScalars::kF64, 90), "13.0"));
  const auto compact_key = [&](int cap) {
    return cuda::kernel_cache_key(
        cuda::block_kernel_program(model, cuda::KernelScalars::kF64, 90, cuda::block_stages::kPerBatch, {true, cap}),
        "13.0");
  };
  EXPECT_NE(key, compact_key(0));
  EXPECT_NE(compact_key(0), compact_key(64));
  cuda::NvrtcProgram other_header = p;
  other_header.headers.pop_back();
  EXPECT_NE(key, cuda::kernel_cache_key(other_header, "13.0"));
}

TEST(KernelCache, CompilesOnceThenServesFromMemoryAndDisk) {
  SKIP_WITHOUT_NVRTC();
  TempDir dir;
  const cuda::NvrtcProgram p = tiny_program("cache" + std::to_string(::getpid()));
  cuda::NvrtcOutput first, second, refreshed;
  cuda::KernelOrigin origin{};
  std::string warning;
  ASSERT_TRUE(cuda::compile_with_cache(p, dir.path.string(), false, first, origin, warning).is_ok());
  EXPECT_EQ(origin, cuda::KernelOrigin::kCompiled);
  EXPECT_EQ(warning, "");
  ASSERT_TRUE(cuda::compile_with_cache(p, dir.path.string(), false, second, origin, warning).is_ok());
  EXPECT_EQ(origin, cuda::KernelOrigin::kMemoryCache);
  EXPECT_EQ(second.cubin, first.cubin);
  EXPECT_EQ(second.kernel_symbols, first.kernel_symbols);
  ASSERT_TRUE(cuda::compile_with_cache(p, dir.path.string(), true, refreshed, origin, warning).is_ok());
  EXPECT_EQ(origin, cuda::KernelOrigin::kCompiled);
  // the file: the kernel's symbol and the cubin, under the program's key
  std::string version;
  ASSERT_TRUE(cuda::nvrtc_version(version).is_ok());
  const std::filesystem::path file = dir.path / (cuda::kernel_cache_key(p, version) + ".cubin");
  ASSERT_TRUE(std::filesystem::exists(file)) << file;
  std::ifstream in(file, std::ios::binary);
  const std::string all((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  ASSERT_EQ(first.kernel_symbols.size(), 1u);
  EXPECT_EQ(all, "rbdgrad-cubin 2\n1\n" + first.kernel_symbols[0] + "\n" + first.cubin);
  EXPECT_EQ(std::distance(std::filesystem::directory_iterator(dir.path), std::filesystem::directory_iterator()), 1)
      << "a temporary file was left behind";
}

TEST(KernelCache, ReadsWhatADaemonBeforeItWrote) {
  SKIP_WITHOUT_NVRTC();
  TempDir dir;
  std::filesystem::create_directories(dir.path);
  const cuda::NvrtcProgram p = tiny_program("disk" + std::to_string(::getpid()));
  std::string version;
  ASSERT_TRUE(cuda::nvrtc_version(version).is_ok());
  const std::filesystem::path file = dir.path / (cuda::kernel_cache_key(p, version) + ".cubin");
  std::ofstream(file, std::ios::binary) << "rbdgrad-cubin 2\n2\nsymbol\nother\nnot a real cubin";
  cuda::NvrtcOutput out;
  cuda::KernelOrigin origin{};
  std::string warning;
  ASSERT_TRUE(cuda::compile_with_cache(p, dir.path.string(), false, out, origin, warning).is_ok());
  EXPECT_EQ(origin, cuda::KernelOrigin::kDiskCache);
  EXPECT_THAT(out.kernel_symbols, ::testing::ElementsAre("symbol", "other"));
  EXPECT_EQ(out.cubin, "not a real cubin");
}

TEST(KernelCache, IgnoresFilesItDidNotWriteAndSaysWhenItCannotWrite) {
  SKIP_WITHOUT_NVRTC();
  TempDir dir;
  std::filesystem::create_directories(dir.path);
  std::string version;
  ASSERT_TRUE(cuda::nvrtc_version(version).is_ok());
  cuda::NvrtcOutput out;
  cuda::KernelOrigin origin{};
  std::string warning;
  // another program's file, version 1's (one symbol, no count), and one with fewer symbols than
  // it says: each is compiled again
  int attempt = 0;
  for (const char* text : {"something else", "rbdgrad-cubin 1\nsymbol\ncubin", "rbdgrad-cubin 2\n3\na\nb\n"}) {
    const cuda::NvrtcProgram foreign = tiny_program("foreign" + std::to_string(::getpid()) + "_" + std::to_string(attempt++));
    std::ofstream(dir.path / (cuda::kernel_cache_key(foreign, version) + ".cubin"), std::ios::binary) << text;
    ASSERT_TRUE(cuda::compile_with_cache(foreign, dir.path.string(), false, out, origin, warning).is_ok()) << text;
    EXPECT_EQ(origin, cuda::KernelOrigin::kCompiled) << text;
  }
  // a cache directory that cannot be made: the kernel still compiles, with a warning
  const std::filesystem::path blocked = dir.path / "a_file";
  std::ofstream(blocked) << "x";
  const cuda::NvrtcProgram q = tiny_program("unwritable" + std::to_string(::getpid()));
  ASSERT_TRUE(cuda::compile_with_cache(q, (blocked / "sub").string(), false, out, origin, warning).is_ok());
  EXPECT_EQ(origin, cuda::KernelOrigin::kCompiled);
  EXPECT_THAT(warning, HasSubstr("kernel cache: cannot create"));
}

}  // namespace
}  // namespace rbdgrad::testing
