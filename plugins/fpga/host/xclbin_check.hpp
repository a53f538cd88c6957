// A structural check of an .xclbin before XRT reads it. XRT 2.13 crashes (empty or 8-byte files)
// or hangs (a truncated header, a section count past the end) on some malformed files instead of
// throwing, and a daemon must not die of a bad path in its configuration (docs/fpga.md lists the
// cases seen). This checks the header, the section table and the array counts of the sections a
// kernel needs; it says nothing of whether the bitstream suits the card.
#pragma once

#include <string>

#include "rbdgrad/status.hpp"

namespace rbdgrad::fpga {

/// ok, or invalid_argument "xclbin '<path>': <what is wrong>".
Status check_xclbin_file(const std::string& path);

}  // namespace rbdgrad::fpga
