// Replaces the global operator new/delete with versions that count allocations, for the tests
// that prove a compute path allocates nothing. Include in exactly ONE source file of a test
// executable (it defines the replacement functions), and give such tests their own executable.
#pragma once

#include <atomic>
#include <cstdlib>
#include <new>

namespace rbdgrad::testing {
// number of operator new calls since the program started, on every thread
inline std::atomic<long> g_allocations{0};
}  // namespace rbdgrad::testing

// the replacements below pair malloc-family allocation with free; GCC cannot see that new is replaced
#pragma GCC diagnostic ignored "-Wmismatched-new-delete"

void* operator new(std::size_t size) {
  ++rbdgrad::testing::g_allocations;
  if (void* p = std::malloc(size ? size : 1)) return p;
  throw std::bad_alloc();
}
void* operator new(std::size_t size, std::align_val_t align) {
  ++rbdgrad::testing::g_allocations;
  const std::size_t a = static_cast<std::size_t>(align);
  if (void* p = std::aligned_alloc(a, (size + a - 1) / a * a)) return p;
  throw std::bad_alloc();
}
void operator delete(void* p) noexcept { std::free(p); }
void operator delete(void* p, std::size_t) noexcept { std::free(p); }
void operator delete(void* p, std::align_val_t) noexcept { std::free(p); }
void operator delete(void* p, std::size_t, std::align_val_t) noexcept { std::free(p); }
