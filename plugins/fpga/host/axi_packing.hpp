// The host's side of the kernel's AXI layout (kernel/axi_layout.hpp): a model and states of
// doubles into device words (Q16.16 raw integers), and results back. Conversions round to nearest
// and refuse what does not fit instead of saturating silently.
#pragma once

#include <string>
#include <vector>

#include "kernel/axi_layout.hpp"
#include "rbdgrad/model.hpp"

namespace rbdgrad::fpga {

/// The robot block. \return false, with the reason, when the model has more than kDeviceMaxNv
/// joints or a constant outside the device format's range.
bool pack_robot(const Model& model, std::vector<DeviceWord>& out, std::string& error);

/// Appends one state's input words: q, qd, u (tau or qdd) and M^-1 (row-major) of nv values each
/// (nv x nv for M^-1); sin and cos of q are computed here. \return false, with the reason, when a
/// value is outside the device format's range.
bool pack_state(int nv, const double* q, const double* qd, const double* u, const double* minv,
                std::vector<DeviceWord>& out, std::string& error);

/// The same into `out`'s AxiLayout::in_words(nv) words (a slot of the kernel's input area); no
/// allocation unless it fails. The words are unspecified after a failure.
bool pack_state(int nv, const double* q, const double* qd, const double* u, const double* minv, DeviceWord* out,
                std::string& error);

/// x as a device word, rounded to nearest; false when it is outside the format's range.
bool to_device_word(double x, DeviceWord& out);

/// One state's results from its output words: qdd (nv), d qdd/d q and d qdd/d qd (nv x nv each).
/// \return false when the kernel flagged the state out of range or did not write it (the outputs
/// are then untouched).
bool unpack_state(int nv, const DeviceWord* words, double* qdd, double* dqdd_dq, double* dqdd_dqd);

}  // namespace rbdgrad::fpga
