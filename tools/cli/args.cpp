#include "args.hpp"

#include <algorithm>
#include <charconv>
#include <cmath>

namespace rbdgrad::cli {

namespace {

const OptionSpec* find_spec(std::span<const OptionSpec> specs, std::string_view name) {
  for (const OptionSpec& s : specs)
    if (s.name == name) return &s;
  return nullptr;
}

std::string_view trim(std::string_view s) {
  while (!s.empty() && (s.front() == ' ' || s.front() == '\t')) s.remove_prefix(1);
  while (!s.empty() && (s.back() == ' ' || s.back() == '\t')) s.remove_suffix(1);
  return s;
}

}  // namespace

std::string Args::parse(std::span<const OptionSpec> specs, int argc, const char* const* argv, int first,
                        Args& out) {
  for (int i = first; i < argc; ++i) {
    const std::string_view arg = argv[i];
    // "-h" is the one short option: everybody types it
    if (arg == "-h" && find_spec(specs, "help")) {
      out.values_["help"] = "";
      continue;
    }
    if (arg.size() < 3 || arg.substr(0, 2) != "--") return "unexpected argument '" + std::string(arg) + "'";
    std::string_view name = arg.substr(2);
    std::string_view inline_value;
    const std::size_t eq = name.find('=');
    const bool has_inline = eq != std::string_view::npos;
    if (has_inline) {
      inline_value = name.substr(eq + 1);
      name = name.substr(0, eq);
    }
    const OptionSpec* spec = find_spec(specs, name);
    if (!spec) return "unknown option '--" + std::string(name) + "'";
    const std::string key(name);
    if (out.values_.count(key)) return "option '--" + key + "' given twice";
    if (spec->value_name.empty()) {
      if (has_inline) return "option '--" + key + "' takes no value";
      out.values_[key] = "";
    } else if (has_inline) {
      out.values_[key] = std::string(inline_value);
    } else {
      // a value may start with '-' (a negative number, "-" for stdin) but not with "--"
      if (i + 1 >= argc || std::string_view(argv[i + 1]).substr(0, 2) == "--")
        return "option '--" + key + "' needs a value (" + std::string(spec->value_name) + ")";
      out.values_[key] = argv[++i];
    }
  }
  return "";
}

const std::string* Args::value(std::string_view name) const {
  auto it = values_.find(std::string(name));
  return it == values_.end() ? nullptr : &it->second;
}

std::string Args::value_or(std::string_view name, std::string_view fallback) const {
  const std::string* v = value(name);
  return v ? *v : std::string(fallback);
}

std::string format_options(std::span<const OptionSpec> specs) {
  std::vector<std::string> left;
  std::size_t width = 0;
  for (const OptionSpec& s : specs) {
    std::string l = "  --";
    l.append(s.name);
    if (!s.value_name.empty()) l.append(" ").append(s.value_name);
    width = std::max(width, l.size());
    left.push_back(std::move(l));
  }
  std::string out;
  for (std::size_t k = 0; k < specs.size(); ++k)
    out += left[k] + std::string(width - left[k].size() + 2, ' ') + std::string(specs[k].help) + "\n";
  return out;
}

std::vector<std::string> split_list(std::string_view text, char separator) {
  std::vector<std::string> items;
  while (true) {
    const std::size_t cut = text.find(separator);
    const std::string_view item = trim(text.substr(0, cut));
    if (!item.empty()) items.emplace_back(item);
    if (cut == std::string_view::npos) break;
    text.remove_prefix(cut + 1);
  }
  return items;
}

std::string parse_numbers(std::string_view text, std::size_t count, std::vector<double>& out) {
  out.clear();
  const std::vector<std::string> items = split_list(text);
  if (items.size() != count)
    return "expected " + std::to_string(count) + " comma-separated numbers, got '" + std::string(text) + "'";
  for (const std::string& item : items) {
    double v = 0;
    const auto [end, ec] = std::from_chars(item.data(), item.data() + item.size(), v);
    if (ec != std::errc() || end != item.data() + item.size() || !std::isfinite(v))
      return "'" + item + "' is not a finite number";
    out.push_back(v);
  }
  return "";
}

}  // namespace rbdgrad::cli
