// Loads the model a tool was asked for: the name of an embedded robot or a URDF path.
#pragma once

#include <optional>
#include <string>

#include <Eigen/Core>

#include "rbdgrad/model.hpp"
#include "rbdgrad/status.hpp"

namespace rbdgrad::cli {

/// \param[in] spec  an embedded robot name ("iiwa14", ...) or a URDF file path; an embedded name wins
///                  over a file of the same name in the working directory (write "./iiwa14" for the file).
/// \param[in] gravity  world-frame gravity in m/s^2; the loader's default (0, 0, -9.81) when empty.
/// \param[out] model  filled only on success.
/// Errors: not_found "model 'x': not an embedded robot (hyq, iiwa14, ...) and no such file", or the
/// URDF loader's message.
Status load_model(const std::string& spec, const std::optional<Eigen::Vector3d>& gravity, Model& model);

// "hyq, iiwa14, panda, talos_reduced"
std::string embedded_robot_list();

}  // namespace rbdgrad::cli
