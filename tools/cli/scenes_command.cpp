// `rbdgrad scenes`: prints ListScenes, one block per scene (its model, joints, what it locks,
// gravity, force links and outputs).
#include "scenes_command.hpp"

#include <iostream>

#include "server_connection.hpp"

namespace rbdgrad::cli {

namespace {

constexpr OptionSpec kOptions[] = {kServerOption,    kTlsCaOption,   kTlsCertOption,           kTlsKeyOption,
                                   kTokenFileOption, kTimeoutOption, {"help", "", "show this help"}};

}  // namespace

int run_scenes_command(int argc, const char* const* argv, int first) {
  Args args;
  std::string error = Args::parse(kOptions, argc, argv, first, args);
  if (args.has("help") && error.empty()) {
    std::cout << "usage: rbdgrad scenes [--server ADDR]\n\n"
              << kScenesSummary << ".\n\noptions:\n"
              << format_options(kOptions);
    return 0;
  }
  std::unique_ptr<Client> client;
  if (error.empty()) error = make_client(args, client);
  if (!error.empty()) {
    std::cerr << "rbdgrad scenes: " << error << "\nusage: rbdgrad scenes [--server ADDR] (see rbdgrad scenes --help)\n";
    return 2;
  }
  std::vector<SceneDescription> scenes;
  if (RpcStatus st = client->list_scenes(scenes); !st) return report_rpc_failure("scenes", *client, st);
  if (scenes.empty()) std::cout << "no scenes configured\n";
  for (const SceneDescription& s : scenes) {
    std::cout << s.name << ": model " << s.model << ", " << s.nv << " joints, gravity " << (s.gravity ? "on" : "off")
              << ", M^-1 " << (s.minv_supplied ? "from each request" : "computed") << "\n  outputs:";
    for (Output o : kEveryOutput)
      if (s.outputs & static_cast<std::uint32_t>(o)) std::cout << " " << output_name(o);
    std::cout << "\n  joints:";
    for (const JointDescription& j : s.joints) std::cout << " " << j.name;
    std::cout << "\n";
    if (!s.locked_joints.empty()) {
      std::cout << "  locked:";
      for (const auto& [joint, value] : s.locked_joints) std::cout << " " << joint << "=" << value;
      std::cout << "\n";
    }
    if (!s.force_links.empty()) {
      std::cout << "  force links (fext order):";
      for (const std::string& link : s.force_links) std::cout << " " << link;
      std::cout << "\n";
    }
  }
  return 0;
}

}  // namespace rbdgrad::cli
