// Fuzzes the daemon's configuration loader: the bytes are the text of a YAML file (rbdgradd
// --config). parse_config must answer every input with a Status (it promises never to throw);
// a configuration it accepts then goes through what rbdgradd does next before it serves (main.cpp,
// Daemon::create) as far as that needs no files, sockets or plugins: describe() for the start-up
// log and the model registry (embedded models, locked joints, scenes).
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>

#include "fuzz_support.hpp"
#include "config.hpp"
#include "model_registry.hpp"

using rbdgrad::fuzz::verbose;

namespace {

namespace server = rbdgrad::server;

// more models than this take long to load (each is a URDF parse) without covering anything new
constexpr std::size_t kMaxModels = 8;
constexpr std::size_t kMaxScenes = 8;

[[noreturn]] void fail(const char* what, const std::string& detail) {
  rbdgrad::fuzz::fail("config_fuzzer", what, detail);
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  server::ServerConfig config;
  const rbdgrad::Status parsed = server::parse_config(text, "fuzz.yaml", config);
  if (verbose()) std::fprintf(stderr, "config_fuzzer: parse_config: %s\n", parsed.to_string().c_str());
  if (!parsed) {
    // an error is the expected answer to most inputs; it must say something
    if (parsed.message().empty()) fail("parse_config failed without a message", text);
    return 0;
  }
  (void)server::describe(config);
  (void)server::log_level_name(config.log_level);

  // The model registry reads `urdf` paths from disk: a fuzzed path may name a device or a FIFO
  // that never ends (/dev/zero), so such models load the embedded iiwa14 instead.
  if (config.models.size() > kMaxModels || config.scenes.size() > kMaxScenes) return 0;
  for (server::ModelConfig& m : config.models) {
    if (m.urdf.empty()) continue;
    m.urdf.clear();
    if (m.embedded.empty()) m.embedded = "iiwa14";
  }
  server::ModelRegistry registry;
  const rbdgrad::Status loaded = server::ModelRegistry::load(config.models, config.scenes, registry);
  if (verbose()) std::fprintf(stderr, "config_fuzzer: ModelRegistry::load: %s\n", loaded.to_string().c_str());
  if (!loaded) {
    if (loaded.message().empty()) fail("ModelRegistry::load failed without a message", text);
    return 0;
  }
  // what the daemon logs and serves for each model (Daemon::create, DynamicsService)
  for (const auto& m : registry.models()) {
    if (m->model.nv < 1 || m->desc.desc().nv != static_cast<std::uint32_t>(m->model.nv))
      fail("a loaded model has no joints or a description of another size", m->name);
    if (std::string problem = rbdgrad::validate_model(m->model); !problem.empty())
      fail("the registry serves an invalid model", m->name + ": " + problem);
  }
  return 0;
}
