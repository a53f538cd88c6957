#include "kernel_cache.hpp"

#include <unistd.h>

#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <map>
#include <mutex>
#include <sstream>

namespace rbdgrad::cuda {

namespace {

// A file: "rbdgrad-cubin 2\n", the number of kernels, then each kernel's symbol, each followed by
// "\n", then the cubin to the end. (Version 1's files, one symbol, are not read: compiled again.)
constexpr const char* kFileMagic = "rbdgrad-cubin 2\n";

struct MemoryCache {
  std::mutex mutex;
  std::map<std::string, NvrtcOutput> kernels;
};
MemoryCache& memory_cache() {
  static MemoryCache cache;
  return cache;
}

// FNV-1a, 64 bits, fed field by field with each field's length, so that no two different
// programs feed the same bytes
struct Fnv {
  std::uint64_t h = 14695981039346656037ull;
  void bytes(const void* p, std::size_t n) {
    const auto* c = static_cast<const unsigned char*>(p);
    for (std::size_t k = 0; k < n; ++k) h = (h ^ c[k]) * 1099511628211ull;
  }
  void field(const std::string& s) {
    const std::uint64_t n = s.size();
    bytes(&n, sizeof n);
    bytes(s.data(), s.size());
  }
};

std::string hex(std::uint64_t x) {
  static const char* digits = "0123456789abcdef";
  std::string s(16, '0');
  for (int k = 15; k >= 0; --k, x >>= 4) s[static_cast<std::size_t>(k)] = digits[x & 15];
  return s;
}

bool read_file(const std::filesystem::path& path, NvrtcOutput& out) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return false;
  const std::string all((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const std::string magic = kFileMagic;
  if (all.compare(0, magic.size(), magic) != 0) return false;
  std::size_t at = magic.size();
  // the next line, without its "\n"; false at the end of the file or on an empty line
  const auto line = [&](std::string& text) {
    const std::size_t end = all.find('\n', at);
    if (end == std::string::npos || end == at) return false;
    text = all.substr(at, end - at);
    at = end + 1;
    return true;
  };
  std::string count_text;
  if (!line(count_text) || count_text.size() > 3 || count_text.find_first_not_of("0123456789") != std::string::npos)
    return false;
  out.kernel_symbols.assign(static_cast<std::size_t>(std::stoi(count_text)), "");
  for (std::string& symbol : out.kernel_symbols)
    if (!line(symbol)) return false;
  if (out.kernel_symbols.empty() || at >= all.size()) return false;
  out.cubin = all.substr(at);
  out.log.clear();
  return true;
}

// written under a unique name and renamed: a reader never sees half a file, and two daemons
// writing the same kernel at once leave one whole copy
Status write_file(const std::filesystem::path& path, const NvrtcOutput& kernel) {
  std::error_code ec;
  std::filesystem::create_directories(path.parent_path(), ec);
  if (ec) return unavailable("cannot create the kernel cache " + path.parent_path().string() + ": " + ec.message());
  const std::filesystem::path tmp = path.string() + ".tmp" + std::to_string(::getpid());
  {
    std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
    out << kFileMagic << kernel.kernel_symbols.size() << '\n';
    for (const std::string& symbol : kernel.kernel_symbols) out << symbol << '\n';
    out.write(kernel.cubin.data(), static_cast<std::streamsize>(kernel.cubin.size()));
    if (!out.flush()) {
      std::filesystem::remove(tmp, ec);
      return unavailable("cannot write " + tmp.string());
    }
  }
  std::filesystem::rename(tmp, path, ec);
  if (ec) {
    std::filesystem::remove(tmp, ec);
    return unavailable("cannot rename " + tmp.string() + " to " + path.string());
  }
  return Status::ok();
}

}  // namespace

const char* kernel_origin_name(KernelOrigin origin) {
  switch (origin) {
    case KernelOrigin::kCompiled: return "compiled";
    case KernelOrigin::kMemoryCache: return "memory cache";
    case KernelOrigin::kDiskCache: return "disk cache";
  }
  return "unknown";
}

std::string default_kernel_cache_dir() {
  if (const char* xdg = std::getenv("XDG_CACHE_HOME"); xdg != nullptr && xdg[0] == '/')
    return std::string(xdg) + "/rbdgrad/cuda-kernels";
  if (const char* home = std::getenv("HOME"); home != nullptr && home[0] == '/')
    return std::string(home) + "/.cache/rbdgrad/cuda-kernels";
  return "";
}

std::string kernel_cache_key(const NvrtcProgram& program, const std::string& nvrtc_version) {
  Fnv f;
  f.field(nvrtc_version);
  f.field(program.source);
  f.field(std::to_string(program.name_expressions.size()));
  for (const std::string& e : program.name_expressions) f.field(e);
  for (const std::string& o : program.options) f.field(o);
  for (const EmbeddedHeader& h : program.headers) {
    f.field(h.name);
    f.field(h.text);
  }
  return hex(f.h);
}

Status compile_with_cache(const NvrtcProgram& program, const std::string& dir, bool refresh, NvrtcOutput& out,
                          KernelOrigin& origin, std::string& warning) {
  warning.clear();
  std::string version;
  if (Status s = nvrtc_version(version); !s) return s;
  const std::string key = kernel_cache_key(program, version);
  MemoryCache& cache = memory_cache();
  // one compilation per key at a time: instances of one model loading together wait for the first
  std::lock_guard lock(cache.mutex);
  if (auto found = cache.kernels.find(key); !refresh && found != cache.kernels.end()) {
    out = found->second;
    origin = KernelOrigin::kMemoryCache;
    return Status::ok();
  }
  const std::filesystem::path file = dir.empty() ? std::filesystem::path() : std::filesystem::path(dir) / (key + ".cubin");
  if (!refresh && !dir.empty() && read_file(file, out)) {
    origin = KernelOrigin::kDiskCache;
  } else {
    if (Status s = nvrtc_compile(program, out); !s) return s;
    origin = KernelOrigin::kCompiled;
    if (!dir.empty())
      if (Status s = write_file(file, out); !s) warning = "kernel cache: " + s.message();
  }
  cache.kernels[key] = out;
  return Status::ok();
}

}  // namespace rbdgrad::cuda
