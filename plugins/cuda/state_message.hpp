// A failed state's status word (device/state_status.hpp) as the core's Status, with the core's
// message, so that the CUDA and CPU backends fail a state alike.
#pragma once

#include <cstdint>

#include "rbdgrad/model.hpp"
#include "rbdgrad/status.hpp"

namespace rbdgrad::cuda {

/// ok for 0; the joint names come from `model`.
Status state_failure(std::uint32_t status, const Model& model);

}  // namespace rbdgrad::cuda
