// `rbdgrad scenes`: prints ListScenes, one block per scene (its model, joints, what it locks,
// gravity, force links and outputs). `rbdgrad register-scene`: RegisterScene, then the scene's
// block.
#include "scenes_command.hpp"

#include <charconv>
#include <cmath>
#include <iostream>
#include <optional>
#include <string_view>

#include "server_connection.hpp"

namespace rbdgrad::cli {

namespace {

constexpr OptionSpec kOptions[] = {kServerOption,    kTlsCaOption,   kTlsCertOption,           kTlsKeyOption,
                                   kTokenFileOption, kTimeoutOption, {"help", "", "show this help"}};

constexpr OptionSpec kRegisterOptions[] = {
    {"model", "NAME", "the model the scene is made from (rbdgrad models); required"},
    {"lock", "J=V,...", "joints held fixed and their values (rad or m), e.g. head_1_joint=0,head_2_joint=0.1"},
    {"no-gravity", "", "compute without gravity"},
    {"force-links", "LIST", "comma-separated links that take external forces, in fext's order"},
    {"outputs", "LIST", "comma-separated subset of qdd,minv,dqdd_dq,dqdd_dqd,tau,dtau_dq,dtau_dqd,m; "
                        "default dqdd_dq,dqdd_dqd"},
    {"minv-supplied", "", "each request brings M^-1 (minv) instead of the scene computing it"},
    kServerOption,
    kTlsCaOption,
    kTlsCertOption,
    kTlsKeyOption,
    kTokenFileOption,
    {"timeout", "SECONDS", "deadline of the call; default 60 (the daemon times the scene on its backends)"},
    {"help", "", "show this help"},
};

constexpr const char* kRegisterUsage =
    "usage: rbdgrad register-scene NAME --model M [--lock J=V,...] [--no-gravity] [--force-links A,B]\n"
    "                              [--outputs LIST] [--minv-supplied] [--server ADDR]";

void print_scene(const SceneDescription& s) {
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

// the scene's definition from the options; "" or the usage problem
std::string scene_definition(const Args& args, std::string name, SceneDefinition& out) {
  SceneDefinition def;
  def.name = std::move(name);
  if (def.name.empty()) return "give the scene's NAME first";
  const std::string* model = args.value("model");
  if (model == nullptr || model->empty()) return "--model is required";
  def.model = *model;
  if (const std::string* locks = args.value("lock")) {
    for (const std::string& item : split_list(*locks)) {
      const std::string problem = "--lock: '" + item + "' is not JOINT=VALUE (a finite number)";
      const auto eq = item.find('=');
      if (eq == std::string::npos || eq == 0) return problem;
      double value = 0;
      const char* end = item.data() + item.size();
      const auto [ptr, ec] = std::from_chars(item.data() + eq + 1, end, value);
      if (ec != std::errc() || ptr != end || !std::isfinite(value)) return problem;
      def.locked_joints.emplace_back(item.substr(0, eq), value);
    }
  }
  def.gravity = !args.has("no-gravity");
  if (const std::string* links = args.value("force-links")) def.force_links = split_list(*links);
  if (const std::string* list = args.value("outputs")) {
    for (const std::string& item : split_list(*list)) {
      std::optional<Output> found;
      for (Output o : kEveryOutput)
        if (item == output_name(o)) found = o;
      if (!found)
        return "--outputs: unknown output '" + item + "' (qdd, minv, dqdd_dq, dqdd_dqd, tau, dtau_dq, dtau_dqd, m)";
      def.outputs |= static_cast<std::uint32_t>(*found);
    }
    if (def.outputs == 0) return "--outputs: no output given";
  }
  def.minv_supplied = args.has("minv-supplied");
  out = std::move(def);
  return "";
}

}  // namespace

int run_register_scene_command(int argc, const char* const* argv, int first) {
  // the scene's name comes first, before the options
  std::string name;
  if (first < argc && argv[first][0] != '-') name = argv[first++];
  Args args;
  std::string error = Args::parse(kRegisterOptions, argc, argv, first, args);
  if (args.has("help") && error.empty()) {
    std::cout << kRegisterUsage << "\n\n"
              << kRegisterSceneSummary << ": a model reduced for one problem, checked as a configured\n"
              << "scene, served under NAME until the daemon stops. The same definition again is fine (exit 0);\n"
              << "the scene's joints, printed below, are the order of its states and results.\n\noptions:\n"
              << format_options(kRegisterOptions);
    return 0;
  }
  SceneDefinition def;
  if (error.empty()) error = scene_definition(args, name, def);
  std::unique_ptr<Client> client;
  if (error.empty()) error = make_client(args, client);
  if (!error.empty()) {
    std::cerr << "rbdgrad register-scene: " << error << "\n"
              << kRegisterUsage << "\n(see rbdgrad register-scene --help)\n";
    return 2;
  }
  // the client's default deadline (10 s) is for quick calls: the daemon may time the scene first
  std::optional<std::chrono::nanoseconds> timeout;
  if (!args.has("timeout")) timeout = std::chrono::seconds(60);
  SceneDescription scene;
  if (RpcStatus st = client->register_scene(def, scene, timeout); !st)
    return report_rpc_failure("register-scene", *client, st);
  std::cout << "registered ";
  print_scene(scene);
  return 0;
}

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
  for (const SceneDescription& s : scenes) print_scene(s);
  return 0;
}

}  // namespace rbdgrad::cli
