// Tests for plugins/cuda/register_cap.hpp (the compact block kernel's register cap) with an H200's
// limits, and the compact kernel's shared memory it starts from (block_launch.hpp). No GPU needed.
#include <gtest/gtest.h>

#include <algorithm>

#include "../../support/test_models.hpp"
#include "block_launch.hpp"
#include "flat_model.hpp"
#include "register_cap.hpp"

namespace rbdgrad::testing {
namespace {

// cudaDeviceProp of an H200 (and of an H100 SXM: the same SM)
cuda::SmLimits h200() { return cuda::hopper_sm_limits(); }

// Shared memory of a block of one state (its size does not depend on the threads) for an f64
// batch from tau without a caller's M^-1: the dense kernel, the compact one, or its lean working set.
enum class Build { kDense, kCompact, kLean };
std::size_t talos_block_bytes(Build build, bool minv_supplied = false) {
  const cuda::FlatModel<double> flat(load_embedded("talos_reduced"));
  cuda::BatchPointers<double> batch;
  batch.tau_input = true;
  const double minv = 0;
  if (minv_supplied) batch.minv = &minv;
  const cuda::BlockShape shape{256, 1};
  return build == Build::kDense ? cuda::block_shared_bytes<double>(flat.nv, true, shape)
                                : cuda::compact_block_shared_bytes(flat.host_view(), batch, shape, build == Build::kLean);
}

TEST(RegisterCap, TheCompactKernelFitsFourTalosStatesAnSm) {
  const cuda::SmLimits sm = h200();
  // the other kernel: 73.5 KiB a block, three an SM, no cap needed (ptxas takes 66 registers)
  EXPECT_EQ(talos_block_bytes(Build::kDense), 73504u);
  EXPECT_EQ(cuda::blocks_by_shared_memory(sm, talos_block_bytes(Build::kDense), 256), 3);
  // compact: 912 bytes of the tree and 55,184 of working set (M^-1 and d tau/d u 472 scalars each)
  EXPECT_EQ(talos_block_bytes(Build::kCompact), 912u + 55184u);
  EXPECT_EQ(cuda::blocks_by_shared_memory(sm, talos_block_bytes(Build::kCompact), 256), 4);
  // 4 blocks of 8 warps: 8 warps on each of the 4 sub-partitions, 16K registers each
  EXPECT_EQ(cuda::block_register_cap(sm, talos_block_bytes(Build::kCompact), 256), 64);
  // a caller's M^-1 stays dense: three again, at 80 registers
  EXPECT_EQ(cuda::blocks_by_shared_memory(sm, talos_block_bytes(Build::kCompact, true), 256), 3);
  EXPECT_EQ(cuda::block_register_cap(sm, talos_block_bytes(Build::kCompact, true), 256), 80);
}

TEST(RegisterCap, TheLeanWorkingSetFitsEightTalosStatesAnSmAt128Threads) {
  const cuda::SmLimits sm = h200();
  // 912 bytes of the tree and 27,024 of working set (76 scalars a joint, M^-1 and d tau/d u 472
  // scalars each, two status words): eight blocks by shared memory (8 x (27,936 + 1,024) =
  // 231,680 of 233,472 bytes)
  EXPECT_EQ(talos_block_bytes(Build::kLean), 912u + 27024u);
  EXPECT_EQ(cuda::blocks_by_shared_memory(sm, talos_block_bytes(Build::kLean), 128), 8);
  // eight blocks of 4 warps: 8 warps a sub-partition, 64 registers
  EXPECT_EQ(cuda::block_register_cap(sm, talos_block_bytes(Build::kLean), 128), 64);
  // at 96 threads a state (the benchmark's cuda_pipeline/1chunks-96) eight blocks of 3 warps: 6 a
  // sub-partition, 80 registers
  EXPECT_EQ(cuda::blocks_by_shared_memory(sm, talos_block_bytes(Build::kLean), 96), 8);
  EXPECT_EQ(cuda::block_register_cap(sm, talos_block_bytes(Build::kLean), 96), 80);
  // at 256 threads a state eight blocks (16 warps a sub-partition) would need 32 registers, seven
  // 36: no cap, and the registers decide (ptxas takes 80: three blocks)
  EXPECT_EQ(cuda::blocks_by_shared_memory(sm, talos_block_bytes(Build::kLean), 256), 8);
  EXPECT_EQ(cuda::block_register_cap(sm, talos_block_bytes(Build::kLean), 256), 0);
  // a caller's M^-1 (dense, 1,024 scalars): seven by shared memory; at 192 threads seven would
  // need 40 registers, six 56: no cap
  EXPECT_EQ(cuda::blocks_by_shared_memory(sm, talos_block_bytes(Build::kLean, true), 192), 7);
  EXPECT_EQ(cuda::block_register_cap(sm, talos_block_bytes(Build::kLean, true), 192), 0);
}

// The automatic shape (block_shape_for) and the cap it leads to: the lean working set takes 128
// threads a state for large batches, where its registers at 256 would allow three states an SM.
TEST(RegisterCap, LeanWorkingSetTakes128ThreadsAStateForLargeBatches) {
  const std::size_t large = cuda::kWideStates + 1;
  // talos_reduced (32 joints): 256 threads a state, or 128 with the lean working set
  EXPECT_EQ(cuda::block_shape_for({}, 32, large).threads_per_state, 256);
  EXPECT_EQ(cuda::block_shape_for({}, 32, large, true).threads_per_state, 128);
  // small batches keep 256 (one state's latency counts), small models their fewer threads
  EXPECT_EQ(cuda::block_shape_for({}, 32, cuda::kWideStates, true).threads_per_state, 256);
  EXPECT_EQ(cuda::block_shape_for({}, 7, large, true).threads_per_state, 64);
  // a shape asked for is kept
  EXPECT_EQ(cuda::block_shape_for({192, 1}, 32, large, true).threads_per_state, 192);
  // which gives the lean build eight blocks at 64 registers
  const cuda::BlockShape shape = cuda::block_shape_for({}, 32, large, true);
  EXPECT_EQ(cuda::block_register_cap(h200(), talos_block_bytes(Build::kLean), shape.threads_per_state), 64);
}

TEST(RegisterCap, NoCapBelowWhatSpillsOrAboveTheMost) {
  const cuda::SmLimits sm = h200();
  // iiwa14's blocks (11 KiB, 64 threads): 18 an SM by shared memory would need 56 registers, 17
  // would need 56 too
  const cuda::FlatModel<double> flat(load_embedded("iiwa14"));
  cuda::BatchPointers<double> batch;
  batch.tau_input = true;
  const std::size_t iiwa = cuda::compact_block_shared_bytes(flat.host_view(), batch, cuda::BlockShape{64, 1});
  EXPECT_EQ(cuda::blocks_by_shared_memory(sm, iiwa, 64), 18);
  EXPECT_EQ(cuda::registers_for_blocks(sm, 17, 64), 56);
  EXPECT_EQ(cuda::block_register_cap(sm, iiwa, 64), 0);
  // one block of 32 threads an SM: any count fits
  EXPECT_EQ(cuda::block_register_cap(sm, 200000, 32), 0);
  // nothing fits: no cap
  EXPECT_EQ(cuda::blocks_by_shared_memory(sm, 240000, 256), 0);
  EXPECT_EQ(cuda::block_register_cap(sm, 240000, 256), 0);
}

TEST(RegisterCap, CountsWarpsBySubPartition) {
  const cuda::SmLimits sm = h200();
  // three blocks of 96 threads (3 warps): 9 warps, 3 on one sub-partition: 16384 / 96 = 170 -> 168
  EXPECT_EQ(cuda::block_register_cap(sm, 70000, 96), 168);
  // the same by the SM's total would allow 65536 / 288 = 227
  // threads limit as well: 2048 / 1024 = 2 blocks of 1024 threads, 64 warps, 16 a partition: 32
  // registers, below kMinRegisterCap; one block fewer, 64 (what a block of 1024 threads can have)
  EXPECT_EQ(cuda::blocks_by_shared_memory(sm, 1000, 1024), 2);
  EXPECT_EQ(cuda::block_register_cap(sm, 1000, 1024), 64);
}

// The packed matrices are what the compact kernel saves beyond the constants: a one-root tree has
// nothing to pack, and a block-diagonal tree all its off-block entries.
TEST(RegisterCap, CompactWorkingSetPacksOnlyBetweenBlocks) {
  for (const char* robot : {"iiwa14", "talos_reduced"}) {
    const cuda::FlatModel<double> flat(load_embedded(robot));
    const int n = flat.nv;
    const std::size_t dense = cuda::block_state_scalars(flat.host_view(), true, false, false);
    const std::size_t compact = cuda::block_state_scalars(flat.host_view(), true, false, true);
    EXPECT_EQ(dense - compact, 2u * static_cast<std::size_t>(n * n - flat.matrix_scalars)) << robot;
    // the compact working set: 186 scalars a joint, the two matrices and two status words; the
    // lean one: 64 a joint, a spare region of 12 a joint (more where it and the two matrices would
    // be fewer than the 30 a joint that the passes before the subtree sums need: iiwa14's 12 n + 2
    // x 49 = 182 < 210), the matrices and the status words
    const std::size_t nn = static_cast<std::size_t>(n), matrices = 2u * static_cast<std::size_t>(flat.matrix_scalars);
    const std::size_t spare = std::max(12 * nn, 30 * nn > matrices ? 30 * nn - matrices : 0);
    EXPECT_EQ(compact, 186 * nn + matrices + 2) << robot;
    EXPECT_EQ(cuda::block_state_scalars(flat.host_view(), true, false, true, true), 64 * nn + spare + matrices + 2)
        << robot;
  }
}

}  // namespace
}  // namespace rbdgrad::testing
