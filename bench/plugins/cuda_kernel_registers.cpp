// Compiles an embedded robot's block kernel (or its warp kernel's entry points) with NVRTC, as the
// CUDA plugin does at model load, and prints ptxas's report on it: registers, stack frame, spills,
// per function. No GPU needed.
// With --headers DIR the device headers are read from DIR (plugins/cuda/device in a source tree)
// in place of those built in, so that an edit to them is checked in one compilation (about 20 s
// for talos_reduced) without rebuilding anything; --cubin FILE writes the code for a disassembler
// (nvdisasm -g on the GPU machine shows where a spill is).
//
// Usage: cuda_kernel_registers [--robot NAME] [--kernel block|warp] [--scalars f64|f64-for-f32|f32|both]
//          [--build compact|lean|chains|columns] [--cap N] [--headers DIR] [--cubin FILE]
// (--kernel warp: the warp kernel's entries for f64 and f32 batches, nv <= 16; --build and --cap
// are the block kernel's)
// Defaults: talos_reduced; f64 and f64 for f32 (both); the plugin's default build for it
// (columns: the lean working set, M^-1 by the tree's chains and its columns by the tree's blocks);
// the register cap the plugin gives that build on an H100 or H200 (64 for talos_reduced's builds
// that compute in f64; none for f32 arithmetic, as in the plugin: register_capped).
// Exit status: 0 when every build compiled without spills, 1 when one spilled, 2 on bad arguments,
// a failed compilation or a log without ptxas's report on the kernel, 77 where NVRTC is not
// installed (CTest's skip).
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "kernel_source.hpp"
#include "nvrtc_compiler.hpp"
#include "ptxas_report.hpp"
#include "register_cap.hpp"
#include "specialized_kernel.hpp"
#include "warp_launch.hpp"
#include "rbdgrad/embedded_robots.hpp"
#include "rbdgrad/urdf.hpp"

namespace {

using rbdgrad::cuda::BlockBuild;
using rbdgrad::cuda::KernelScalars;

struct Options {
  std::string robot = "talos_reduced";
  bool warp = false;
  std::vector<KernelScalars> scalars = {KernelScalars::kF64, KernelScalars::kF64ForF32};
  std::string build = "columns";
  int cap = -1;  // -1: the plugin's
  std::string headers;
  std::string cubin;
};

int usage(const char* why) {
  std::fprintf(stderr,
               "cuda_kernel_registers: %s\nusage: cuda_kernel_registers [--robot NAME] [--kernel block|warp] "
               "[--scalars f64|f64-for-f32|f32|both] [--build compact|lean|chains|columns] [--cap N] "
               "[--headers DIR] [--cubin FILE]\n",
               why);
  return 2;
}

// the program's headers read from dir where it has them (each must be there: a header missing
// from dir would silently compile the built-in one)
bool headers_from(const std::string& dir, rbdgrad::cuda::NvrtcProgram& program, std::vector<std::string>& texts) {
  texts.reserve(program.headers.size());
  for (rbdgrad::cuda::EmbeddedHeader& h : program.headers) {
    const std::string path = dir + "/" + h.name;
    std::ifstream in(path, std::ios::binary);
    if (!in) {
      std::fprintf(stderr, "cuda_kernel_registers: cannot read %s\n", path.c_str());
      return false;
    }
    std::ostringstream text;
    text << in.rdbuf();
    texts.push_back(text.str());
    h.text = texts.back().c_str();
  }
  return true;
}

}  // namespace

int main(int argc, char** argv) {
  Options o;
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    if (arg == "--help" || arg == "-h") {
      usage("the block kernel's registers and spills");
      return 0;
    }
    if (i + 1 >= argc) return usage(("no value after " + arg).c_str());
    const std::string value = argv[++i];
    if (arg == "--robot") {
      o.robot = value;
    } else if (arg == "--kernel") {
      if (value != "block" && value != "warp") return usage(("unknown --kernel " + value).c_str());
      o.warp = value == "warp";
    } else if (arg == "--scalars") {
      if (value == "f64") o.scalars = {KernelScalars::kF64};
      else if (value == "f64-for-f32") o.scalars = {KernelScalars::kF64ForF32};
      else if (value == "f32") o.scalars = {KernelScalars::kF32};
      else if (value != "both") return usage(("unknown --scalars " + value).c_str());
    } else if (arg == "--build") {
      if (value != "compact" && value != "lean" && value != "chains" && value != "columns")
        return usage(("unknown --build " + value).c_str());
      o.build = value;
    } else if (arg == "--cap") {
      char* end = nullptr;
      const long cap = std::strtol(value.c_str(), &end, 10);
      if (end == value.c_str() || *end != '\0' || cap < 0 || cap > 255) return usage("--cap wants 0 to 255");
      o.cap = static_cast<int>(cap);
    } else if (arg == "--headers") {
      o.headers = value;
    } else if (arg == "--cubin") {
      o.cubin = value;
    } else {
      return usage(("unknown argument " + arg).c_str());
    }
  }

  std::string version;
  if (rbdgrad::Status s = rbdgrad::cuda::nvrtc_version(version); !s) {
    std::printf("skipped: no NVRTC on this machine: %s\n", s.message().c_str());
    return 77;
  }
  const std::string_view urdf = rbdgrad::embedded_robot_urdf(o.robot);
  if (urdf.empty()) return usage(("no embedded robot " + o.robot).c_str());
  rbdgrad::Model model;
  if (rbdgrad::Status s = rbdgrad::load_urdf_string(std::string(urdf), o.robot + ".urdf", model); !s)
    return usage(s.to_string().c_str());

  const bool lean = o.build != "compact";
  BlockBuild build;
  build.compact = true;
  build.lean = lean;
  build.tree_chains = o.build == "chains" || o.build == "columns";
  build.tree_columns = o.build == "columns";
  const int plugin_cap = rbdgrad::cuda::compact_register_cap(model, lean, {}, rbdgrad::cuda::hopper_sm_limits());

  if (o.warp && model.nv > rbdgrad::cuda::kMaxWarpNv) return usage(("no warp kernel for " + o.robot).c_str());
  // the warp kernel: one program for f64 and f32 batches (computed in f64 either way)
  if (o.warp) o.scalars = {KernelScalars::kF64};
  bool spilled = false;
  for (const KernelScalars scalars : o.scalars) {
    build.register_cap = o.cap >= 0 ? o.cap : rbdgrad::cuda::register_capped(scalars) ? plugin_cap : 0;
    rbdgrad::cuda::NvrtcProgram program =
        o.warp ? rbdgrad::cuda::warp_kernel_program(model, true, 90)
               : rbdgrad::cuda::block_kernel_program(model, scalars, 90, rbdgrad::cuda::block_stages::kPerBatch, build);
    std::vector<std::string> texts;
    if (!o.headers.empty() && !headers_from(o.headers, program, texts)) return 2;
    program.options.push_back("--ptxas-options=--verbose");
    if (!o.cubin.empty()) program.options.push_back("--generate-line-info");
    const auto start = std::chrono::steady_clock::now();
    rbdgrad::cuda::NvrtcOutput out;
    if (rbdgrad::Status s = rbdgrad::cuda::nvrtc_compile(program, out); !s) {
      std::fprintf(stderr, "cuda_kernel_registers: %s\n", s.message().c_str());
      return 2;
    }
    const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    if (o.warp)
      std::printf("%s (warp kernel, f64 and f32 batches): compiled in %.1f s (NVRTC %s)\n", program.name.c_str(),
                  seconds, version.c_str());
    else
      std::printf("%s (%s, %s): cap %d, compiled in %.1f s (NVRTC %s)\n", program.name.c_str(),
                  rbdgrad::cuda::kernel_scalars_name(scalars), o.build.c_str(), build.register_cap, seconds,
                  version.c_str());
    const std::vector<rbdgrad::cuda::PtxasFunction> functions = rbdgrad::cuda::ptxas_functions(out.log);
    if (std::none_of(functions.begin(), functions.end(), [](const auto& f) { return f.entry && f.registers > 0; })) {
      std::fprintf(stderr, "cuda_kernel_registers: no kernel's registers in ptxas's report:\n%s\n", out.log.c_str());
      return 2;
    }
    for (const rbdgrad::cuda::PtxasFunction& f : functions) {
      std::printf("  %s %s: %d registers, %d bytes stack frame, %d bytes spill stores, %d bytes spill loads\n",
                  f.entry ? "kernel" : "function", f.name.c_str(), f.registers, f.stack_frame, f.spill_stores,
                  f.spill_loads);
      spilled = spilled || f.spill_stores > 0 || f.spill_loads > 0;
    }
    if (!o.cubin.empty()) {
      const std::string path =
          o.scalars.size() > 1 ? o.cubin + "." + (scalars == KernelScalars::kF64 ? "f64" : "f64-for-f32") : o.cubin;
      std::ofstream file(path, std::ios::binary | std::ios::trunc);
      file.write(out.cubin.data(), static_cast<std::streamsize>(out.cubin.size()));
      if (!file.flush()) {
        std::fprintf(stderr, "cuda_kernel_registers: cannot write %s\n", path.c_str());
        return 2;
      }
      std::printf("  cubin: %s\n", path.c_str());
    }
  }
  return spilled ? 1 : 0;
}
