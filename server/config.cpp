// The daemon's configuration: YAML file and flag parsing on top of the built-in defaults.
#include "config.hpp"

#include <yaml-cpp/yaml.h>

#include <arpa/inet.h>
#include <netinet/in.h>

#include <cctype>
#include <charconv>
#include <cstdlib>
#include <fstream>
#include <set>
#include <sstream>
#include <string_view>
#include <utility>

namespace rbdgrad::server {
namespace {

constexpr int64_t kMaxInt32 = 2147483647;

// every error names the file, the key path and, when known, the line
class Parser {
 public:
  explicit Parser(std::string name) : name_(std::move(name)) {}

  Status error_at(const std::string& key, const YAML::Node& node, const std::string& what) const {
    std::ostringstream os;
    os << name_ << ": key '" << key << "'";
    if (!node.Mark().is_null()) os << " (line " << node.Mark().line + 1 << ")";
    os << ": " << what;
    return invalid_argument(os.str());
  }

  // unknown keys are errors: a typo must not silently fall back to a default
  Status check_keys(const std::string& prefix, const YAML::Node& map,
                    std::initializer_list<std::string_view> known) const {
    for (const auto& kv : map) {
      const std::string key = kv.first.Scalar();
      bool found = false;
      for (std::string_view k : known) found = found || key == k;
      if (!found) {
        std::ostringstream os;
        os << name_ << ": unknown key '" << (prefix.empty() ? key : prefix + "." + key) << "'";
        if (!kv.first.Mark().is_null()) os << " (line " << kv.first.Mark().line + 1 << ")";
        return invalid_argument(os.str());
      }
    }
    return Status::ok();
  }

  Status require_map(const std::string& key, const YAML::Node& node) const {
    if (!node.IsMap()) return error_at(key, node, "expected a mapping");
    return Status::ok();
  }

  // a null value ("tcp:" or "tcp: ~") reads as the empty string, i.e. "none"
  Status get_string(const std::string& key, const YAML::Node& node, std::string& out) const {
    if (node.IsNull()) {
      out.clear();
      return Status::ok();
    }
    if (!node.IsScalar()) return error_at(key, node, "expected a string");
    out = node.Scalar();
    return Status::ok();
  }

  Status get_int(const std::string& key, const YAML::Node& node, int64_t lo, int64_t hi,
                 int64_t& out) const {
    if (!node.IsScalar()) return error_at(key, node, "expected an integer");
    const std::string& s = node.Scalar();
    int64_t v = 0;
    auto [end, ec] = std::from_chars(s.data(), s.data() + s.size(), v);
    if (ec == std::errc::result_out_of_range) {
      return error_at(key, node, "value '" + s + "' is out of range");
    }
    if (ec != std::errc() || end != s.data() + s.size() || s.empty()) {
      return error_at(key, node, "expected an integer, got '" + s + "'");
    }
    if (v < lo || v > hi) {
      return error_at(key, node, "value " + s + " is outside [" + std::to_string(lo) + ", " +
                                     std::to_string(hi) + "]");
    }
    out = v;
    return Status::ok();
  }

  Status get_double(const std::string& key, const YAML::Node& node, double& out) const {
    if (!node.IsScalar()) return error_at(key, node, "expected a number");
    const std::string& s = node.Scalar();
    char* end = nullptr;
    out = std::strtod(s.c_str(), &end);
    if (s.empty() || end != s.c_str() + s.size()) {
      return error_at(key, node, "expected a number, got '" + s + "'");
    }
    return Status::ok();
  }

  // only "true" and "false": YAML 1.1's yes/no/on/off read too easily as something else
  Status get_bool(const std::string& key, const YAML::Node& node, bool& out) const {
    if (!node.IsScalar() || (node.Scalar() != "true" && node.Scalar() != "false"))
      return error_at(key, node, "expected true or false");
    out = node.Scalar() == "true";
    return Status::ok();
  }

  // `section: {key: "string", ...}` for the sections made only of strings (tls, auth)
  Status parse_strings(const std::string& section, const YAML::Node& node,
                       std::initializer_list<std::pair<std::string_view, std::string*>> fields) const {
    if (node.IsNull()) return Status::ok();
    if (Status s = require_map(section, node); !s) return s;
    for (const auto& kv : node) {
      const std::string key = kv.first.Scalar();
      std::string* dst = nullptr;
      for (const auto& [name, field] : fields) dst = key == name ? field : dst;
      if (dst == nullptr) {
        std::ostringstream os;
        os << name_ << ": unknown key '" << section << "." << key << "'";
        if (!kv.first.Mark().is_null()) os << " (line " << kv.first.Mark().line + 1 << ")";
        return invalid_argument(os.str());
      }
      if (Status s = get_string(section + "." + key, kv.second, *dst); !s) return s;
    }
    return Status::ok();
  }

  Status parse_listen(const YAML::Node& node, ListenConfig& out) const {
    if (Status s = require_map("listen", node); !s) return s;
    if (Status s = check_keys("listen", node, {"tcp", "unix_socket", "insecure"}); !s) return s;
    if (node["insecure"]) {
      if (Status s = get_bool("listen.insecure", node["insecure"], out.insecure); !s) return s;
    }
    if (node["tcp"]) {
      if (Status s = get_string("listen.tcp", node["tcp"], out.tcp); !s) return s;
    }
    if (node["unix_socket"]) {
      if (Status s = get_string("listen.unix_socket", node["unix_socket"], out.unix_socket); !s) {
        return s;
      }
    }
    return Status::ok();
  }

  Status parse_model(const std::string& key, const YAML::Node& node, ModelConfig& out) const {
    if (Status s = require_map(key, node); !s) return s;
    if (Status s = check_keys(key, node, {"name", "urdf", "embedded", "gravity", "locked_joints"}); !s) return s;
    if (!node["name"]) return error_at(key, node, "a model needs a 'name'");
    if (Status s = get_string(key + ".name", node["name"], out.name); !s) return s;
    if (out.name.empty()) return error_at(key + ".name", node["name"], "must not be empty");
    if (node["urdf"]) {
      if (Status s = get_string(key + ".urdf", node["urdf"], out.urdf); !s) return s;
    }
    if (node["embedded"]) {
      if (Status s = get_string(key + ".embedded", node["embedded"], out.embedded); !s) return s;
    }
    // one source per model: which one would win is not obvious to the reader of the file
    if (out.urdf.empty() == out.embedded.empty()) {
      return error_at(key, node, "model '" + out.name + "' needs exactly one of 'urdf' or 'embedded'");
    }
    const YAML::Node g = node["gravity"];
    if (g && !g.IsNull()) {
      if (!g.IsSequence() || g.size() != 3) {
        return error_at(key + ".gravity", g, "expected a list of 3 numbers [gx, gy, gz]");
      }
      std::array<double, 3> v{};
      for (std::size_t i = 0; i < 3; ++i) {
        const std::string k = key + ".gravity[" + std::to_string(i) + "]";
        if (Status s = get_double(k, g[i], v[i]); !s) return s;
      }
      out.gravity = v;
    }
    return parse_locked_joints(key, node["locked_joints"], out.locked_joints);
  }

  // `locked_joints: {joint: value, ...}` of a model or a scene, in the file's order
  Status parse_locked_joints(const std::string& key, const YAML::Node& locked,
                             std::vector<std::pair<std::string, double>>& out) const {
    if (!locked || locked.IsNull()) return Status::ok();
    if (!locked.IsMap()) return error_at(key + ".locked_joints", locked, "expected a map of joint name: value");
    for (const auto& entry : locked) {
      const std::string joint = entry.first.as<std::string>();
      double value = 0;
      if (Status s = get_double(key + ".locked_joints." + joint, entry.second, value); !s) return s;
      out.emplace_back(joint, value);
    }
    return Status::ok();
  }

  // A list of named entries (`models`, `scenes`), each read by `parse_one`, the names unique. The
  // file's list replaces the default list, it does not add to it.
  template <class T>
  Status parse_named_list(const std::string& section, const char* what, const YAML::Node& node,
                          Status (Parser::*parse_one)(const std::string&, const YAML::Node&, T&) const,
                          std::vector<T>& out) const {
    out.clear();
    if (node.IsNull()) return Status::ok();
    if (!node.IsSequence()) return error_at(section, node, "expected a list");
    std::set<std::string> names;
    for (std::size_t i = 0; i < node.size(); ++i) {
      const std::string key = section + "[" + std::to_string(i) + "]";
      T entry;
      if (Status s = (this->*parse_one)(key, node[i], entry); !s) return s;
      if (!names.insert(entry.name).second)
        return error_at(key + ".name", node[i]["name"], std::string("duplicate ") + what + " name '" + entry.name + "'");
      out.push_back(std::move(entry));
    }
    return Status::ok();
  }

  Status parse_scene(const std::string& key, const YAML::Node& node, SceneConfig& out) const {
    if (Status s = require_map(key, node); !s) return s;
    if (Status s = check_keys(key, node, {"name", "model", "locked_joints", "gravity", "force_links", "outputs", "minv"});
        !s)
      return s;
    for (const char* required : {"name", "model"}) {
      if (!node[required]) return error_at(key, node, std::string("a scene needs a '") + required + "'");
    }
    if (Status s = get_string(key + ".name", node["name"], out.name); !s) return s;
    if (out.name.empty()) return error_at(key + ".name", node["name"], "must not be empty");
    if (Status s = get_string(key + ".model", node["model"], out.model); !s) return s;
    if (Status s = parse_locked_joints(key, node["locked_joints"], out.locked_joints); !s) return s;
    if (const YAML::Node g = node["gravity"]) {
      if (!g.IsScalar() || (g.Scalar() != "true" && g.Scalar() != "false"))
        return error_at(key + ".gravity", g, "expected true or false");
      out.gravity = g.Scalar() == "true";
    }
    const auto strings = [&](const char* name, std::vector<std::string>& list) -> Status {
      const YAML::Node n = node[name];
      if (!n || n.IsNull()) return Status::ok();
      if (!n.IsSequence()) return error_at(key + "." + name, n, "expected a list of names");
      list.clear();
      for (std::size_t i = 0; i < n.size(); ++i) {
        std::string v;
        if (Status s = get_string(key + "." + name + "[" + std::to_string(i) + "]", n[i], v); !s) return s;
        list.push_back(std::move(v));
      }
      return Status::ok();
    };
    if (Status s = strings("force_links", out.force_links); !s) return s;
    if (Status s = strings("outputs", out.outputs); !s) return s;
    if (node["minv"]) {
      if (Status s = get_string(key + ".minv", node["minv"], out.minv); !s) return s;
      if (out.minv != "computed" && out.minv != "supplied")
        return error_at(key + ".minv", node["minv"], "expected 'computed' or 'supplied', got '" + out.minv + "'");
    }
    return Status::ok();
  }

  Status parse_plugins(const YAML::Node& node, std::vector<PluginConfig>& out) const {
    out.clear();
    if (node.IsNull()) return Status::ok();
    if (!node.IsSequence()) return error_at("plugins", node, "expected a list");
    for (std::size_t i = 0; i < node.size(); ++i) {
      const std::string key = "plugins[" + std::to_string(i) + "]";
      const YAML::Node p = node[i];
      if (Status s = require_map(key, p); !s) return s;
      if (Status s = check_keys(key, p, {"path", "name", "options", "instances"}); !s) return s;
      PluginConfig plugin;
      if (!p["path"]) return error_at(key, p, "a plugin needs a 'path'");
      if (Status s = get_string(key + ".path", p["path"], plugin.path); !s) return s;
      if (plugin.path.empty()) return error_at(key + ".path", p["path"], "must not be empty");
      if (p["name"]) {
        if (Status s = get_string(key + ".name", p["name"], plugin.name); !s) return s;
        if (!valid_backend_name(plugin.name))
          return error_at(key + ".name", p["name"],
                          "'" + plugin.name + "' is not a backend name: 1 to 32 of a-z, 0-9, '_' and '-'");
        for (const PluginConfig& other : out) {
          if (other.name == plugin.name)
            return error_at(key + ".name", p["name"], "'" + plugin.name + "' is already the name of another plugin");
        }
      }
      const YAML::Node opts = p["options"];
      if (opts && !opts.IsNull()) {
        if (!opts.IsMap()) return error_at(key + ".options", opts, "expected a string mapping");
        for (const auto& kv : opts) {
          const std::string k = kv.first.Scalar();
          std::string v;
          if (Status s = get_string(key + ".options." + k, kv.second, v); !s) return s;
          plugin.options[k] = v;
        }
      }
      if (p["instances"]) {
        if (Status s = get_int(key + ".instances", p["instances"], 1, 64, plugin.instances); !s) return s;
      }
      out.push_back(std::move(plugin));
    }
    return Status::ok();
  }

  Status parse_limits(const YAML::Node& node, LimitsConfig& out) const {
    if (Status s = require_map("limits", node); !s) return s;
    if (Status s = check_keys("limits", node,
                              {"max_states_per_request", "max_message_bytes", "max_concurrent_requests",
                               "max_queue_delay_us", "client_requests_per_second", "client_burst",
                               "client_max_concurrent", "max_registered_scenes"});
        !s) {
      return s;
    }
    struct Field {
      const char* name;
      int64_t lo, hi;
      int64_t* dst;
    };
    const Field fields[] = {
        {"max_states_per_request", 1, kMaxInt32, &out.max_states_per_request},
        {"max_message_bytes", 0, kMaxInt32, &out.max_message_bytes},
        {"max_concurrent_requests", 1, kMaxInt32, &out.max_concurrent_requests},
        {"max_queue_delay_us", 0, 10'000'000, &out.max_queue_delay_us},
        {"client_burst", 0, kMaxInt32, &out.client_burst},
        {"client_max_concurrent", 0, kMaxInt32, &out.client_max_concurrent},
        {"max_registered_scenes", 0, 4096, &out.max_registered_scenes},
    };
    for (const Field& f : fields) {
      if (!node[f.name]) continue;
      if (Status s = get_int(std::string("limits.") + f.name, node[f.name], f.lo, f.hi, *f.dst); !s) {
        return s;
      }
    }
    if (const YAML::Node rate = node["client_requests_per_second"]) {
      const std::string key = "limits.client_requests_per_second";
      double v = 0;
      if (Status s = get_double(key, rate, v); !s) return s;
      // written so that NaN fails too
      if (!(v >= 0 && v <= 1e9)) return error_at(key, rate, "value " + rate.Scalar() + " is outside [0, 1e9]");
      out.client_requests_per_second = v;
    }
    return Status::ok();
  }

  Status parse_scheduler(const YAML::Node& node, SchedulerConfig& out) const {
    if (Status s = require_map("scheduler", node); !s) return s;
    if (Status s = check_keys("scheduler", node,
                              {"policy", "small_n", "large_n", "calibrate", "calibration_file", "calibration_sizes",
                               "preferred_batch_states", "split_min_states", "backend_timeout_ms"});
        !s)
      return s;
    if (node["policy"]) {
      if (Status s = get_string("scheduler.policy", node["policy"], out.policy); !s) return s;
      if (out.policy != "cost" && out.policy != "threshold")
        return error_at("scheduler.policy", node["policy"], "expected cost or threshold; got '" + out.policy + "'");
    }
    for (const auto& [key, dst] : {std::pair{"small_n", &out.small_n}, std::pair{"large_n", &out.large_n}}) {
      if (!node[key]) continue;
      if (Status s = get_int(std::string("scheduler.") + key, node[key], -1, kMaxInt32, *dst); !s) return s;
    }
    if (node["preferred_batch_states"]) {
      if (Status s = get_int("scheduler.preferred_batch_states", node["preferred_batch_states"], 1, kMaxInt32,
                             out.preferred_batch_states);
          !s)
        return s;
    }
    if (node["split_min_states"]) {
      if (Status s = get_int("scheduler.split_min_states", node["split_min_states"], 0, kMaxInt32,
                             out.split_min_states);
          !s)
        return s;
    }
    if (node["backend_timeout_ms"]) {
      if (Status s = get_int("scheduler.backend_timeout_ms", node["backend_timeout_ms"], -1, kMaxInt32,
                             out.backend_timeout_ms);
          !s)
        return s;
    }
    if (node["calibrate"]) {
      if (Status s = get_string("scheduler.calibrate", node["calibrate"], out.calibrate); !s) return s;
      if (out.calibrate != "start" && out.calibrate != "off")
        return error_at("scheduler.calibrate", node["calibrate"], "expected start or off; got '" + out.calibrate + "'");
    }
    if (node["calibration_file"]) {
      if (Status s = get_string("scheduler.calibration_file", node["calibration_file"], out.calibration_file); !s)
        return s;
    }
    if (node["calibration_sizes"]) {
      const YAML::Node list = node["calibration_sizes"];
      if (!list.IsSequence() || list.size() == 0)
        return error_at("scheduler.calibration_sizes", list, "expected a non-empty list of batch sizes");
      out.calibration_sizes.clear();
      for (std::size_t i = 0; i < list.size(); ++i) {
        int64_t n = 0;
        const std::string key = "scheduler.calibration_sizes[" + std::to_string(i) + "]";
        if (Status s = get_int(key, list[i], 1, kMaxInt32, n); !s) return s;
        if (!out.calibration_sizes.empty() && n <= out.calibration_sizes.back())
          return error_at(key, list[i], "sizes must ascend");
        out.calibration_sizes.push_back(n);
      }
    }
    return Status::ok();
  }

  Status parse_root(const YAML::Node& root, ServerConfig& out) const {
    // an empty file keeps every default
    if (root.IsNull()) return Status::ok();
    if (!root.IsMap()) return invalid_argument(name_ + ": the top level must be a mapping");
    if (Status s = check_keys("", root,
                              {"listen", "tls", "auth", "models", "scenes", "plugins", "workers",
                               "inline_max_states", "fixed_point_fallback", "limits", "scheduler", "metrics",
                               "log_level"});
        !s) {
      return s;
    }
    if (root["listen"]) {
      if (Status s = parse_listen(root["listen"], out.listen); !s) return s;
    }
    if (root["tls"]) {
      if (Status s = parse_strings("tls", root["tls"],
                                   {{"cert_file", &out.tls.cert_file},
                                    {"key_file", &out.tls.key_file},
                                    {"client_ca_file", &out.tls.client_ca_file}});
          !s)
        return s;
    }
    if (root["auth"]) {
      if (Status s = parse_strings("auth", root["auth"], {{"tokens_file", &out.auth.tokens_file}}); !s) return s;
    }
    if (root["models"]) {
      if (Status s = parse_named_list("models", "model", root["models"], &Parser::parse_model, out.models); !s) return s;
    }
    if (root["scenes"]) {
      if (Status s = parse_named_list("scenes", "scene", root["scenes"], &Parser::parse_scene, out.scenes); !s) return s;
    }
    if (root["plugins"]) {
      if (Status s = parse_plugins(root["plugins"], out.plugins); !s) return s;
    }
    if (root["workers"]) {
      if (Status s = get_int("workers", root["workers"], 0, 4096, out.workers); !s) return s;
    }
    if (root["inline_max_states"]) {
      if (Status s = get_int("inline_max_states", root["inline_max_states"], 0, kMaxInt32, out.inline_max_states); !s)
        return s;
    }
    if (root["fixed_point_fallback"]) {
      if (Status s = get_string("fixed_point_fallback", root["fixed_point_fallback"], out.fixed_point_fallback); !s)
        return s;
    }
    if (root["limits"]) {
      if (Status s = parse_limits(root["limits"], out.limits); !s) return s;
    }
    if (root["scheduler"]) {
      if (Status s = parse_scheduler(root["scheduler"], out.scheduler); !s) return s;
    }
    if (root["metrics"]) {
      const YAML::Node m = root["metrics"];
      if (Status s = require_map("metrics", m); !s) return s;
      if (Status s = check_keys("metrics", m, {"listen"}); !s) return s;
      if (m["listen"]) {
        if (Status s = get_string("metrics.listen", m["listen"], out.metrics_listen); !s) return s;
      }
    }
    if (root["log_level"]) {
      std::string lvl;
      if (Status s = get_string("log_level", root["log_level"], lvl); !s) return s;
      if (!parse_log_level(lvl, out.log_level)) {
        return error_at("log_level", root["log_level"],
                        "expected one of trace, debug, info, warn, error; got '" + lvl + "'");
      }
    }
    return Status::ok();
  }

 private:
  std::string name_;
};

Status parse_flag_int(const std::string& flag, const std::string& value, int64_t lo, int64_t hi,
                      int64_t& out) {
  int64_t v = 0;
  auto [end, ec] = std::from_chars(value.data(), value.data() + value.size(), v);
  if (ec != std::errc() || end != value.data() + value.size() || value.empty()) {
    return invalid_argument(flag + ": expected an integer, got '" + value + "'");
  }
  if (v < lo || v > hi) {
    return invalid_argument(flag + ": value " + value + " is outside [" + std::to_string(lo) +
                            ", " + std::to_string(hi) + "]");
  }
  out = v;
  return Status::ok();
}

}  // namespace

const char* log_level_name(LogLevel level) noexcept {
  switch (level) {
    case LogLevel::kTrace: return "trace";
    case LogLevel::kDebug: return "debug";
    case LogLevel::kInfo: return "info";
    case LogLevel::kWarn: return "warn";
    case LogLevel::kError: return "error";
  }
  return "unknown";
}

bool parse_log_level(const std::string& name, LogLevel& out) {
  for (LogLevel l : {LogLevel::kTrace, LogLevel::kDebug, LogLevel::kInfo, LogLevel::kWarn,
                     LogLevel::kError}) {
    if (name == log_level_name(l)) {
      out = l;
      return true;
    }
  }
  return false;
}

Status parse_config(const std::string& yaml_text, const std::string& name_for_messages,
                    ServerConfig& out) {
  // yaml-cpp reports syntax errors by throwing: stop them here, at our API boundary
  try {
    const YAML::Node root = YAML::Load(yaml_text);
    return Parser(name_for_messages).parse_root(root, out);
  } catch (const YAML::Exception& e) {
    std::string msg = name_for_messages;
    if (!e.mark.is_null()) msg += ":" + std::to_string(e.mark.line + 1);
    return invalid_argument(msg + ": " + e.msg);
  } catch (const std::exception& e) {
    return invalid_argument(name_for_messages + ": " + e.what());
  }
}

Status load_config_file(const std::string& path, ServerConfig& out) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return not_found("cannot read config file '" + path + "'");
  std::ostringstream text;
  text << in.rdbuf();
  return parse_config(text.str(), path, out);
}

Status apply_flag_overrides(const std::vector<std::string>& args, ServerConfig& cfg) {
  for (std::size_t i = 0; i < args.size(); ++i) {
    std::string flag = args[i];
    std::string value;
    bool has_value = false;
    // "--flag=value" and "--flag value" mean the same
    if (const auto eq = flag.find('='); flag.rfind("--", 0) == 0 && eq != std::string::npos) {
      value = flag.substr(eq + 1);
      flag.resize(eq);
      has_value = true;
    }
    static const std::set<std::string> kKnown = {"--listen", "--unix-socket", "--workers",
                                                 "--log-level", "--max-states"};
    if (kKnown.count(flag) == 0) return invalid_argument("unknown flag '" + flag + "'");
    if (!has_value) {
      if (i + 1 >= args.size()) return invalid_argument(flag + ": missing value");
      value = args[++i];
    }
    if (flag == "--listen") {
      cfg.listen.tcp = value;
    } else if (flag == "--unix-socket") {
      cfg.listen.unix_socket = value;
    } else if (flag == "--workers") {
      if (Status s = parse_flag_int(flag, value, 0, 4096, cfg.workers); !s) return s;
    } else if (flag == "--log-level") {
      if (!parse_log_level(value, cfg.log_level)) {
        return invalid_argument(flag + ": expected one of trace, debug, info, warn, error; got '" +
                                value + "'");
      }
    } else if (flag == "--max-states") {
      if (Status s = parse_flag_int(flag, value, 1, kMaxInt32, cfg.limits.max_states_per_request);
          !s) {
        return s;
      }
    }
  }
  return Status::ok();
}

bool valid_backend_name(const std::string& name) noexcept {
  if (name.empty() || name.size() > 32) return false;
  for (const char c : name) {
    if (!((c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '_' || c == '-')) return false;
  }
  return true;
}

bool is_loopback_address(const std::string& tcp) {
  std::string host;
  if (!tcp.empty() && tcp.front() == '[') {
    const auto close = tcp.find(']');
    if (close == std::string::npos) return false;
    host = tcp.substr(1, close - 1);
  } else {
    const auto colon = tcp.rfind(':');
    host = colon == std::string::npos ? tcp : tcp.substr(0, colon);
  }
  std::string lower;
  for (char c : host) lower += static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  if (lower == "localhost") return true;
  in_addr v4{};
  if (inet_pton(AF_INET, host.c_str(), &v4) == 1) return (ntohl(v4.s_addr) >> 24) == 127;
  in6_addr v6{};
  if (inet_pton(AF_INET6, host.c_str(), &v6) == 1) return IN6_IS_ADDR_LOOPBACK(&v6);
  // anything else, the empty host (every interface) and other names included, may be reachable
  return false;
}

Status check_security(const ServerConfig& cfg) {
  const TlsConfig& tls = cfg.tls;
  if (tls.cert_file.empty() != tls.key_file.empty())
    return invalid_argument("tls.cert_file and tls.key_file go together: set both for TLS, or neither");
  if (!tls.client_ca_file.empty() && !tls.enabled())
    return invalid_argument("tls.client_ca_file (mutual TLS) needs TLS: set tls.cert_file and tls.key_file too");
  if (!cfg.listen.tcp.empty() && !tls.enabled() && !cfg.listen.insecure && !is_loopback_address(cfg.listen.tcp))
    return invalid_argument("listen.tcp '" + cfg.listen.tcp +
                            "' is not a loopback address and TLS is off: set tls.cert_file and tls.key_file, or "
                            "listen.insecure: true to serve it in plaintext anyway");
  return Status::ok();
}

std::string describe(const ServerConfig& cfg) {
  std::ostringstream os;
  os << "listen: tcp " << (cfg.listen.tcp.empty() ? "(off)" : cfg.listen.tcp) << ", unix "
     << (cfg.listen.unix_socket.empty() ? "(off)" : cfg.listen.unix_socket)
     << (cfg.listen.insecure ? ", insecure: true" : "") << "\n";
  os << "tls: ";
  if (!cfg.tls.enabled()) os << "off";
  else os << "cert " << cfg.tls.cert_file << ", key " << cfg.tls.key_file;
  if (!cfg.tls.client_ca_file.empty()) os << ", client CA " << cfg.tls.client_ca_file << " (mutual TLS)";
  os << "\nauth: " << (cfg.auth.tokens_file.empty() ? "off" : "tokens from " + cfg.auth.tokens_file) << "\n";
  os << "models (" << cfg.models.size() << "):\n";
  for (const ModelConfig& m : cfg.models) {
    os << "  " << m.name << ": " << (m.urdf.empty() ? "embedded " + m.embedded : "urdf " + m.urdf);
    if (m.gravity) {
      os << ", gravity [" << (*m.gravity)[0] << ", " << (*m.gravity)[1] << ", " << (*m.gravity)[2]
         << "]";
    }
    os << "\n";
  }
  if (!cfg.scenes.empty()) os << "scenes (" << cfg.scenes.size() << "):\n";
  for (const SceneConfig& sc : cfg.scenes) {
    os << "  " << sc.name << ": model " << sc.model << ", " << sc.locked_joints.size() << " joint(s) locked, gravity "
       << (sc.gravity ? "on" : "off") << ", " << sc.force_links.size() << " force link(s), M^-1 " << sc.minv
       << ", outputs";
    for (const std::string& o : sc.outputs) os << " " << o;
    os << "\n";
  }
  os << "plugins (" << cfg.plugins.size() << ", plus the built-in CPU backend):\n";
  for (const PluginConfig& p : cfg.plugins) {
    os << "  " << (p.name.empty() ? "" : p.name + ": ") << p.path;
    for (const auto& [k, v] : p.options) os << " " << k << "=" << v;
    if (p.instances > 0) os << ", " << p.instances << " instances per model";
    os << "\n";
  }
  os << "workers: ";
  if (cfg.workers == 0) {
    os << "0 (hardware concurrency)\n";
  } else {
    os << cfg.workers << "\n";
  }
  os << "inline_max_states: " << cfg.inline_max_states << "\n";
  os << "fixed_point_fallback: " << (cfg.fixed_point_fallback.empty() ? "none" : cfg.fixed_point_fallback) << "\n";
  os << "limits: max_states_per_request " << cfg.limits.max_states_per_request
     << ", max_message_bytes "
     << (cfg.limits.max_message_bytes == 0 ? std::string("derived") : std::to_string(cfg.limits.max_message_bytes))
     << ", max_concurrent_requests " << cfg.limits.max_concurrent_requests << ", max_queue_delay_us "
     << cfg.limits.max_queue_delay_us << ", per client: " << cfg.limits.client_requests_per_second
     << " requests/s (0 = unlimited), burst " << cfg.limits.client_burst << ", max_concurrent "
     << cfg.limits.client_max_concurrent << ", max_registered_scenes " << cfg.limits.max_registered_scenes << "\n";
  os << "scheduler: policy " << cfg.scheduler.policy;
  if (cfg.scheduler.policy == "threshold")
    os << " (small_n " << cfg.scheduler.small_n << ", large_n " << cfg.scheduler.large_n << "; -1 = from calibration)";
  os << ", calibrate " << cfg.scheduler.calibrate << ", calibration_file "
     << (cfg.scheduler.calibration_file.empty() ? "none" : cfg.scheduler.calibration_file) << ", sizes";
  for (int64_t n : cfg.scheduler.calibration_sizes) os << " " << n;
  os << ", split ";
  if (cfg.scheduler.split_min_states > 0) os << "from " << cfg.scheduler.split_min_states << " states";
  else os << "off";
  os << ", backend timeout ";
  if (cfg.scheduler.backend_timeout_ms < 0) os << "max(1 s, 20x the prediction)";
  else if (cfg.scheduler.backend_timeout_ms == 0) os << "off";
  else os << cfg.scheduler.backend_timeout_ms << " ms";
  os << "\n";
  os << "metrics: " << (cfg.metrics_listen.empty() ? "not served" : "http://" + cfg.metrics_listen + "/metrics") << "\n";
  os << "log_level: " << log_level_name(cfg.log_level) << "\n";
  return os.str();
}

}  // namespace rbdgrad::server
