// The block kernel's shared-memory accesses, traced on the host: its device code (compiled as plain
// C++, the threads of a state's group one after another) runs on a scalar type whose loads and
// stores within the state's working set are recorded with the thread that makes them (as the GPU
// spreads a pass's items, thread_group.hpp's trace hooks) and the site in the code. A warp's
// instruction is then the same site's k-th access by each of its lanes (the warp runs its lanes
// in step), and its cost in shared-memory wavefronts follows from the banks its lanes touch: 32
// banks of 4 bytes, one wavefront for each distinct word a bank must deliver (a broadcast of one
// word is one). So bank conflicts and broadcasts can be counted pass by pass and site by site
// without a GPU (Nsight Compute's figures, docs/benchmarks/cuda.md, are the measured ones; the
// GPU's compiler may merge or repeat loads that the source makes once).
#pragma once

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <dlfcn.h>
#include <map>
#include <string>
#include <tuple>
#include <vector>

// (the device headers' trace hooks: the tool's target defines it for all of them)
#if !defined(RBDGRAD_SHARED_TRACE)
#error "build with RBDGRAD_SHARED_TRACE defined"
#endif
#include "device/thread_group.hpp"

namespace shared_trace {

// One access: the bytes [offset, offset + bytes) of the working set
struct Access {
  const void* site;
  int pass;
  std::uint32_t offset;
  std::uint8_t bytes;
  bool store;
};

// One warp instruction's accesses (its lanes'), and what it costs
struct Instruction {
  int warp = 0, pass = 0;
  const void* site = nullptr;
  bool store = false;
  // a load whose every lane reads words its own thread stored last (values a thread could have
  // kept in its registers, the items mapped as they are)
  bool own = false;
  std::vector<std::pair<int, Access>> lanes;  // (lane, access)
};

// Shared-memory wavefronts of one instruction: for each bank, the distinct 4-byte words its lanes
// ask of it; the busiest bank sets the count (at least 1). Ideal: the distinct words over 32 banks
// (what the same bytes cost without conflicts).
struct Wavefronts {
  int actual = 0, ideal = 0;
};
inline Wavefronts wavefronts(const std::vector<std::pair<int, Access>>& lanes) {
  std::vector<std::uint32_t> words;
  for (const auto& [lane, a] : lanes)
    for (std::uint32_t w = a.offset / 4; w < (a.offset + a.bytes + 3) / 4; ++w) words.push_back(w);
  std::sort(words.begin(), words.end());
  words.erase(std::unique(words.begin(), words.end()), words.end());
  int per_bank[32] = {};
  int busiest = 0;
  for (std::uint32_t w : words) busiest = std::max(busiest, ++per_bank[w % 32]);
  Wavefronts f;
  f.actual = std::max(busiest, 1);
  f.ideal = std::max(static_cast<int>((words.size() + 31) / 32), 1);
  return f;
}

// The recorder: the working set's range, the thread that runs now, every thread's accesses
class Recorder final : public rbdgrad::cuda::SharedTraceThreads {
 public:
  void watch(const void* begin, std::size_t bytes, int threads) {
    begin_ = static_cast<const char*>(begin);
    end_ = begin_ + bytes;
    per_thread_.assign(static_cast<std::size_t>(threads), {});
    thread_ = 0;
    pass_ = 0;
  }
  void thread(int rank) override { thread_ = rank; }
  void sync(bool warp) override {
    if (!warp) ++pass_;
  }
  // an access of `bytes` at p from `site`; a pair's two elements (after pair()) are its one access
  void access(const void* p, int bytes, bool store, const void* site) {
    const char* c = static_cast<const char*>(p);
    if (c < begin_ || c >= end_) return;
    if (skip_ > 0) {
      --skip_;
      return;
    }
    per_thread_.at(static_cast<std::size_t>(thread_))
        .push_back(Access{site, pass_, static_cast<std::uint32_t>(c - begin_), static_cast<std::uint8_t>(bytes), store});
  }
  void pair(const void* p, int bytes, bool store, const void* site) {
    const char* c = static_cast<const char*>(p);
    if (c < begin_ || c >= end_) return;
    access(p, bytes, store, site);
    skip_ = 2;
  }

  // The sites seen, each once
  std::vector<const void*> sites() const {
    std::vector<const void*> out;
    for (const auto& accesses : per_thread_)
      for (const Access& a : accesses) out.push_back(a.site);
    std::sort(out.begin(), out.end());
    out.erase(std::unique(out.begin(), out.end()), out.end());
    return out;
  }

  // The warps' instructions: the k-th access of a site by each lane of a warp, in the order the
  // first lane made them. `same` maps the host compiler's copies of one site (a loop's first
  // iteration peeled, say) to one of them (source_sites below); a site not in it is its own.
  std::vector<Instruction> instructions(const std::map<const void*, const void*>& same = {}) const {
    // whose thread stored each word last, pass by pass (within a pass, the threads one after
    // another: no item reads what another item of its pass writes); own[t][k]: access k of
    // thread t is a load of words thread t stored last
    std::vector<std::vector<bool>> own(per_thread_.size());
    {
      std::map<std::uint32_t, std::size_t> writer;
      std::vector<std::size_t> next(per_thread_.size(), 0);
      for (int pass = 0; pass <= pass_; ++pass)
        for (std::size_t t = 0; t < per_thread_.size(); ++t)
          for (; next[t] < per_thread_[t].size() && per_thread_[t][next[t]].pass == pass; ++next[t]) {
            const Access& a = per_thread_[t][next[t]];
            bool mine = !a.store;
            for (std::uint32_t w = a.offset / 4; w < (a.offset + a.bytes + 3) / 4; ++w) {
              if (a.store) {
                writer[w] = t;
              } else {
                const auto it = writer.find(w);
                mine = mine && it != writer.end() && it->second == t;
              }
            }
            own[t].push_back(mine);
          }
    }
    std::map<std::tuple<int, const void*, int>, std::size_t> index;  // (warp, site, k)
    std::vector<Instruction> out;
    for (std::size_t t = 0; t < per_thread_.size(); ++t) {
      const int warp = static_cast<int>(t / 32), lane = static_cast<int>(t % 32);
      std::map<const void*, int> seen;
      for (std::size_t k = 0; k < per_thread_[t].size(); ++k) {
        const Access& a = per_thread_[t][k];
        const auto found = same.find(a.site);
        const void* site = found == same.end() ? a.site : found->second;
        const auto key = std::make_tuple(warp, site, seen[site]++);
        auto [it, fresh] = index.emplace(key, out.size());
        if (fresh) {
          Instruction i;
          i.warp = warp;
          i.pass = a.pass;
          i.site = site;
          i.store = a.store;
          i.own = !a.store;
          out.push_back(i);
        }
        out[it->second].lanes.emplace_back(lane, a);
        out[it->second].own = out[it->second].own && own[t][k];
      }
    }
    return out;
  }

 private:
  const char* begin_ = nullptr;
  const char* end_ = nullptr;
  int thread_ = 0, pass_ = 0, skip_ = 0;
  std::vector<std::vector<Access>> per_thread_;
};

inline Recorder recorder;

// the site: where the (inlined) scalar operation that calls this returns to
[[gnu::noinline]] inline void record(const void* p, int bytes, bool store) {
  recorder.access(p, bytes, store, __builtin_return_address(0));
}
[[gnu::noinline]] inline void record_pair(const void* p, int bytes, bool store) {
  recorder.pair(p, bytes, store, __builtin_return_address(0));
}

// The source of each site (this program built with -g): its inline frames, innermost first, as
// addr2line gives them (one call for all), and the map that makes the sites of one source the
// same (the copies the host compiler made of one line of code: their frames are the same but for
// the discriminators). Empty where addr2line is not there.
struct SourceSites {
  std::map<const void*, std::vector<std::string>> frames;
  std::map<const void*, const void*> same;
};
inline SourceSites source_sites(const std::vector<const void*>& sites) {
  SourceSites out;
  if (sites.empty()) return out;
  Dl_info info{};
  if (dladdr(sites.front(), &info) == 0 || info.dli_fname == nullptr) return out;
  const auto base = reinterpret_cast<std::uintptr_t>(info.dli_fbase);
  char in_name[] = "/tmp/rbdgrad_sites_XXXXXX";
  const int fd = mkstemp(in_name);
  if (fd < 0) return out;
  FILE* in = fdopen(fd, "w");
  // (the call's return address less one: within the call instruction, on the call's line)
  for (const void* s : sites) std::fprintf(in, "0x%lx\n", static_cast<unsigned long>(reinterpret_cast<std::uintptr_t>(s) - base - 1));
  std::fclose(in);
  const std::string command = std::string("addr2line -a -i -e '") + info.dli_fname + "' < " + in_name + " 2>/dev/null";
  FILE* p = popen(command.c_str(), "r");
  if (p != nullptr) {
    std::size_t k = 0;
    std::vector<std::string>* current = nullptr;
    char line[2048];
    while (std::fgets(line, sizeof line, p) != nullptr) {
      std::string s(line);
      if (!s.empty() && s.back() == '\n') s.pop_back();
      if (s.rfind("0x", 0) == 0) {  // -a: the next address's frames follow
        current = k < sites.size() ? &out.frames[sites[k++]] : nullptr;
        continue;
      }
      if (current == nullptr) continue;
      const auto d = s.find(" (discriminator");
      current->push_back(d == std::string::npos ? s : s.substr(0, d));
    }
    pclose(p);
  }
  std::remove(in_name);
  std::map<std::vector<std::string>, const void*> first;
  for (const auto& [site, f] : out.frames) {
    if (f.empty() || f.front().rfind("??", 0) == 0) continue;
    out.same[site] = first.emplace(f, site).first->second;
  }
  return out;
}

// A double whose copies from the working set are loads and whose assignments into it are stores
struct Traced {
  double v = 0;
  Traced() = default;
  explicit Traced(double x) : v(x) {}
  explicit Traced(int x) : v(x) {}
  [[gnu::always_inline]] Traced(const Traced& o) : v(o.v) { record(&o, sizeof(double), false); }
  [[gnu::always_inline]] Traced& operator=(const Traced& o) {
    record(&o, sizeof(double), false);
    record(this, sizeof(double), true);
    v = o.v;
    return *this;
  }
  Traced operator-() const { return Traced(-v); }
  Traced& operator+=(Traced o) { return assign(v + o.v); }
  Traced& operator-=(Traced o) { return assign(v - o.v); }
  Traced& operator*=(Traced o) { return assign(v * o.v); }
  Traced& operator/=(Traced o) { return assign(v / o.v); }
  friend Traced operator+(Traced a, Traced b) { return Traced(a.v + b.v); }
  friend Traced operator-(Traced a, Traced b) { return Traced(a.v - b.v); }
  friend Traced operator*(Traced a, Traced b) { return Traced(a.v * b.v); }
  friend Traced operator/(Traced a, Traced b) { return Traced(a.v / b.v); }
  friend bool operator==(Traced a, Traced b) { return a.v == b.v; }
  friend bool operator!=(Traced a, Traced b) { return a.v != b.v; }
  friend bool operator<(Traced a, Traced b) { return a.v < b.v; }
  friend bool operator>(Traced a, Traced b) { return a.v > b.v; }
  friend Traced sin(Traced a) { return Traced(std::sin(a.v)); }
  friend Traced cos(Traced a) { return Traced(std::cos(a.v)); }
  friend Traced sqrt(Traced a) { return Traced(std::sqrt(a.v)); }
  friend Traced abs(Traced a) { return Traced(std::abs(a.v)); }

 private:
  // x op= y on an element of the working set: its load and its store
  [[gnu::always_inline]] Traced& assign(double x) {
    record(this, sizeof(double), false);
    record(this, sizeof(double), true);
    v = x;
    return *this;
  }
};

// scalar_pairs.hpp's pair_access for this type: a pair's load or store is one 16-byte access
[[gnu::always_inline]] inline void pair_access(const Traced* p, bool store) { record_pair(p, 2 * sizeof(double), store); }

}  // namespace shared_trace
