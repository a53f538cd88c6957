// Tests for server/config.cpp.
#include "config.hpp"

#include <gtest/gtest.h>

#include <fstream>
#include <sstream>

namespace rbdgrad::server {
namespace {

std::string read_text(const std::string& path) {
  std::ifstream in(path);
  std::ostringstream os;
  os << in.rdbuf();
  return os.str();
}

TEST(ServerConfigTest, DefaultsAreTheDocumentedValues) {
  const ServerConfig cfg;
  EXPECT_EQ(cfg.listen.tcp, "127.0.0.1:50051");
  EXPECT_EQ(cfg.listen.unix_socket, "/tmp/rbdgradd.sock");
  ASSERT_EQ(cfg.models.size(), 1u);
  EXPECT_EQ(cfg.models[0].name, "iiwa14");
  EXPECT_EQ(cfg.models[0].embedded, "iiwa14");
  EXPECT_TRUE(cfg.models[0].urdf.empty());
  EXPECT_FALSE(cfg.models[0].gravity.has_value());
  EXPECT_TRUE(cfg.plugins.empty());
  EXPECT_EQ(cfg.workers, 0);
  EXPECT_EQ(cfg.inline_max_states, 128);
  EXPECT_EQ(cfg.fixed_point_fallback, "cpu");
  EXPECT_EQ(cfg.limits.max_states_per_request, 65536);
  EXPECT_EQ(cfg.limits.max_message_bytes, 0);  // derived from the models at start-up
  EXPECT_EQ(cfg.limits.max_concurrent_requests, 256);
  EXPECT_EQ(cfg.limits.max_queue_delay_us, 0);
  EXPECT_EQ(cfg.limits.client_requests_per_second, 0.0);
  EXPECT_EQ(cfg.limits.client_burst, 0);
  EXPECT_EQ(cfg.limits.client_max_concurrent, 0);
  EXPECT_FALSE(cfg.listen.insecure);
  EXPECT_EQ(cfg.tls, TlsConfig{});
  EXPECT_FALSE(cfg.tls.enabled());
  EXPECT_EQ(cfg.auth.tokens_file, "");
  EXPECT_EQ(cfg.log_level, LogLevel::kInfo);
}

TEST(ServerConfigTest, DefaultYamlEqualsBuiltInDefaults) {
  const std::string text = read_text(RBDGRAD_DEFAULT_CONFIG_PATH);
  ASSERT_FALSE(text.empty());
  // start from a config that differs everywhere, so every field must come from the file
  ServerConfig cfg;
  cfg.listen = {"x:1", "/y", true};
  cfg.tls = {"/c.pem", "/k.pem", "/ca.pem"};
  cfg.auth.tokens_file = "/t";
  cfg.models = {};
  cfg.plugins = {PluginConfig{"/p.so", {}}};
  cfg.workers = 7;
  cfg.inline_max_states = 9;
  cfg.fixed_point_fallback = "";
  cfg.limits = {1, 2, 3, 4, 5.5, 6, 7, 8};
  cfg.log_level = LogLevel::kError;
  const Status s = parse_config(text, "default.yaml", cfg);
  ASSERT_TRUE(s.is_ok()) << s.to_string();
  EXPECT_EQ(cfg, ServerConfig{});
}

TEST(ServerConfigTest, LoadConfigFileReadsAndReportsMissingFile) {
  ServerConfig cfg;
  EXPECT_TRUE(load_config_file(RBDGRAD_DEFAULT_CONFIG_PATH, cfg).is_ok());
  const Status s = load_config_file("/nonexistent/rbdgradd.yaml", cfg);
  EXPECT_EQ(s.code(), StatusCode::kNotFound);
}

TEST(ServerConfigTest, EmptyFileKeepsDefaults) {
  ServerConfig cfg;
  ASSERT_TRUE(parse_config("", "empty.yaml", cfg).is_ok());
  EXPECT_EQ(cfg, ServerConfig{});
}

TEST(ServerConfigTest, OverridesListen) {
  ServerConfig cfg;
  const Status s = parse_config("listen:\n  tcp: \"0.0.0.0:6000\"\n  unix_socket: \"\"\n", "t", cfg);
  ASSERT_TRUE(s.is_ok()) << s.to_string();
  EXPECT_EQ(cfg.listen.tcp, "0.0.0.0:6000");
  EXPECT_TRUE(cfg.listen.unix_socket.empty());
}

TEST(ServerConfigTest, OverridesModelsReplacingTheDefaultList) {
  ServerConfig cfg;
  const Status s = parse_config(
      "models:\n"
      "  - name: arm\n"
      "    urdf: /robots/arm.urdf\n"
      "    gravity: [0, 0, -1.62]\n"
      "  - name: panda\n"
      "    embedded: panda\n",
      "t", cfg);
  ASSERT_TRUE(s.is_ok()) << s.to_string();
  ASSERT_EQ(cfg.models.size(), 2u);
  EXPECT_EQ(cfg.models[0].name, "arm");
  EXPECT_EQ(cfg.models[0].urdf, "/robots/arm.urdf");
  ASSERT_TRUE(cfg.models[0].gravity.has_value());
  EXPECT_DOUBLE_EQ((*cfg.models[0].gravity)[2], -1.62);
  EXPECT_EQ(cfg.models[1].embedded, "panda");
  EXPECT_FALSE(cfg.models[1].gravity.has_value());
}

TEST(ServerConfigTest, ModelsWithLockedJoints) {
  ServerConfig cfg;
  const Status s = parse_config(
      "models:\n"
      "  - name: wristless\n"
      "    embedded: iiwa14\n"
      "    locked_joints: {iiwa_joint_7: -1, iiwa_joint_6: 0.5}\n",
      "t", cfg);
  ASSERT_TRUE(s.is_ok()) << s.to_string();
  ASSERT_EQ(cfg.models.size(), 1u);
  // in the file's order
  const std::vector<std::pair<std::string, double>> want = {{"iiwa_joint_7", -1.0}, {"iiwa_joint_6", 0.5}};
  EXPECT_EQ(cfg.models[0].locked_joints, want);
  const std::pair<const char*, const char*> bad[] = {
      {"models:\n  - {name: a, embedded: iiwa14, locked_joints: [iiwa_joint_1]}\n",
       "key 'models[0].locked_joints' (line 2): expected a map of joint name: value"},
      {"models:\n  - {name: a, embedded: iiwa14, locked_joints: {iiwa_joint_1: up}}\n",
       "models[0].locked_joints.iiwa_joint_1"},
  };
  for (const auto& [text, want_message] : bad) {
    ServerConfig c;
    const Status e = parse_config(text, "t", c);
    EXPECT_FALSE(e.is_ok()) << text;
    EXPECT_NE(e.message().find(want_message), std::string::npos) << e.message();
  }
}

TEST(ServerConfigTest, Scenes) {
  ServerConfig cfg;
  const Status s = parse_config(
      "scenes:\n"
      "  - name: trot\n"
      "    model: hyq\n"
      "    gravity: false\n"
      "    force_links: [lf_lowerleg, rh_lowerleg]\n"
      "    outputs: [dqdd_dq]\n"
      "    minv: supplied\n"
      "  - name: walk\n"
      "    model: talos\n"
      "    locked_joints: {head_1_joint: 0, head_2_joint: 0.1}\n",
      "t", cfg);
  ASSERT_TRUE(s.is_ok()) << s.to_string();
  ASSERT_EQ(cfg.scenes.size(), 2u);
  const SceneConfig& trot = cfg.scenes[0];
  EXPECT_EQ(trot.model, "hyq");
  EXPECT_FALSE(trot.gravity);
  EXPECT_EQ(trot.force_links, (std::vector<std::string>{"lf_lowerleg", "rh_lowerleg"}));
  EXPECT_EQ(trot.outputs, std::vector<std::string>{"dqdd_dq"});
  EXPECT_EQ(trot.minv, "supplied");
  // the defaults
  const SceneConfig& walk = cfg.scenes[1];
  EXPECT_TRUE(walk.gravity);
  EXPECT_TRUE(walk.force_links.empty());
  EXPECT_EQ(walk.outputs, (std::vector<std::string>{"dqdd_dq", "dqdd_dqd"}));
  EXPECT_EQ(walk.minv, "computed");
  EXPECT_EQ(walk.locked_joints, (std::vector<std::pair<std::string, double>>{{"head_1_joint", 0.0}, {"head_2_joint", 0.1}}));
  EXPECT_NE(describe(cfg).find("trot: model hyq, 0 joint(s) locked, gravity off, 2 force link(s), M^-1 supplied"),
            std::string::npos)
      << describe(cfg);
  const std::pair<const char*, const char*> bad[] = {
      {"scenes:\n  - {name: a}\n", "a scene needs a 'model'"},
      {"scenes:\n  - {model: hyq}\n", "a scene needs a 'name'"},
      {"scenes:\n  - {name: a, model: hyq, gravity: off}\n", "scenes[0].gravity' (line 2): expected true or false"},
      {"scenes:\n  - {name: a, model: hyq, minv: cached}\n", "expected 'computed' or 'supplied', got 'cached'"},
      {"scenes:\n  - {name: a, model: hyq, force_links: lf_lowerleg}\n", "scenes[0].force_links' (line 2): expected a list"},
      {"scenes:\n  - {name: a, model: hyq, fext: []}\n", "fext"},
      {"scenes:\n  - {name: a, model: hyq}\n  - {name: a, model: hyq}\n", "duplicate scene name 'a'"},
  };
  for (const auto& [text, want_message] : bad) {
    ServerConfig c;
    const Status e = parse_config(text, "t", c);
    EXPECT_FALSE(e.is_ok()) << text;
    EXPECT_NE(e.message().find(want_message), std::string::npos) << e.message();
  }
}

TEST(ServerConfigTest, OverridesPlugins) {
  ServerConfig cfg;
  const Status s = parse_config(
      "plugins:\n"
      "  - path: /opt/rbdgrad/libcuda_backend.so\n"
      "    options: {device: \"1\", streams: \"4\"}\n",
      "t", cfg);
  ASSERT_TRUE(s.is_ok()) << s.to_string();
  ASSERT_EQ(cfg.plugins.size(), 1u);
  EXPECT_EQ(cfg.plugins[0].path, "/opt/rbdgrad/libcuda_backend.so");
  EXPECT_EQ(cfg.plugins[0].options.at("device"), "1");
  EXPECT_EQ(cfg.plugins[0].options.at("streams"), "4");
  EXPECT_EQ(cfg.plugins[0].instances, 0) << "not set";
}

TEST(ServerConfigTest, PluginInstancesPerModel) {
  ServerConfig cfg;
  Status s = parse_config(
      "plugins:\n"
      "  - path: /opt/rbdgrad/librbdgrad_cuda.so\n"
      "    instances: 4\n",
      "t", cfg);
  ASSERT_TRUE(s.is_ok()) << s.to_string();
  EXPECT_EQ(cfg.plugins[0].instances, 4);
  for (const char* bad : {"0", "65", "-1", "two"}) {
    s = parse_config(std::string("plugins:\n  - path: /p.so\n    instances: ") + bad + "\n", "t", cfg);
    ASSERT_FALSE(s.is_ok()) << bad;
    EXPECT_NE(s.message().find("plugins[0].instances"), std::string::npos) << s.message();
  }
}

TEST(ServerConfigTest, PluginNames) {
  ServerConfig cfg;
  Status s = parse_config(
      "plugins:\n"
      "  - {path: /opt/rbdgrad/librbdgrad_cuda.so, name: cuda0, options: {device: \"0\"}}\n"
      "  - {path: /opt/rbdgrad/librbdgrad_cuda.so, name: cuda_1-b, options: {device: \"1\"}}\n"
      "  - {path: /opt/rbdgrad/librbdgrad_fpga.so}\n",
      "t", cfg);
  ASSERT_TRUE(s.is_ok()) << s.to_string();
  ASSERT_EQ(cfg.plugins.size(), 3u);
  EXPECT_EQ(cfg.plugins[0].name, "cuda0");
  EXPECT_EQ(cfg.plugins[1].name, "cuda_1-b");
  EXPECT_EQ(cfg.plugins[1].options.at("device"), "1");
  EXPECT_EQ(cfg.plugins[2].name, "") << "not set: the plugin's own";
  EXPECT_NE(describe(cfg).find("cuda0: /opt/rbdgrad/librbdgrad_cuda.so"), std::string::npos) << describe(cfg);
  for (const char* bad : {"\"\"", "Cuda0", "cuda 0", "cuda.0", "gpu/0", "\"abcdefghijabcdefghijabcdefghijabc\"", "[a]"}) {
    s = parse_config(std::string("plugins:\n  - path: /p.so\n    name: ") + bad + "\n", "t", cfg);
    ASSERT_FALSE(s.is_ok()) << bad;
    EXPECT_NE(s.message().find("plugins[0].name"), std::string::npos) << s.message();
  }
  s = parse_config("plugins:\n  - path: /p.so\n    name: abcdefghijabcdefghijabcdefghijab\n", "t", cfg);
  EXPECT_TRUE(s.is_ok()) << "32 characters: " << s.to_string();
  s = parse_config(
      "plugins:\n  - {path: /a.so, name: gpu}\n  - {path: /b.so, name: gpu}\n", "t", cfg);
  ASSERT_FALSE(s.is_ok());
  EXPECT_NE(s.message().find("plugins[1].name"), std::string::npos) << s.message();
  EXPECT_NE(s.message().find("'gpu' is already the name of another plugin"), std::string::npos) << s.message();
}

TEST(ServerConfigTest, OverridesWorkersLimitsAndLogLevelKeepingOtherDefaults) {
  ServerConfig cfg;
  const Status s = parse_config(
      "workers: 12\n"
      "inline_max_states: 0\n"
      "fixed_point_fallback: \"\"\n"
      "limits:\n"
      "  max_states_per_request: 1024\n"
      "  max_queue_delay_us: 500\n"
      "log_level: debug\n",
      "t", cfg);
  ASSERT_TRUE(s.is_ok()) << s.to_string();
  EXPECT_EQ(cfg.workers, 12);
  EXPECT_EQ(cfg.inline_max_states, 0);
  EXPECT_EQ(cfg.fixed_point_fallback, "");  // none: out-of-range states fail their request
  EXPECT_EQ(cfg.limits.max_states_per_request, 1024);
  EXPECT_EQ(cfg.limits.max_queue_delay_us, 500);
  // keys the file leaves out keep their defaults
  EXPECT_EQ(cfg.limits.max_concurrent_requests, 256);
  EXPECT_EQ(cfg.listen, ListenConfig{});
  EXPECT_EQ(cfg.log_level, LogLevel::kDebug);
}

TEST(ServerConfigTest, FixedPointFallbackMustBeAString) {
  ServerConfig cfg;
  const Status s = parse_config("fixed_point_fallback: [cpu]\n", "t", cfg);
  ASSERT_FALSE(s.is_ok());
  EXPECT_NE(s.message().find("fixed_point_fallback"), std::string::npos) << s.message();
}

TEST(ServerConfigTest, SchedulerSection) {
  ServerConfig cfg;
  EXPECT_EQ(cfg.scheduler.policy, "cost");
  EXPECT_EQ(cfg.scheduler.calibrate, "start");
  EXPECT_EQ(cfg.scheduler.calibration_file, "");
  EXPECT_EQ(cfg.scheduler.split_min_states, 4096);
  EXPECT_EQ(cfg.scheduler.backend_timeout_ms, -1) << "from the latency model";
  EXPECT_NE(describe(cfg).find("backend timeout max(1 s, 20x the prediction)"), std::string::npos);
  ASSERT_TRUE(parse_config("scheduler:\n  backend_timeout_ms: 0\n", "t", cfg));
  EXPECT_EQ(cfg.scheduler.backend_timeout_ms, 0);
  EXPECT_NE(describe(cfg).find("backend timeout off"), std::string::npos);
  ASSERT_TRUE(parse_config("scheduler:\n  backend_timeout_ms: 2500\n", "t", cfg));
  EXPECT_EQ(cfg.scheduler.backend_timeout_ms, 2500);
  ASSERT_TRUE(parse_config("scheduler:\n  policy: threshold\n  small_n: 16\n  large_n: 512\n  calibrate: off\n"
                           "  calibration_file: /var/cache/rbdgrad/cal.yaml\n  calibration_sizes: [1, 8, 64]\n"
                           "  preferred_batch_states: 64\n  split_min_states: 0\n",
                           "t", cfg));
  EXPECT_EQ(cfg.scheduler.policy, "threshold");
  EXPECT_EQ(cfg.scheduler.small_n, 16);
  EXPECT_EQ(cfg.scheduler.large_n, 512);
  EXPECT_EQ(cfg.scheduler.calibrate, "off");
  EXPECT_EQ(cfg.scheduler.calibration_file, "/var/cache/rbdgrad/cal.yaml");
  EXPECT_EQ(cfg.scheduler.calibration_sizes, (std::vector<int64_t>{1, 8, 64}));
  EXPECT_EQ(cfg.scheduler.preferred_batch_states, 64);
  EXPECT_EQ(cfg.scheduler.split_min_states, 0);
  EXPECT_NE(describe(cfg).find("split off"), std::string::npos);
  EXPECT_NE(describe(cfg).find("scheduler: policy threshold (small_n 16, large_n 512"), std::string::npos);
  const std::pair<const char*, const char*> bad[] = {
      {"scheduler:\n  policy: fastest\n", "scheduler.policy"},
      {"scheduler:\n  small_n: -2\n", "scheduler.small_n"},
      {"scheduler:\n  calibrate: always\n", "scheduler.calibrate"},
      {"scheduler:\n  calibration_sizes: [4, 4]\n", "sizes must ascend"},
      {"scheduler:\n  calibration_sizes: []\n", "non-empty list"},
      {"scheduler:\n  calibration_sizes: [0]\n", "scheduler.calibration_sizes[0]"},
      {"scheduler:\n  sizes: [1]\n", "unknown key 'scheduler.sizes'"},
      {"scheduler:\n  preferred_batch_states: 0\n", "scheduler.preferred_batch_states"},
      {"scheduler:\n  split_min_states: -1\n", "scheduler.split_min_states"},
      {"scheduler:\n  backend_timeout_ms: -2\n", "scheduler.backend_timeout_ms"},
      {"scheduler:\n  backend_timeout_ms: soon\n", "scheduler.backend_timeout_ms"},
  };
  for (const auto& [text, want] : bad) {
    ServerConfig c;
    const Status s = parse_config(text, "t", c);
    EXPECT_FALSE(s.is_ok()) << text;
    EXPECT_NE(s.message().find(want), std::string::npos) << text << ": " << s.message();
  }
}

TEST(ServerConfigTest, UnknownKeyIsNamedWithItsPath) {
  ServerConfig cfg;
  const Status s = parse_config("limits:\n  max_state: 5\n", "rbdgradd.yaml", cfg);
  ASSERT_FALSE(s.is_ok());
  EXPECT_EQ(s.code(), StatusCode::kInvalidArgument);
  EXPECT_NE(s.message().find("rbdgradd.yaml: unknown key 'limits.max_state'"), std::string::npos)
      << s.message();

  const Status top = parse_config("wokers: 3\n", "rbdgradd.yaml", cfg);
  EXPECT_NE(top.message().find("unknown key 'wokers'"), std::string::npos) << top.message();
}

TEST(ServerConfigTest, WrongTypeNamesKeyAndLine) {
  ServerConfig cfg;
  const Status s = parse_config("log_level: info\nworkers: many\n", "rbdgradd.yaml", cfg);
  ASSERT_FALSE(s.is_ok());
  EXPECT_NE(s.message().find("'workers'"), std::string::npos) << s.message();
  EXPECT_NE(s.message().find("line 2"), std::string::npos) << s.message();
}

TEST(ServerConfigTest, OutOfRangeNamesKeyAndLine) {
  ServerConfig cfg;
  const Status s =
      parse_config("limits:\n  max_concurrent_requests: 0\n", "rbdgradd.yaml", cfg);
  ASSERT_FALSE(s.is_ok());
  EXPECT_NE(s.message().find("'limits.max_concurrent_requests'"), std::string::npos)
      << s.message();
  EXPECT_NE(s.message().find("line 2"), std::string::npos) << s.message();

  const Status lvl = parse_config("log_level: loud\n", "rbdgradd.yaml", cfg);
  EXPECT_NE(lvl.message().find("'log_level'"), std::string::npos) << lvl.message();
}

TEST(ServerConfigTest, ModelNeedsExactlyOneSource) {
  ServerConfig cfg;
  const Status both = parse_config(
      "models:\n  - name: a\n    urdf: /a.urdf\n    embedded: iiwa14\n", "t", cfg);
  ASSERT_FALSE(both.is_ok());
  EXPECT_NE(both.message().find("exactly one of"), std::string::npos) << both.message();

  const Status neither = parse_config("models:\n  - name: a\n", "t", cfg);
  EXPECT_FALSE(neither.is_ok());
}

TEST(ServerConfigTest, SyntaxErrorIsAStatusNotAnException) {
  ServerConfig cfg;
  const Status s = parse_config("listen: [unclosed\n", "bad.yaml", cfg);
  ASSERT_FALSE(s.is_ok());
  EXPECT_EQ(s.message().rfind("bad.yaml", 0), 0u) << s.message();
}

TEST(ServerConfigTest, FlagsOverrideTheFile) {
  ServerConfig cfg;
  ASSERT_TRUE(parse_config("workers: 2\nlog_level: warn\n", "t", cfg).is_ok());
  const Status s = apply_flag_overrides({"--listen", "0.0.0.0:7000", "--unix-socket=", "--workers",
                                         "8", "--log-level=trace", "--max-states", "99"},
                                        cfg);
  ASSERT_TRUE(s.is_ok()) << s.to_string();
  EXPECT_EQ(cfg.listen.tcp, "0.0.0.0:7000");
  EXPECT_TRUE(cfg.listen.unix_socket.empty());
  EXPECT_EQ(cfg.workers, 8);
  EXPECT_EQ(cfg.log_level, LogLevel::kTrace);
  EXPECT_EQ(cfg.limits.max_states_per_request, 99);
}

TEST(ServerConfigTest, UnknownOrBadFlagIsAnError) {
  ServerConfig cfg;
  const Status unknown = apply_flag_overrides({"--port", "1"}, cfg);
  ASSERT_FALSE(unknown.is_ok());
  EXPECT_NE(unknown.message().find("--port"), std::string::npos) << unknown.message();
  EXPECT_FALSE(apply_flag_overrides({"--workers"}, cfg).is_ok());
  EXPECT_FALSE(apply_flag_overrides({"--workers", "x"}, cfg).is_ok());
  EXPECT_FALSE(apply_flag_overrides({"--log-level", "loud"}, cfg).is_ok());
}

TEST(ServerConfigTest, SecuritySectionsAndClientLimits) {
  ServerConfig cfg;
  const Status s = parse_config(
      "listen:\n  tcp: \"0.0.0.0:50051\"\n  insecure: true\n"
      "tls:\n  cert_file: /etc/rbdgrad/server.pem\n  key_file: /etc/rbdgrad/server.key\n"
      "  client_ca_file: /etc/rbdgrad/clients-ca.pem\n"
      "auth:\n  tokens_file: /etc/rbdgrad/tokens\n"
      "limits:\n  client_requests_per_second: 0.5\n  client_burst: 2\n  client_max_concurrent: 3\n"
      "  max_message_bytes: 1048576\n",
      "t", cfg);
  ASSERT_TRUE(s.is_ok()) << s.to_string();
  EXPECT_TRUE(cfg.listen.insecure);
  EXPECT_EQ(cfg.listen.unix_socket, "/tmp/rbdgradd.sock");  // kept
  EXPECT_EQ(cfg.tls.cert_file, "/etc/rbdgrad/server.pem");
  EXPECT_EQ(cfg.tls.key_file, "/etc/rbdgrad/server.key");
  EXPECT_EQ(cfg.tls.client_ca_file, "/etc/rbdgrad/clients-ca.pem");
  EXPECT_TRUE(cfg.tls.enabled());
  EXPECT_EQ(cfg.auth.tokens_file, "/etc/rbdgrad/tokens");
  EXPECT_EQ(cfg.limits.client_requests_per_second, 0.5);
  EXPECT_EQ(cfg.limits.client_burst, 2);
  EXPECT_EQ(cfg.limits.client_max_concurrent, 3);
  EXPECT_EQ(cfg.limits.max_message_bytes, 1048576);  // an explicit value wins over the derived one
  const std::string described = describe(cfg);
  EXPECT_NE(described.find("insecure: true"), std::string::npos) << described;
  EXPECT_NE(described.find("client CA /etc/rbdgrad/clients-ca.pem (mutual TLS)"), std::string::npos) << described;
  EXPECT_NE(described.find("auth: tokens from /etc/rbdgrad/tokens"), std::string::npos) << described;
  EXPECT_NE(describe(ServerConfig{}).find("max_message_bytes derived"), std::string::npos);

  // empty sections keep the defaults
  ServerConfig empty;
  ASSERT_TRUE(parse_config("tls:\nauth:\n", "t", empty).is_ok());
  EXPECT_EQ(empty, ServerConfig{});

  const std::pair<const char*, const char*> bad[] = {
      {"listen:\n  insecure: yes\n", "'listen.insecure' (line 2): expected true or false"},
      {"listen:\n  insecure: [true]\n", "'listen.insecure'"},
      {"tls:\n  cert: /x\n", "unknown key 'tls.cert' (line 2)"},
      {"tls:\n  cert_file: [a, b]\n", "'tls.cert_file' (line 2): expected a string"},
      {"tls: /x.pem\n", "'tls' (line 1): expected a mapping"},
      {"auth:\n  tokens: /x\n", "unknown key 'auth.tokens'"},
      {"auth:\n  tokens_file: {a: 1}\n", "'auth.tokens_file'"},
      {"limits:\n  client_requests_per_second: -1\n", "'limits.client_requests_per_second' (line 2): value -1 is outside"},
      {"limits:\n  client_requests_per_second: fast\n", "'limits.client_requests_per_second' (line 2): expected a number"},
      {"limits:\n  client_requests_per_second: .nan\n", "'limits.client_requests_per_second'"},
      {"limits:\n  client_burst: -1\n", "'limits.client_burst' (line 2): value -1 is outside [0, 2147483647]"},
      {"limits:\n  client_burst: 1.5\n", "'limits.client_burst'"},
      {"limits:\n  client_max_concurrent: -2\n", "'limits.client_max_concurrent'"},
      {"limits:\n  max_message_bytes: -1\n", "'limits.max_message_bytes'"},
      {"limits:\n  max_message_bytes: 2147483648\n", "'limits.max_message_bytes'"},
  };
  for (const auto& [text, want] : bad) {
    ServerConfig c;
    const Status st = parse_config(text, "t", c);
    EXPECT_FALSE(st.is_ok()) << text;
    EXPECT_NE(st.message().find(want), std::string::npos) << text << ": " << st.message();
  }
}

TEST(ServerConfigTest, LoopbackAddresses) {
  for (const char* a : {"127.0.0.1:50051", "127.1.2.3:0", "localhost:50051", "LOCALHOST:1", "[::1]:50051", "::1:50051"})
    EXPECT_TRUE(is_loopback_address(a)) << a;
  for (const char* a : {"0.0.0.0:50051", ":50051", "[::]:50051", "10.1.2.3:50051", "128.0.0.1:1", "example.com:50051",
                        "localhost.example.com:1", "[::1:50051", ""})
    EXPECT_FALSE(is_loopback_address(a)) << a;
}

TEST(ServerConfigTest, NonLoopbackWithoutTlsNeedsInsecure) {
  ServerConfig cfg;
  EXPECT_TRUE(check_security(cfg).is_ok());  // the defaults: loopback, plaintext
  cfg.listen.tcp = "0.0.0.0:50051";
  const Status refused = check_security(cfg);
  ASSERT_FALSE(refused.is_ok());
  EXPECT_EQ(refused.code(), StatusCode::kInvalidArgument);
  EXPECT_EQ(refused.message(),
            "listen.tcp '0.0.0.0:50051' is not a loopback address and TLS is off: set tls.cert_file and "
            "tls.key_file, or listen.insecure: true to serve it in plaintext anyway");
  // either lifts it
  ServerConfig insecure = cfg;
  insecure.listen.insecure = true;
  EXPECT_TRUE(check_security(insecure).is_ok());
  ServerConfig tls = cfg;
  tls.tls.cert_file = "/s.pem";
  tls.tls.key_file = "/s.key";
  EXPECT_TRUE(check_security(tls).is_ok());
  // no TCP at all: only the Unix socket, guarded by its permissions
  ServerConfig unix_only = cfg;
  unix_only.listen.tcp = "";
  EXPECT_TRUE(check_security(unix_only).is_ok());
  // the flag --listen counts as well as the file
  ServerConfig flagged;
  ASSERT_TRUE(apply_flag_overrides({"--listen", "[::]:7000"}, flagged).is_ok());
  EXPECT_FALSE(check_security(flagged).is_ok());

  ServerConfig half;
  half.tls.cert_file = "/s.pem";
  EXPECT_NE(check_security(half).message().find("tls.cert_file and tls.key_file go together"), std::string::npos);
  ServerConfig ca_only;
  ca_only.tls.client_ca_file = "/ca.pem";
  EXPECT_NE(check_security(ca_only).message().find("tls.client_ca_file (mutual TLS) needs TLS"), std::string::npos);
}

TEST(ServerConfigTest, DescribeMentionsListenAddressAndModels) {
  ServerConfig cfg;
  cfg.listen.tcp = "10.1.2.3:4567";
  const std::string text = describe(cfg);
  EXPECT_NE(text.find("10.1.2.3:4567"), std::string::npos) << text;
  EXPECT_NE(text.find("/tmp/rbdgradd.sock"), std::string::npos) << text;
  EXPECT_NE(text.find("iiwa14"), std::string::npos) << text;
}

}  // namespace
}  // namespace rbdgrad::server
