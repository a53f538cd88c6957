#include "options.hpp"

#include <charconv>
#include <string>

namespace rbdgrad::plugin {

Status check_options(const rbdgrad_options* options, std::initializer_list<std::string_view> known) {
  if (options == nullptr) return Status::ok();
  if (options->struct_size < sizeof(rbdgrad_options))
    return invalid_argument("options.struct_size is " + std::to_string(options->struct_size) + ", expected at least " +
                            std::to_string(sizeof(rbdgrad_options)));
  if (options->count == 0) return Status::ok();
  if (options->keys == nullptr || options->values == nullptr)
    return invalid_argument("options.count is " + std::to_string(options->count) + " but options.keys or options.values is NULL");
  for (std::size_t i = 0; i < options->count; ++i) {
    const char* key = options->keys[i];
    if (key == nullptr) return invalid_argument("options.keys[" + std::to_string(i) + "] is NULL");
    if (options->values[i] == nullptr)
      return invalid_argument("option '" + std::string(key) + "' (options.values[" + std::to_string(i) + "]) is NULL");
    bool is_known = false;
    std::string list;
    for (std::string_view k : known) {
      is_known |= k == key;
      list += (list.empty() ? "" : ", ") + std::string(k);
    }
    if (!is_known)
      return invalid_argument("unknown option '" + std::string(key) + "' (known: " + (list.empty() ? "none" : list) + ")");
    for (std::size_t j = 0; j < i; ++j)
      if (std::string_view(options->keys[j]) == key) return invalid_argument("option '" + std::string(key) + "' is given twice");
  }
  return Status::ok();
}

const char* find_option(const rbdgrad_options* options, std::string_view key) {
  if (options == nullptr || options->keys == nullptr || options->values == nullptr) return nullptr;
  for (std::size_t i = 0; i < options->count; ++i)
    if (options->keys[i] != nullptr && key == options->keys[i]) return options->values[i];
  return nullptr;
}

Status option_uint(const rbdgrad_options* options, std::string_view key, std::uint64_t min, std::uint64_t max,
                   std::uint64_t& value) {
  const char* text = find_option(options, key);
  if (text == nullptr) return Status::ok();
  const std::string_view s(text);
  std::uint64_t parsed = 0;
  // from_chars takes digits only: no sign, no spaces, no "0x"; the whole value must be used
  const auto [end, ec] = std::from_chars(s.data(), s.data() + s.size(), parsed);
  if (s.empty() || ec != std::errc() || end != s.data() + s.size() || parsed < min || parsed > max)
    return invalid_argument("option '" + std::string(key) + "' is '" + std::string(s) + "': expected an integer in [" +
                            std::to_string(min) + ", " + std::to_string(max) + "]");
  value = parsed;
  return Status::ok();
}

Status option_bool(const rbdgrad_options* options, std::string_view key, bool& value) {
  const char* text = find_option(options, key);
  if (text == nullptr) return Status::ok();
  const std::string_view s(text);
  if (s != "true" && s != "false")
    return invalid_argument("option '" + std::string(key) + "' is '" + std::string(s) + "': expected 'true' or 'false'");
  value = s == "true";
  return Status::ok();
}

}  // namespace rbdgrad::plugin
