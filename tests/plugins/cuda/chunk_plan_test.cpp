// Tests for chunk_states (plugins/cuda/cuda_instance.cpp): how a large batch is split into the
// chunks that are pipelined on two streams.
#include <gtest/gtest.h>

#include "cuda_instance.hpp"

namespace rbdgrad::cuda {
namespace {

TEST(CudaChunkPlan, SmallBatchesAreOneChunk) {
  EXPECT_EQ(chunk_states(1, 100000), 1u);
  EXPECT_EQ(chunk_states(kChunkStates * 2 - 1, 100000), kChunkStates * 2 - 1);
}

TEST(CudaChunkPlan, OnePassIsSplitInUpToFourChunks) {
  EXPECT_EQ(chunk_states(2 * kChunkStates, 100000), kChunkStates);
  EXPECT_EQ(chunk_states(3 * kChunkStates + 5, 100000), kChunkStates + 2);  // 3 chunks, the last one shorter
  EXPECT_EQ(chunk_states(65536, 270336), 16384u);
  EXPECT_EQ(chunk_states(100 * kChunkStates, 1000000), 25 * kChunkStates);  // never more than 4
}

TEST(CudaChunkPlan, SeveralPassesAreSplitAtWholePasses) {
  // talos_reduced on an H200: 7552 slots, 9 passes for 65536 states -> 3 passes per chunk
  EXPECT_EQ(chunk_states(65536, 7552), 3u * 7552);
  EXPECT_EQ(chunk_states(2 * 7552, 7552), 7552u);
  EXPECT_EQ(chunk_states(2 * 7552 + 1, 7552), 7552u);  // 3 passes, 3 chunks
  for (std::size_t n : {7553u, 20000u, 65536u, 100001u}) {
    const std::size_t chunk = chunk_states(n, 7552);
    EXPECT_EQ(chunk % 7552, 0u) << n;
    EXPECT_LE((n + chunk - 1) / chunk, kMaxChunks) << n;
  }
}

}  // namespace
}  // namespace rbdgrad::cuda
