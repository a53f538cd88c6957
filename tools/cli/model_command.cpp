// `rbdgrad model`: loads a robot model and prints its summary.
#include "model_command.hpp"

#include <iostream>
#include <optional>
#include <vector>

#include "args.hpp"
#include "model_source.hpp"
#include "rbdgrad/model.hpp"

namespace rbdgrad::cli {

namespace {

constexpr OptionSpec kOptions[] = {
    {"model", "NAME|PATH", "embedded robot (hyq, iiwa14, panda, talos_reduced) or URDF file; default iiwa14"},
    {"gravity", "GX,GY,GZ", "world-frame gravity in m/s^2; default 0,0,-9.81"},
    {"help", "", "show this help"},
};

int usage_error(const std::string& message) {
  std::cerr << "rbdgrad model: " << message << "\nusage: rbdgrad model [--model NAME|PATH] (see rbdgrad model --help)\n";
  return 2;
}

}  // namespace

int run_model_command(int argc, const char* const* argv, int first) {
  Args args;
  if (std::string error = Args::parse(kOptions, argc, argv, first, args); !error.empty()) return usage_error(error);
  if (args.has("help")) {
    std::cout << "usage: rbdgrad model [--model NAME|PATH]\n\n" << kModelSummary << ".\n\noptions:\n"
              << format_options(kOptions);
    return 0;
  }
  std::optional<Eigen::Vector3d> gravity;
  if (const std::string* g = args.value("gravity")) {
    std::vector<double> v;
    if (std::string error = parse_numbers(*g, 3, v); !error.empty()) return usage_error("--gravity: " + error);
    gravity = Eigen::Vector3d(v[0], v[1], v[2]);
  }
  Model model;
  if (Status st = load_model(args.value_or("model", "iiwa14"), gravity, model); !st) {
    std::cerr << "rbdgrad model: " << st.to_string() << "\n";
    return 1;
  }
  std::cout << model_summary(model);
  return 0;
}

}  // namespace rbdgrad::cli
