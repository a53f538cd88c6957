// A small command-line option parser for the rbdgrad tools (no dependency): `--name value`,
// `--name=value` and `--flag`. Each command declares its options in a table, which also gives
// its --help text, so that the accepted options and their documentation cannot drift apart.
#pragma once

#include <map>
#include <span>
#include <string>
#include <string_view>
#include <vector>

namespace rbdgrad::cli {

struct OptionSpec {
  std::string_view name;        // without the leading "--", e.g. "model"
  std::string_view value_name;  // e.g. "PATH"; empty for a flag that takes no value
  std::string_view help;        // one line; mention the default here
};

class Args {
 public:
  /// Parses argv[first, argc) against `specs`.
  /// \return "" on success, else a message for the user: "unknown option '--foo'",
  ///         "option '--in' needs a value", "option '--help' takes no value", "option '--in' given twice",
  ///         "unexpected argument 'x'". `out` holds what was parsed before the problem.
  static std::string parse(std::span<const OptionSpec> specs, int argc, const char* const* argv, int first,
                           Args& out);

  bool has(std::string_view name) const { return values_.find(std::string(name)) != values_.end(); }
  // nullptr when the option was not given (or is a flag).
  const std::string* value(std::string_view name) const;
  std::string value_or(std::string_view name, std::string_view fallback) const;

 private:
  std::map<std::string, std::string> values_;  // flags map to ""
};

// "  --model NAME|PATH   robot ..." lines, names aligned, for --help.
std::string format_options(std::span<const OptionSpec> specs);

// "a,b,,c" -> {"a", "b", "c"}: empty items are dropped, surrounding spaces trimmed.
std::vector<std::string> split_list(std::string_view text, char separator = ',');

// Parses exactly `count` comma-separated finite numbers ("0,0,-9.81"). Returns "" or the problem.
std::string parse_numbers(std::string_view text, std::size_t count, std::vector<double>& out);

}  // namespace rbdgrad::cli
