// Builds a Model from a URDF (urdfdom). The root link is fixed to the world.
#pragma once

#include <Eigen/Core>
#include <optional>
#include <string>

#include "rbdgrad/model.hpp"
#include "rbdgrad/status.hpp"

namespace rbdgrad {

struct UrdfOptions {
  // world-frame gravity in m/s^2; default (0, 0, -9.81)
  std::optional<Eigen::Vector3d> gravity;
};

/// Loads a URDF file.
/// \param[in] path  URDF file; named in every error message.
/// \param[out] model  filled only on success.
/// Errors name the file and the joint or link: malformed XML, closed loops, floating/planar joints
/// ("not supported yet"), a moving body without an <inertial>, invalid inertias, a joint whose
/// subtree has no inertia about its axis (M would be singular).
Status load_urdf_file(const std::string& path, Model& model, const UrdfOptions& options = {});

/// Same from URDF text; `name_for_messages` stands for the file name in errors and in model.source.
Status load_urdf_string(const std::string& xml, const std::string& name_for_messages, Model& model,
                        const UrdfOptions& options = {});

}  // namespace rbdgrad
