// The words the FPGA kernel's AXI ports carry, shared by the kernel and the host: every value is
// the raw integer of the device scalar (Q16.16: an int32 holding round(x * 2^16)).
//
// robot (once per batch): nv, then per joint: parent, prismatic (0/1), R0 (9, row-major),
//   p0 (3), spatial inertia (36, row-major); then gravity (3)
// in (per state):  q, sin q, cos q, qd, u (tau or qdd) (nv each), M^-1 (nv x nv, row-major)
// out (per state): qdd (nv), d qdd/d q (nv x nv), d qdd/d qd (nv x nv), status (1 word:
//   kStatusOk, or kStatusOverflow when the state left the format's range: its other words are
//   then not a result). Not 0: memory the kernel never wrote (zeros) must not read as a result.
#pragma once

#include <cstdint>

namespace rbdgrad::fpga {

using DeviceWord = std::int32_t;
inline constexpr int kDeviceMaxNv = 32;  // the largest model one bitstream takes
inline constexpr DeviceWord kStatusOk = 0x52420000;  // "RB" in the high half
inline constexpr DeviceWord kStatusOverflow = kStatusOk | 1;
// The top function's `mode` bits: u holds tau (else qdd); the d/dq or d/dqd datapaths bypassed (a
// scene that does not need those columns: their output words are written as 0).
inline constexpr int kModeTauInput = 1, kModeNoDq = 2, kModeNoDqd = 4;

struct AxiLayout {
  static constexpr int kWordsPerJoint = 2 + 9 + 3 + 36;
  static constexpr int robot_words(int nv) { return 1 + kWordsPerJoint * nv + 3; }
  static constexpr int in_words(int nv) { return 5 * nv + nv * nv; }
  static constexpr int out_words(int nv) { return nv + 2 * nv * nv + 1; }
};

}  // namespace rbdgrad::fpga
