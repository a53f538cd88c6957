// Tests for chunk_states (plugins/cuda/cuda_instance.cpp): how a large batch is split into the
// chunks that are pipelined (an upload stream, two compute streams, a download stream), the
// block kernel's shape a chunk's launch takes, and the kernel options that set them.
#include <gtest/gtest.h>

#include "cuda_instance.hpp"

namespace rbdgrad::cuda {
namespace {

constexpr int kNv = 7;  // iiwa14: 1024 states per chunk at least
constexpr ChunkRule kAutomatic{};

TEST(CudaChunkPlan, TheSmallestChunkFollowsTheModelsSize) {
  EXPECT_EQ(chunk_min_states(7), 1024u);
  EXPECT_EQ(chunk_min_states(9), 620u);  // 50176 / 81, rounded up
  EXPECT_EQ(chunk_min_states(32), kMinChunkStates);
  EXPECT_EQ(chunk_min_states(64), kMinChunkStates);
}

TEST(CudaChunkPlan, SmallBatchesAreOneChunk) {
  EXPECT_EQ(chunk_states(1, 100000, kAutomatic, kNv), 1u);
  EXPECT_EQ(chunk_states(2047, 100000, kAutomatic, kNv), 2047u);
  EXPECT_EQ(chunk_states(127, 100000, kAutomatic, 32), 127u);
}

TEST(CudaChunkPlan, OnePassIsSplitInUpToEightChunks) {
  EXPECT_EQ(chunk_states(2048, 100000, kAutomatic, kNv), 1024u);
  EXPECT_EQ(chunk_states(3 * 1024 + 5, 100000, kAutomatic, kNv), 1024u + 2);  // 3 chunks, the last one shorter
  EXPECT_EQ(chunk_states(65536, 270336, kAutomatic, kNv), 8192u);
  EXPECT_EQ(chunk_states(1024, 100000, kAutomatic, 32), 128u);
  EXPECT_EQ(chunk_states(100 * 8192, 1000000, kAutomatic, kNv), 100u * 1024);  // never more than 8
}

TEST(CudaChunkPlan, TheRuleSetsTheSmallestChunkAndTheMostChunks) {
  const ChunkRule four_of_8192{8192, 4};
  EXPECT_EQ(chunk_states(2 * 8192 - 1, 100000, four_of_8192, kNv), 2u * 8192 - 1);
  EXPECT_EQ(chunk_states(65536, 270336, four_of_8192, kNv), 16384u);
  EXPECT_EQ(chunk_states(65536, 270336, {1, 1}, kNv), 65536u);
  EXPECT_EQ(chunk_states(4096, 100000, {100, 8}, kNv), 512u);
}

TEST(CudaChunkPlan, SeveralPassesAreSplitAtWholePasses) {
  // talos_reduced on an H200: 7552 slots, 9 passes for 65536 states -> 2 passes per chunk (5 chunks)
  EXPECT_EQ(chunk_states(65536, 7552, kAutomatic, 32), 2u * 7552);
  EXPECT_EQ(chunk_states(65536, 7552, {1, 4}, 32), 3u * 7552);
  EXPECT_EQ(chunk_states(2 * 7552, 7552, kAutomatic, 32), 7552u);
  EXPECT_EQ(chunk_states(2 * 7552 + 1, 7552, kAutomatic, 32), 7552u);  // 3 passes, 3 chunks
  for (std::size_t n : {7553u, 20000u, 65536u, 100001u}) {
    const std::size_t chunk = chunk_states(n, 7552, kAutomatic, 32);
    EXPECT_EQ(chunk % 7552, 0u) << n;
    EXPECT_LE((n + chunk - 1) / chunk, kMaxChunks) << n;
  }
}

// The block kernel's threads a state follow the states of one launch, a chunk's
// (cuda_instance.cpp): talos_reduced's lean build (measured on an H200,
// docs/benchmarks/cuda.md, twenty-fifth session) runs 1024 states in 8 chunks of 128, fewer than
// one an SM, at 256 threads a state (128 there: 29% slower), and 4096 states in chunks of 512 at
// 128 (256 there: 11% slower).
TEST(CudaChunkPlan, ALaunchTakesTheShapeOfItsChunk) {
  const int talos = 32;
  const std::size_t at_1024 = chunk_states(1024, 1024, kAutomatic, talos);
  EXPECT_EQ(at_1024, 128u);
  EXPECT_EQ(block_shape_for({}, talos, at_1024, true).threads_per_state, 256);
  const std::size_t at_4096 = chunk_states(4096, 4096, kAutomatic, talos);
  EXPECT_EQ(at_4096, 512u);
  EXPECT_EQ(block_shape_for({}, talos, at_4096, true).threads_per_state, 128);
  EXPECT_EQ(block_shape_for({}, talos, chunk_states(65536, 65536, kAutomatic, talos), true).threads_per_state, 128);
}

// The defaults: the compact kernel with its lean working set and M^-1 by the tree's chains; the
// lean working set without the compact kernel is refused (the plugin turns it off with
// block_compact: false unless asked for); the chains without it are ignored (they are its).
TEST(CudaChunkPlan, TheLeanCompactKernelIsTheDefault) {
  KernelOptions options;
  EXPECT_TRUE(options.block_compact);
  EXPECT_TRUE(options.block_lean);
  EXPECT_TRUE(check_kernel_options(options));
  options.block_compact = false;
  const Status s = check_kernel_options(options);
  ASSERT_FALSE(s);
  EXPECT_NE(s.message().find("block_lean without block_compact"), std::string::npos) << s.message();
  options.block_lean = false;
  EXPECT_TRUE(options.block_tree_chains);
  // M^-1's columns by the tree's blocks: on, with the chains
  EXPECT_TRUE(options.block_tree_columns);
  EXPECT_TRUE(check_kernel_options(options));
}

TEST(CudaChunkPlan, OptionsOutsideTheRangeAreRefused) {
  KernelOptions options;
  EXPECT_TRUE(check_kernel_options(options));
  options.chunks = {1024, 0};
  EXPECT_FALSE(check_kernel_options(options));
  options.chunks = {1024, kMaxChunks + 1};
  const Status s = check_kernel_options(options);
  ASSERT_FALSE(s);
  EXPECT_NE(s.message().find("1 to " + std::to_string(kMaxChunks) + " chunks"), std::string::npos) << s.message();
  options.chunks = {1, kMaxChunks};
  EXPECT_TRUE(check_kernel_options(options));
}

}  // namespace
}  // namespace rbdgrad::cuda
