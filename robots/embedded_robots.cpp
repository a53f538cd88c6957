#include "rbdgrad/embedded_robots.hpp"

#include <array>
#include <utility>

namespace rbdgrad {
namespace embedded {
extern const std::string_view k_hyq;
extern const std::string_view k_iiwa14;
extern const std::string_view k_panda;
extern const std::string_view k_talos_reduced;
}  // namespace embedded

namespace {
const std::array<std::pair<std::string_view, const std::string_view*>, 4> kRobots = {{
    {"hyq", &embedded::k_hyq},
    {"iiwa14", &embedded::k_iiwa14},
    {"panda", &embedded::k_panda},
    {"talos_reduced", &embedded::k_talos_reduced},
}};
}  // namespace

std::vector<std::string_view> embedded_robot_names() {
  std::vector<std::string_view> out;
  for (const auto& r : kRobots) out.push_back(r.first);
  return out;
}

std::string_view embedded_robot_urdf(std::string_view name) {
  for (const auto& r : kRobots)
    if (r.first == name) return *r.second;
  return {};
}

}  // namespace rbdgrad
