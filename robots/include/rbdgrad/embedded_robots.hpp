// The robot models of robots/*.urdf, compiled into the binaries so that the daemon and the tests
// run without any file next to them. iiwa14 is the default everywhere.
#pragma once

#include <string_view>
#include <vector>

namespace rbdgrad {

inline constexpr std::string_view kDefaultRobot = "iiwa14";

// Names of the embedded robots ("hyq", "iiwa14", "panda", "talos_reduced").
std::vector<std::string_view> embedded_robot_names();

// URDF text of an embedded robot; empty when there is none by that name.
std::string_view embedded_robot_urdf(std::string_view name);

}  // namespace rbdgrad
