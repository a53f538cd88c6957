// `rbdgrad scenes`: the scenes the daemon serves; `rbdgrad register-scene`: one more, at run time.
#pragma once

namespace rbdgrad::cli {

inline constexpr const char* kScenesSummary = "list the scenes the daemon serves (models reduced for one problem)";

/// \return 0, 1 when the call fails (the server's code and message on stderr), 2 on a usage error.
int run_scenes_command(int argc, const char* const* argv, int first);

inline constexpr const char* kRegisterSceneSummary = "register a scene with the running daemon (RegisterScene)";

/// `rbdgrad register-scene NAME --model M [--lock J=V,...] [--no-gravity] [--force-links A,B]
/// [--outputs LIST] [--minv-supplied]`: prints the scene as `scenes` does.
/// \return 0 (registered, or registered before with the same definition), 1 when the call fails
///         (the server's code and message on stderr), 2 on a usage error.
int run_register_scene_command(int argc, const char* const* argv, int first);

}  // namespace rbdgrad::cli
