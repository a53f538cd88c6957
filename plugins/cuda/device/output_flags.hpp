// The output flags of the plugin ABI (rbdgrad_output) as device code sees them, and the index of
// each flag in BatchPointers::out. cuda_instance.cpp checks that the values agree with plugin_api.h.
#pragma once

#include "spatial.hpp"

namespace rbdgrad::cuda {

inline constexpr std::uint32_t kOutputQdd = 1;
inline constexpr std::uint32_t kOutputMinv = 2;
inline constexpr std::uint32_t kOutputDqddDq = 4;
inline constexpr std::uint32_t kOutputDqddDqd = 8;
inline constexpr std::uint32_t kOutputTau = 16;
inline constexpr std::uint32_t kOutputDtauDq = 32;
inline constexpr std::uint32_t kOutputDtauDqd = 64;
inline constexpr std::uint32_t kOutputM = 128;
inline constexpr int kOutputCount = 8;

// log2 of one flag: 0 for qdd ... 7 for M
constexpr RBDGRAD_HD int output_index(std::uint32_t flag) {
  int i = 0;
  while ((1u << i) != flag) ++i;
  return i;
}

}  // namespace rbdgrad::cuda
