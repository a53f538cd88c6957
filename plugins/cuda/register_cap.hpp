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

/// The cap for blocks of `block_shared_bytes` and `threads`: the registers a thread that let as
/// many blocks onto an SM as shared memory does, rounded down to the allocation unit; 0 (no cap)
/// where that is fewer than kMinRegisterCap or no cap at all (at least kMaxRegisters).
inline int block_register_cap(const SmLimits& sm, std::size_t block_shared_bytes, int threads) {
  const int blocks = blocks_by_shared_memory(sm, block_shared_bytes, threads);
  if (blocks <= 0) return 0;
  const int warps_per_block = (threads + 31) / 32;
  const int warps_per_partition = (blocks * warps_per_block + kSmPartitions - 1) / kSmPartitions;
  const int cap = sm.registers / kSmPartitions / (warps_per_partition * 32) / kRegisterGranule * kRegisterGranule;
  return cap < kMinRegisterCap || cap >= kMaxRegisters ? 0 : cap;
}

}  // namespace rbdgrad::cuda
