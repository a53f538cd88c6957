// The first line of a result file, shared by `rbdgrad eval` and `rbdgrad compute` so that their
// files read alike (tests/tools/compare_results.py checks nv, joint_names, precision, outputs).
#pragma once

#include <array>
#include <cstddef>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

namespace rbdgrad::cli {

struct ResultHeader {
  std::string robot;                     // model name
  std::string source;                    // URDF path or "<embedded>"
  int nv = 0;
  std::vector<std::string> joint_names;  // (nv) the order of every array
  std::array<double, 3> gravity{};       // world frame, m/s^2
  std::string precision;                 // "f64", "f32", "fixed"
  std::vector<std::string> outputs;      // eval's names, in file order
  std::string input;                     // the input file
  std::size_t n_states = 0;
  std::string generator;                 // "rbdgrad eval 0.1.0"
};

// The header as an ordered JSON object (keys in the order above, then "convention"); callers may
// add keys before dumping it.
nlohmann::ordered_json result_header_json(const ResultHeader& h);

// One line of JSON, invalid UTF-8 replaced.
std::string dump_header(const nlohmann::ordered_json& header);

}  // namespace rbdgrad::cli
