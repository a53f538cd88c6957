#include "model_source.hpp"

#include <filesystem>
#include <system_error>

#include "rbdgrad/embedded_robots.hpp"
#include "rbdgrad/urdf.hpp"

namespace rbdgrad::cli {

std::string embedded_robot_list() {
  std::string out;
  for (std::string_view name : embedded_robot_names()) {
    if (!out.empty()) out += ", ";
    out += name;
  }
  return out;
}

Status load_model(const std::string& spec, const std::optional<Eigen::Vector3d>& gravity, Model& model) {
  UrdfOptions options;
  options.gravity = gravity;
  if (const std::string_view urdf = embedded_robot_urdf(spec); !urdf.empty())
    return load_urdf_string(std::string(urdf), spec + ".urdf", model, options);
  std::error_code ec;
  if (!std::filesystem::exists(spec, ec))
    return not_found("model '" + spec + "': not an embedded robot (" + embedded_robot_list() +
                     ") and no such file");
  return load_urdf_file(spec, model, options);
}

}  // namespace rbdgrad::cli
