#include "nvrtc_compiler.hpp"

#include <dlfcn.h>
#include <nvrtc.h>

#include <mutex>
#include <type_traits>
#include <utility>


#ifndef RBDGRAD_NVRTC_SONAME
#define RBDGRAD_NVRTC_SONAME "libnvrtc.so"
#endif

namespace rbdgrad::cuda {

namespace {

// The NVRTC entry points used, resolved once per process. The library stays loaded until exit.
struct Nvrtc {
  decltype(&nvrtcVersion) version = nullptr;
  decltype(&nvrtcGetErrorString) error_string = nullptr;
  decltype(&nvrtcCreateProgram) create = nullptr;
  decltype(&nvrtcDestroyProgram) destroy = nullptr;
  decltype(&nvrtcAddNameExpression) add_name_expression = nullptr;
  decltype(&nvrtcCompileProgram) compile = nullptr;
  decltype(&nvrtcGetProgramLogSize) log_size = nullptr;
  decltype(&nvrtcGetProgramLog) log = nullptr;
  decltype(&nvrtcGetCUBINSize) cubin_size = nullptr;
  decltype(&nvrtcGetCUBIN) cubin = nullptr;
  decltype(&nvrtcGetLoweredName) lowered_name = nullptr;
  std::string unavailable;  // why not, when empty the rest is set
};

const Nvrtc& nvrtc() {
  static Nvrtc lib;
  static std::once_flag once;
  std::call_once(once, [] {
    // the soname of the CUDA major version the plugin was built with, then any
    void* handle = nullptr;
    std::string tried;
    for (const char* name : {RBDGRAD_NVRTC_SONAME, "libnvrtc.so"}) {
      handle = dlopen(name, RTLD_NOW | RTLD_LOCAL);
      if (handle) break;
      const char* why = dlerror();
      tried += std::string(tried.empty() ? "" : "; ") + (why ? why : name);
    }
    if (!handle) {
      lib.unavailable = "NVRTC is not installed (" + tried + ")";
      return;
    }
    bool all = true;
    auto get = [&](auto& f, const char* symbol) {
      f = reinterpret_cast<std::remove_reference_t<decltype(f)>>(dlsym(handle, symbol));
      if (!f) {
        all = false;
        lib.unavailable = std::string("NVRTC lacks ") + symbol;
      }
    };
    get(lib.version, "nvrtcVersion");
    get(lib.error_string, "nvrtcGetErrorString");
    get(lib.create, "nvrtcCreateProgram");
    get(lib.destroy, "nvrtcDestroyProgram");
    get(lib.add_name_expression, "nvrtcAddNameExpression");
    get(lib.compile, "nvrtcCompileProgram");
    get(lib.log_size, "nvrtcGetProgramLogSize");
    get(lib.log, "nvrtcGetProgramLog");
    get(lib.cubin_size, "nvrtcGetCUBINSize");
    get(lib.cubin, "nvrtcGetCUBIN");
    get(lib.lowered_name, "nvrtcGetLoweredName");
    if (!all) lib = Nvrtc{.unavailable = lib.unavailable};
  });
  return lib;
}

Status internal(std::string message) { return Status(StatusCode::kInternal, std::move(message)); }

Status nvrtc_error(const Nvrtc& lib, nvrtcResult r, const std::string& what) {
  return internal(what + ": " + lib.error_string(r));
}

}  // namespace

Status nvrtc_version(std::string& version) {
  const Nvrtc& lib = nvrtc();
  if (!lib.unavailable.empty()) return unavailable(lib.unavailable);
  int major = 0, minor = 0;
  if (nvrtcResult r = lib.version(&major, &minor); r != NVRTC_SUCCESS) return nvrtc_error(lib, r, "nvrtcVersion");
  version = std::to_string(major) + "." + std::to_string(minor);
  return Status::ok();
}

Status nvrtc_compile(const NvrtcProgram& program, NvrtcOutput& out) {
  const Nvrtc& lib = nvrtc();
  if (!lib.unavailable.empty()) return unavailable(lib.unavailable);
  std::vector<const char*> header_names, header_texts, options;
  for (const EmbeddedHeader& h : program.headers) {
    header_names.push_back(h.name);
    header_texts.push_back(h.text);
  }
  for (const std::string& o : program.options) options.push_back(o.c_str());
  nvrtcProgram p = nullptr;
  if (nvrtcResult r = lib.create(&p, program.source.c_str(), program.name.c_str(), static_cast<int>(header_names.size()),
                                 header_texts.data(), header_names.data());
      r != NVRTC_SUCCESS)
    return nvrtc_error(lib, r, "nvrtcCreateProgram");
  struct Destroy {
    const Nvrtc& lib;
    nvrtcProgram& p;
    ~Destroy() { lib.destroy(&p); }
  } destroy{lib, p};
  for (const std::string& e : program.name_expressions)
    if (nvrtcResult r = lib.add_name_expression(p, e.c_str()); r != NVRTC_SUCCESS)
      return nvrtc_error(lib, r, "nvrtcAddNameExpression");
  const nvrtcResult compiled = lib.compile(p, static_cast<int>(options.size()), options.data());
  std::size_t log_size = 0;
  if (lib.log_size(p, &log_size) == NVRTC_SUCCESS && log_size > 1) {
    out.log.resize(log_size);
    if (lib.log(p, out.log.data()) != NVRTC_SUCCESS) out.log.clear();
    while (!out.log.empty() && (out.log.back() == '\0' || out.log.back() == '\n')) out.log.pop_back();
  }
  if (compiled != NVRTC_SUCCESS)
    return internal("compiling " + program.name + " with NVRTC: " + lib.error_string(compiled) + "\n" + out.log);
  std::size_t size = 0;
  if (nvrtcResult r = lib.cubin_size(p, &size); r != NVRTC_SUCCESS) return nvrtc_error(lib, r, "nvrtcGetCUBINSize");
  if (size == 0) return internal("NVRTC made no cubin for " + program.name + " (a virtual architecture was asked for)");
  out.cubin.resize(size);
  if (nvrtcResult r = lib.cubin(p, out.cubin.data()); r != NVRTC_SUCCESS) return nvrtc_error(lib, r, "nvrtcGetCUBIN");
  out.kernel_symbols.clear();
  for (const std::string& e : program.name_expressions) {
    const char* lowered = nullptr;
    if (nvrtcResult r = lib.lowered_name(p, e.c_str(), &lowered); r != NVRTC_SUCCESS)
      return nvrtc_error(lib, r, "nvrtcGetLoweredName");
    out.kernel_symbols.push_back(lowered);
  }
  return Status::ok();
}

}  // namespace rbdgrad::cuda
