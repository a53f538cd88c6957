// Instance options of the plugin ABI (rbdgrad_options: key/value strings): lookup and parsing with
// messages that name the option.
#pragma once

#include <cstdint>
#include <initializer_list>
#include <string_view>

#include "rbdgrad/plugin_api.h"
#include "rbdgrad/status.hpp"

namespace rbdgrad::plugin {

/// Checks the option list itself and that every key is in `known` (unknown keys are an error, as
/// plugin_api.h says) and appears once. NULL options mean none.
Status check_options(const rbdgrad_options* options, std::initializer_list<std::string_view> known);

/// The value of `key`, or NULL when absent. Call after check_options.
const char* find_option(const rbdgrad_options* options, std::string_view key);

/// Parses option `key` as a decimal integer in [min, max] into `value`, which keeps its default when
/// the option is absent: invalid_argument "option 'threads' is 'abc': expected an integer in [1, 1024]".
Status option_uint(const rbdgrad_options* options, std::string_view key, std::uint64_t min, std::uint64_t max,
                   std::uint64_t& value);

/// Parses option `key` as "true" or "false" into `value`, which keeps its default when the option
/// is absent: invalid_argument "option 'specialize' is 'yes': expected 'true' or 'false'".
Status option_bool(const rbdgrad_options* options, std::string_view key, bool& value);

}  // namespace rbdgrad::plugin
