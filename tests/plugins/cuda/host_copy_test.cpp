// Tests for plugins/cuda/host_copy.cpp: every byte lands where it belongs, whatever the split.
#include "host_copy.hpp"

#include <gtest/gtest.h>

#include <cstdint>
#include <vector>

namespace rbdgrad::cuda {
namespace {

// blocks of the given sizes, each source filled with its own pattern, copied and compared
void check(const std::vector<std::size_t>& sizes, unsigned max_threads) {
  std::vector<std::vector<std::uint8_t>> from, to;
  std::vector<HostCopy> copies;
  for (std::size_t b = 0; b < sizes.size(); ++b) {
    from.emplace_back(sizes[b]);
    to.emplace_back(sizes[b], 0xEE);
    for (std::size_t i = 0; i < sizes[b]; ++i) from[b][i] = static_cast<std::uint8_t>(i * 31 + b * 7 + (i >> 12));
  }
  for (std::size_t b = 0; b < sizes.size(); ++b) copies.push_back({to[b].data(), from[b].data(), sizes[b]});
  copy_in_parallel(copies, max_threads);
  for (std::size_t b = 0; b < sizes.size(); ++b) EXPECT_EQ(to[b], from[b]) << "block " << b << ", " << max_threads << " threads";
}

TEST(HostCopy, SmallCopiesOnOneThread) {
  check({}, 8);
  check({1, 0, 4095, 70000}, 8);
}

// above the threshold the bytes are split over threads at boundaries that fall inside blocks
TEST(HostCopy, LargeCopiesSplitAcrossBlocksOverThreads) {
  const std::size_t mib = std::size_t{1} << 20;
  for (unsigned threads : {1u, 2u, 3u, 8u}) {
    check({kParallelCopyMinBytes}, threads);
    check({5 * mib + 3, 7, 9 * mib + 1, 0, 3 * mib + 11}, threads);
  }
  EXPECT_GE(host_copy_threads(), 1u);
  EXPECT_LE(host_copy_threads(), 8u);
}

}  // namespace
}  // namespace rbdgrad::cuda
