// The checks every plugin's entry points make on what the host passes before using it: the
// versioned structs' sizes and the can_run question itself. Messages name the field.
#pragma once

#include <cstddef>
#include <cstdint>

#include "rbdgrad/plugin_api.h"
#include "rbdgrad/status.hpp"

namespace rbdgrad::plugin {

/// invalid_argument "info.struct_size is 8, expected at least 48" when `got` < `want`.
Status check_struct_size(const char* what, std::size_t got, std::size_t want);

/// get_info's argument: not NULL, and of at least this build's size.
Status check_info(const rbdgrad_plugin_info* info);

/// describe_instance's argument: not NULL, and at least the 1.1 struct (mode and device).
Status check_instance_info(const rbdgrad_instance_info* info);
/// Whether `info` (checked) has room for the 1.2 field detail.
bool instance_info_has_detail(const rbdgrad_instance_info& info);

/// can_run's model and n, before the backend's own answer: a model (not NULL, of at least the 1.2
/// description's size, nv >= 1) and n >= 1.
Status check_can_run_question(const rbdgrad_model_desc* model, std::uint64_t n);

}  // namespace rbdgrad::plugin
