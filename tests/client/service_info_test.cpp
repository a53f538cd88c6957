// Tests for client/src/info_decoding.cpp: ListModels, GetModel, ListScenes, GetScene and
// GetServerInfo as plain structs.
#include <gtest/gtest.h>

#include "fake_dynamics_service.hpp"
#include "rbdgrad/client.hpp"

namespace rbdgrad::testing {
namespace {

TEST(ClientServiceInfo, ListModels) {
  FakeServer server;
  const std::vector<ServedModel> models = Client(server.address()).list_models();
  ASSERT_EQ(models.size(), 2u);
  EXPECT_EQ(models[0].name, "iiwa14");
  EXPECT_EQ(models[0].nv, 7);
  EXPECT_EQ(models[0].source, "<embedded>");
  EXPECT_EQ(models[1].name, "panda");
  EXPECT_EQ(models[1].nv, 9);
  EXPECT_EQ(models[1].source, "/robots/panda.urdf");
}

TEST(ClientServiceInfo, GetModelMapsJointsInOrder) {
  FakeServer server;
  const ModelDescription m = Client(server.address()).get_model("twolink");
  EXPECT_EQ(m.name, "twolink");
  EXPECT_EQ(m.nv, 2);
  ASSERT_EQ(m.joints.size(), 2u);
  const JointDescription& a = m.joints[0];
  EXPECT_EQ(a.name, "shoulder");
  EXPECT_EQ(a.type, "revolute");
  EXPECT_EQ(a.parent, -1);
  EXPECT_EQ(a.parent_link, "base");
  EXPECT_EQ(a.child_link, "upper_arm");
  EXPECT_EQ(a.lower_limit, -1.5);
  EXPECT_EQ(a.upper_limit, 2.5);
  EXPECT_EQ(a.effort_limit, 80);
  EXPECT_EQ(a.velocity_limit, 3);
  EXPECT_TRUE(a.has_position_limits());
  const JointDescription& b = m.joints[1];
  EXPECT_EQ(b.name, "wrist");
  EXPECT_EQ(b.type, "continuous");
  EXPECT_EQ(b.parent, 0);
  EXPECT_FALSE(b.has_position_limits());
  EXPECT_EQ(m.gravity, Eigen::Vector3d(0.0, -9.81, 0.5));
  EXPECT_EQ(m.summary, "model 'twolink': 2 moving joints");
}

TEST(ClientServiceInfo, ScenesAsPlainStructs) {
  FakeServer server;
  Client client(server.address());
  const std::vector<SceneDescription> scenes = client.list_scenes();
  ASSERT_EQ(scenes.size(), 1u);
  const SceneDescription s = client.get_scene("reach");
  for (const SceneDescription* d : {&scenes[0], &s}) {
    EXPECT_EQ(d->name, "reach");
    EXPECT_EQ(d->model, "twolink");
    EXPECT_EQ(d->nv, 1);
    ASSERT_EQ(d->joints.size(), 1u);
    EXPECT_EQ(d->joints[0].name, "shoulder");
    ASSERT_EQ(d->locked_joints.size(), 1u);
    EXPECT_EQ(d->locked_joints[0], (std::pair<std::string, double>{"wrist", 0.25}));
    EXPECT_FALSE(d->gravity);
    EXPECT_EQ(d->force_links, std::vector<std::string>{"upper_arm"});
    EXPECT_EQ(d->outputs, static_cast<std::uint32_t>(Output::kQdd) | static_cast<std::uint32_t>(Output::kDqddDq));
    EXPECT_TRUE(d->minv_supplied);
  }
  SceneDescription none;
  const RpcStatus st = client.get_scene("dance", none);
  EXPECT_EQ(st.code(), RpcCode::kNotFound);
  EXPECT_EQ(st.message(), "scene 'dance' is not configured");
}

TEST(ClientServiceInfo, RegisterSceneSendsTheDefinitionAndReturnsTheScene) {
  FakeServer server;
  Client client(server.address());
  SceneDefinition def;
  def.name = "reach2";
  def.model = "twolink";
  def.locked_joints = {{"wrist", 0.25}};
  def.force_links = {"upper_arm"};
  def.outputs = Output::kDqddDq | Output::kQdd;
  def.minv_supplied = true;
  const SceneDescription s = client.register_scene(def);
  EXPECT_EQ(s.name, "reach2");
  EXPECT_EQ(s.nv, 1);
  ASSERT_EQ(s.joints.size(), 1u);
  EXPECT_EQ(s.joints[0].name, "shoulder");

  // defaults: gravity sent as on (unset would mean on too), no outputs = the server's default
  SceneDefinition plain;
  plain.name = "plain";
  plain.model = "twolink";
  SceneDescription ignored;
  ASSERT_TRUE(client.register_scene(plain, ignored).is_ok());
  const std::vector<v1::RegisterSceneRequest> got = server.service().registrations();
  ASSERT_EQ(got.size(), 2u);
  EXPECT_EQ(got[0].name(), "reach2");
  EXPECT_EQ(got[0].model(), "twolink");
  ASSERT_EQ(got[0].locked_joints_size(), 1);
  EXPECT_EQ(got[0].locked_joints(0), "wrist");
  ASSERT_EQ(got[0].locked_values_size(), 1);
  EXPECT_EQ(got[0].locked_values(0), 0.25);
  EXPECT_TRUE(got[0].has_gravity());
  EXPECT_TRUE(got[0].gravity());
  ASSERT_EQ(got[0].force_links_size(), 1);
  EXPECT_EQ(got[0].force_links(0), "upper_arm");
  ASSERT_EQ(got[0].outputs_size(), 2);
  EXPECT_EQ(got[0].outputs(0), v1::OUTPUT_QDD);
  EXPECT_EQ(got[0].outputs(1), v1::OUTPUT_DQDD_DQ);
  EXPECT_TRUE(got[0].minv_supplied());
  EXPECT_EQ(got[1].outputs_size(), 0);
  EXPECT_FALSE(got[1].minv_supplied());
  plain.gravity = false;
  ASSERT_TRUE(client.register_scene(plain, ignored).is_ok());
  EXPECT_TRUE(server.service().registrations().back().has_gravity());
  EXPECT_FALSE(server.service().registrations().back().gravity());

  // the server's refusal, with its code; bits that name no output never leave the client
  def.name = "twolink";
  SceneDescription none;
  RpcStatus st = client.register_scene(def, none);
  EXPECT_EQ(st.code(), RpcCode::kAlreadyExists);
  EXPECT_EQ(st.message(), "'twolink' is the name of a model");
  def.outputs = 1u << 9;
  st = client.register_scene(def, none);
  EXPECT_EQ(st.code(), RpcCode::kInvalidArgument);
  EXPECT_EQ(server.service().registrations().size(), 4u);
  EXPECT_THROW(client.register_scene(def), ClientError);
}

TEST(ClientServiceInfo, RegisterSceneIsRetriedWhenUnavailable) {
  FakeServer server;
  Client client(server.address());
  server.service().fail_next(2);
  SceneDefinition def;
  def.name = "again";
  def.model = "twolink";
  SceneDescription s;
  const RpcStatus st = client.register_scene(def, s);
  ASSERT_TRUE(st.is_ok()) << st.message();
  EXPECT_EQ(s.name, "again");
  EXPECT_EQ(server.service().registrations().size(), 3u) << "registering again is harmless: retried";
}

// A scene's request may leave the outputs to the scene: the result holds what the server sent.
TEST(ClientServiceInfo, ASceneRequestWithoutOutputsGetsTheScenes) {
  FakeServer server;
  Client client(server.address());
  const std::vector<double> q = {0.1, 0.2}, qd = {0.3, 0.4}, u = {0.5, 0.6};
  ComputeRequest req;
  req.scene = "reach";
  req.num_states = 2;
  req.q = q;
  req.qd = qd;
  req.u = u;
  const ComputeResult r = client.compute(req);
  ASSERT_EQ(server.service().received().size(), 1u);
  EXPECT_EQ(server.service().received()[0].scene(), "reach");
  EXPECT_TRUE(r.has(Output::kQdd));
  EXPECT_TRUE(r.has(Output::kDqddDq));
  EXPECT_FALSE(r.has(Output::kDqddDqd));
  EXPECT_EQ(r.matrix(Output::kDqddDq, 1).rows(), 1);
}

TEST(ClientServiceInfo, GetModelOfAnUnknownNameIsNotFound) {
  FakeServer server;
  Client client(server.address());
  try {
    (void)client.get_model("nope");
    FAIL() << "no exception";
  } catch (const ClientError& e) {
    EXPECT_EQ(e.code(), RpcCode::kNotFound);
    EXPECT_EQ(e.message(), "model 'nope' is not loaded");
  }
  ModelDescription m;
  EXPECT_EQ(client.get_model("nope", m).code(), RpcCode::kNotFound);
}

TEST(ClientServiceInfo, ServerInfoMapsBackendsAndLimits) {
  FakeServer server;
  ServerInfo info;
  ASSERT_TRUE(Client(server.address()).server_info(info));
  EXPECT_EQ(info.version, "9.8.7-fake");
  ASSERT_EQ(info.backends.size(), 2u);
  const BackendStatus& cpu = info.backends[0];
  EXPECT_EQ(cpu.backend, Backend::kCpu);
  EXPECT_EQ(cpu.name, "cpu");
  EXPECT_TRUE(cpu.ready);
  EXPECT_EQ(cpu.precisions, (std::vector<Precision>{Precision::kF64, Precision::kF32}));
  EXPECT_EQ(cpu.max_batch, 0u);
  const BackendStatus& fpga = info.backends[1];
  EXPECT_EQ(fpga.backend, Backend::kFpga);
  EXPECT_FALSE(fpga.ready);
  EXPECT_EQ(fpga.reason, "no XRT device found");
  EXPECT_EQ(fpga.precisions, std::vector<Precision>{Precision::kFixed});
  EXPECT_EQ(fpga.max_batch, 4096u);
  EXPECT_EQ(info.max_states_per_request, 1000u);
  EXPECT_EQ(info.max_message_bytes, std::uint64_t{5} << 30);
  EXPECT_EQ(info.max_concurrent_requests, 8u);
}

TEST(ClientNames, RoundTrip) {
  for (Precision p : {Precision::kAuto, Precision::kF64, Precision::kF32, Precision::kFixed}) {
    Precision back{};
    ASSERT_TRUE(parse_precision(precision_name(p), back));
    EXPECT_EQ(back, p);
  }
  for (Backend b : {Backend::kAuto, Backend::kCpu, Backend::kCuda, Backend::kFpga}) {
    Backend back{};
    ASSERT_TRUE(parse_backend(backend_name(b), back));
    EXPECT_EQ(back, b);
  }
  ComputeInput in{};
  EXPECT_TRUE(parse_input("qdd", in));
  EXPECT_EQ(in, ComputeInput::kQdd);
  ScalarType t{};
  EXPECT_TRUE(parse_scalar_type("f32", t));
  EXPECT_EQ(t, ScalarType::kF32);
  Precision p = Precision::kF32;
  EXPECT_FALSE(parse_precision("f16", p));
  EXPECT_EQ(p, Precision::kF32) << "untouched on failure";
  EXPECT_STREQ(output_name(Output::kDqddDqd), "dqdd_dqd");
  EXPECT_STREQ(rpc_code_name(RpcCode::kResourceExhausted), "RESOURCE_EXHAUSTED");
  EXPECT_STREQ(rpc_code_name(static_cast<RpcCode>(99)), "UNKNOWN_CODE");
}

}  // namespace
}  // namespace rbdgrad::testing
