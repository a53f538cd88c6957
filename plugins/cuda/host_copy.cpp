#include "host_copy.hpp"

#include <algorithm>
#include <cstring>
#include <thread>
#include <vector>

namespace rbdgrad::cuda {
namespace {

// the bytes [begin, end) of the copies laid end to end
void copy_range(std::span<const HostCopy> copies, std::size_t begin, std::size_t end) {
  std::size_t offset = 0;
  for (const HostCopy& c : copies) {
    const std::size_t lo = std::max(begin, offset), hi = std::min(end, offset + c.bytes);
    if (lo < hi)
      std::memcpy(static_cast<unsigned char*>(c.to) + (lo - offset),
                  static_cast<const unsigned char*>(c.from) + (lo - offset), hi - lo);
    offset += c.bytes;
    if (offset >= end) break;
  }
}

}  // namespace

void copy_in_parallel(std::span<const HostCopy> copies, unsigned max_threads) {
  std::size_t total = 0;
  for (const HostCopy& c : copies) total += c.bytes;
  const std::size_t threads =
      total < kParallelCopyMinBytes ? 1 : std::clamp<std::size_t>(total >> 22, 1, std::max(1u, max_threads));
  if (threads == 1) {
    copy_range(copies, 0, total);
    return;
  }
  const std::size_t share = (total + threads - 1) / threads;
  std::vector<std::thread> helpers;
  std::size_t started = 1;  // ranges handed to helper threads: 1 .. started - 1
  try {
    helpers.reserve(threads - 1);
    for (; started < threads; ++started)
      helpers.emplace_back(copy_range, copies, std::min(total, started * share),
                           std::min(total, (started + 1) * share));
  } catch (...) {
    // no thread to be had: this thread copies what is left
  }
  copy_range(copies, 0, std::min(total, share));
  copy_range(copies, std::min(total, started * share), total);
  for (std::thread& h : helpers) h.join();
}

unsigned host_copy_threads() {
  static const unsigned threads = std::clamp(std::thread::hardware_concurrency(), 1u, 8u);
  return threads;
}

}  // namespace rbdgrad::cuda
