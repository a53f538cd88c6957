// The registers a thread that the compact block kernel (device/block_kernel_entry.hpp) is built
// for: as few as let onto an SM as many of its blocks as shared memory does. The compact kernel
// exists to fit more states an SM; without a cap, registers would limit them again (talos_reduced's
// f64 kernel takes 66 a thread, and four blocks of 256 threads need at most 64).
#pragma once

#include <algorithm>
#include <cstddef>

namespace rbdgrad::cuda {

/// What an SM offers the blocks resident on it (cudaDeviceProp's fields of the same meaning).
struct SmLimits {
  std::size_t shared_bytes = 0;         // sharedMemPerMultiprocessor
  std::size_t reserved_shared_bytes = 0;  // reservedSharedMemPerBlock: taken by every block
  int registers = 0;                    // regsPerMultiprocessor
  int max_threads = 0;                  // maxThreadsPerMultiProcessor
  int max_blocks = 0;                   // maxBlocksPerMultiProcessor
};

/// An H100 SXM's or an H200's SM (the same SM; their cudaDeviceProp): what the register caps are
/// checked against where no GPU is (the tests, bench/plugins/cuda_kernel_registers.cpp).
inline SmLimits hopper_sm_limits() {
  SmLimits sm;
  sm.shared_bytes = 233472;  // 228 KiB
  sm.reserved_shared_bytes = 1024;
  sm.registers = 65536;
  sm.max_threads = 2048;
  sm.max_blocks = 32;
  return sm;
}

/// An SM's registers are split among its sub-partitions (4 since Volta), each serving the warps it
/// holds: a warp's registers come from its partition's share, so the warps a partition holds,
/// not the SM's, set what each may take (ptxas counts them so for __launch_bounds__).
inline constexpr int kSmPartitions = 4;
/// Registers are allocated a warp at a time in units of 256, 8 a thread.
inline constexpr int kRegisterGranule = 8;
/// Below this ptxas spills the compact kernel's values (talos_reduced at 56: 12 bytes of spill
/// stores), which costs more than the state an SM it gains.
inline constexpr int kMinRegisterCap = 64;
/// The most registers a thread can have.
inline constexpr int kMaxRegisters = 255;

/// Blocks of `block_shared_bytes` (dynamic shared memory) and `threads` an SM holds by shared
/// memory and threads alone.
inline int blocks_by_shared_memory(const SmLimits& sm, std::size_t block_shared_bytes, int threads) {
  const std::size_t per_block = block_shared_bytes + sm.reserved_shared_bytes;
  if (per_block == 0 || threads <= 0) return 0;
  const auto by_shared = static_cast<int>(sm.shared_bytes / per_block);
  return std::min({by_shared, sm.max_threads / threads, sm.max_blocks});
}

/// The registers a thread that let `blocks` blocks of `threads` onto an SM, rounded down to the
/// allocation unit.
inline int registers_for_blocks(const SmLimits& sm, int blocks, int threads) {
  const int warps_per_block = (threads + 31) / 32;
  const int warps_per_partition = (blocks * warps_per_block + kSmPartitions - 1) / kSmPartitions;
  return sm.registers / kSmPartitions / (warps_per_partition * 32) / kRegisterGranule * kRegisterGranule;
}

/// The cap for blocks of `block_shared_bytes` and `threads`: the registers a thread that let as
/// many blocks onto an SM as shared memory does; where that is fewer than kMinRegisterCap, those
/// that let one block fewer (a working set just under a block's share of shared memory, such as
/// talos_reduced's at 256 threads a state: five by shared memory, four at 64 registers, where
/// left uncapped its registers would allow three); 0 (no cap) where neither is at least
/// kMinRegisterCap, or where no cap is needed (at least kMaxRegisters).
inline int block_register_cap(const SmLimits& sm, std::size_t block_shared_bytes, int threads) {
  const int blocks = blocks_by_shared_memory(sm, block_shared_bytes, threads);
  if (blocks <= 0) return 0;
  int cap = registers_for_blocks(sm, blocks, threads);
  if (cap < kMinRegisterCap && blocks > 1) cap = registers_for_blocks(sm, blocks - 1, threads);
  return cap < kMinRegisterCap || cap >= kMaxRegisters ? 0 : cap;
}

}  // namespace rbdgrad::cuda
