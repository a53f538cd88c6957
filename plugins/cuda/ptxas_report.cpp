#include "ptxas_report.hpp"

#include <cctype>
#include <cstddef>
#include <sstream>

namespace rbdgrad::cuda {
namespace {

// the name between the first pair of quotes after `at`, or the rest of the line where unquoted
std::string function_name(const std::string& line, std::size_t at) {
  const std::size_t open = line.find('\'', at);
  if (open != std::string::npos) {
    const std::size_t close = line.find('\'', open + 1);
    if (close != std::string::npos) return line.substr(open + 1, close - open - 1);
  }
  std::size_t begin = at;
  while (begin < line.size() && line[begin] == ' ') ++begin;
  std::size_t end = line.size();
  while (end > begin && std::isspace(static_cast<unsigned char>(line[end - 1]))) --end;
  return line.substr(begin, end - begin);
}

// the number just before `what` in `line` ("8 bytes spill stores"), or -1
int number_before(const std::string& line, const char* what) {
  const std::size_t at = line.find(what);
  if (at == std::string::npos) return -1;
  std::size_t end = at;
  while (end > 0 && line[end - 1] == ' ') --end;
  std::size_t begin = end;
  while (begin > 0 && std::isdigit(static_cast<unsigned char>(line[begin - 1]))) --begin;
  return begin < end ? std::stoi(line.substr(begin, end - begin)) : -1;
}

}  // namespace

std::vector<PtxasFunction> ptxas_functions(const std::string& log) {
  std::vector<PtxasFunction> functions;
  std::vector<std::string> entries;
  // (an index: the vector grows)
  std::size_t current = 0;
  bool in_function = false;
  const auto function_named = [&](const std::string& name) {
    for (std::size_t i = 0; i < functions.size(); ++i)
      if (functions[i].name == name) return i;
    functions.push_back(PtxasFunction{name});
    return functions.size() - 1;
  };
  std::istringstream lines(log);
  std::string line;
  static const std::string kEntry = "Compiling entry function ";
  static const std::string kProperties = "Function properties for ";
  while (std::getline(lines, line)) {
    const std::size_t entry_at = line.find(kEntry), properties_at = line.find(kProperties);
    if (entry_at != std::string::npos) {
      entries.push_back(function_name(line, entry_at + kEntry.size()));
    } else if (properties_at != std::string::npos) {
      current = function_named(function_name(line, properties_at + kProperties.size()));
      in_function = true;
    } else if (in_function && line.find("bytes stack frame") != std::string::npos) {
      PtxasFunction& f = functions[current];
      f.stack_frame = number_before(line, "bytes stack frame");
      f.spill_stores = number_before(line, "bytes spill stores");
      f.spill_loads = number_before(line, "bytes spill loads");
    } else if (in_function && line.find("Used ") != std::string::npos) {
      functions[current].registers = number_before(line, "registers");
    }
  }
  for (PtxasFunction& f : functions)
    for (const std::string& e : entries) f.entry = f.entry || f.name == e;
  return functions;
}

PtxasFunction ptxas_entry(const std::string& log) {
  for (PtxasFunction& f : ptxas_functions(log))
    if (f.entry) return f;
  return {};
}

}  // namespace rbdgrad::cuda
