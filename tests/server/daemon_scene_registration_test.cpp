// Scenes registered while the daemon serves (RegisterScene, issue 8): a registered scene computes
// what the configured scene of the same definition computes, requests on other models go on while
// scenes are registered, the same definition again is fine, another one under the same name is
// refused saying what differs, every bad scene is refused as in a configuration, and the limit
// limits.max_registered_scenes holds.
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <atomic>
#include <cstdio>
#include <fstream>
#include <thread>
#include <vector>

#include "daemon_test_support.hpp"

namespace rbdgrad::server {
namespace {

using namespace daemon_testing;
using ::testing::HasSubstr;

constexpr int kHyqNv = 12, kWalkNv = 28;

// iiwa14 and panda (test_options), the humanoid and the quadruped, and the configured twins of
// the scenes registered below
DaemonOptions registration_options() {
  DaemonOptions options = test_options("");
  options.config.models.push_back({"talos", "", "talos_reduced", std::nullopt, {}});
  options.config.models.push_back({"hyq", "", "hyq", std::nullopt, {}});
  SceneConfig walk;
  walk.name = "walk_cfg";
  walk.model = "talos";
  walk.locked_joints = {
      {"head_1_joint", 0.0}, {"head_2_joint", 0.1}, {"gripper_left_joint", 0.0}, {"gripper_right_joint", 0.0}};
  SceneConfig trot;
  trot.name = "trot_cfg";
  trot.model = "hyq";
  trot.gravity = false;
  trot.force_links = {"lf_lowerleg", "rh_lowerleg"};
  trot.outputs = {"qdd", "dqdd_dq"};
  options.config.scenes = {walk, trot};
  return options;
}

v1::RegisterSceneRequest walk_request(const std::string& name) {
  v1::RegisterSceneRequest req;
  req.set_name(name);
  req.set_model("talos");
  // the configured scene's locks in another order: the same definition
  for (const auto& [joint, value] : std::vector<std::pair<std::string, double>>{
           {"gripper_right_joint", 0.0}, {"gripper_left_joint", 0.0}, {"head_2_joint", 0.1}, {"head_1_joint", 0.0}}) {
    req.add_locked_joints(joint);
    req.add_locked_values(value);
  }
  return req;
}

v1::RegisterSceneRequest trot_request(const std::string& name) {
  v1::RegisterSceneRequest req;
  req.set_name(name);
  req.set_model("hyq");
  req.set_gravity(false);
  req.add_force_links("lf_lowerleg");
  req.add_force_links("rh_lowerleg");
  req.add_outputs(v1::OUTPUT_DQDD_DQ);
  req.add_outputs(v1::OUTPUT_QDD);
  return req;
}

// an arm scene without anything locked: cheap to register many of
v1::RegisterSceneRequest arm_request(const std::string& name) {
  v1::RegisterSceneRequest req;
  req.set_name(name);
  req.set_model("iiwa14");
  return req;
}

grpc::Status register_scene(v1::Dynamics::Stub& stub, const v1::RegisterSceneRequest& req, v1::Scene* out = nullptr,
                            const std::string& token = "") {
  grpc::ClientContext ctx;
  ctx.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(30));
  if (!token.empty()) ctx.AddMetadata("authorization", "Bearer " + token);
  v1::Scene scene;
  const grpc::Status s = stub.RegisterScene(&ctx, req, &scene);
  if (out != nullptr) *out = scene;
  return s;
}

v1::ListScenesResponse list_scenes(v1::Dynamics::Stub& stub) {
  grpc::ClientContext ctx;
  v1::ListScenesResponse out;
  EXPECT_TRUE(stub.ListScenes(&ctx, {}, &out).ok());
  return out;
}

v1::ComputeResponse compute(v1::Dynamics::Stub& stub, const v1::ComputeRequest& req) {
  grpc::ClientContext ctx;
  v1::ComputeResponse resp;
  const grpc::Status s = stub.Compute(&ctx, req, &resp);
  EXPECT_TRUE(s.ok()) << req.scene() << ": " << s.error_message();
  return resp;
}

TEST(DaemonSceneRegistration, ARegisteredSceneComputesAsTheConfiguredOneOfItsDefinition) {
  std::unique_ptr<Daemon> daemon = start_daemon(registration_options());
  ASSERT_NE(daemon, nullptr);
  auto stub = v1::Dynamics::NewStub(channel_to(daemon->addresses()[0]));

  // the answer is GetScene's: the joints in the scene's order, what it locks, its outputs
  v1::Scene walk;
  grpc::Status s = register_scene(*stub, walk_request("walk_rpc"), &walk);
  ASSERT_TRUE(s.ok()) << s.error_message();
  v1::Scene trot;
  s = register_scene(*stub, trot_request("trot_rpc"), &trot);
  ASSERT_TRUE(s.ok()) << s.error_message();
  EXPECT_EQ(walk.nv(), static_cast<std::uint32_t>(kWalkNv));
  const v1::ListScenesResponse scenes = list_scenes(*stub);
  ASSERT_EQ(scenes.scenes_size(), 4) << "the configured scenes, then the registered ones";
  EXPECT_EQ(scenes.scenes(2).SerializeAsString(), walk.SerializeAsString());
  EXPECT_EQ(scenes.scenes(3).name(), "trot_rpc");
  for (const auto& [configured, registered] : {std::pair{scenes.scenes(0), walk}, std::pair{scenes.scenes(1), trot}}) {
    ASSERT_EQ(registered.joints_size(), configured.joints_size());
    for (int j = 0; j < configured.joints_size(); ++j)
      EXPECT_EQ(registered.joints(j).SerializeAsString(), configured.joints(j).SerializeAsString()) << j;
    EXPECT_EQ(registered.gravity(), configured.gravity());
    EXPECT_EQ(registered.outputs_size(), configured.outputs_size());
    EXPECT_EQ(registered.force_links_size(), configured.force_links_size());
  }
  grpc::ClientContext get_ctx;
  v1::GetSceneRequest get;
  get.set_name("trot_rpc");
  v1::Scene got;
  ASSERT_TRUE(stub->GetScene(&get_ctx, get, &got).ok());
  EXPECT_EQ(got.SerializeAsString(), trot.SerializeAsString());
  {
    grpc::ClientContext ctx;
    v1::ListModelsResponse models;
    ASSERT_TRUE(stub->ListModels(&ctx, {}, &models).ok());
    EXPECT_EQ(models.models_size(), 4) << "a scene is no model";
  }

  // the same states through each twin: the same numbers, bit for bit (the cpu runs both)
  for (const char* backend_hint : {"auto", "cuda"}) {
    v1::ComputeRequest req = make_request("", kWalkNv, 3, 21, "walk", {});
    if (std::string(backend_hint) == "cuda") req.set_backend(v1::BACKEND_CUDA);
    req.set_scene("walk_cfg");
    const v1::ComputeResponse configured = compute(*stub, req);
    req.set_scene("walk_rpc");
    const v1::ComputeResponse registered = compute(*stub, req);
    EXPECT_EQ(registered.backend_name(), configured.backend_name());
    ASSERT_FALSE(configured.dqdd_dq().data().empty());
    EXPECT_EQ(registered.dqdd_dq().data(), configured.dqdd_dq().data()) << backend_hint;
    EXPECT_EQ(registered.dqdd_dqd().data(), configured.dqdd_dqd().data()) << backend_hint;
  }
  v1::ComputeRequest req = make_request("", kHyqNv, 3, 22, "trot", {});
  std::vector<double> forces(3 * 2 * 6);
  for (std::size_t e = 0; e < forces.size(); ++e) forces[e] = 0.25 * static_cast<double>(e % 5) - 0.5;
  set_tensor(req.mutable_fext(), forces);
  req.set_scene("trot_cfg");
  const v1::ComputeResponse configured = compute(*stub, req);
  req.set_scene("trot_rpc");
  const v1::ComputeResponse registered = compute(*stub, req);
  ASSERT_FALSE(configured.qdd().data().empty());
  EXPECT_EQ(registered.qdd().data(), configured.qdd().data());
  EXPECT_EQ(registered.dqdd_dq().data(), configured.dqdd_dq().data());
  EXPECT_TRUE(registered.dqdd_dqd().data().empty()) << "only the scene's outputs";

  // and a registered scene is refused what its definition refuses, as a configured one
  req.clear_fext();
  req.add_outputs(v1::OUTPUT_DQDD_DQD);
  grpc::ClientContext ctx;
  v1::ComputeResponse resp;
  s = stub->Compute(&ctx, req, &resp);
  EXPECT_EQ(s.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_THAT(s.error_message(), HasSubstr("scene 'trot_rpc': output dqdd_dqd is not one the scene computes"));
}

TEST(DaemonSceneRegistration, TheSchedulerGetsLatencyModelsForARegisteredScene) {
  DaemonOptions options = registration_options();
  options.config.scheduler.calibrate = "start";
  options.config.scheduler.calibration_sizes = {1, 4};
  std::unique_ptr<Daemon> daemon = start_daemon(std::move(options));
  ASSERT_NE(daemon, nullptr);
  auto stub = v1::Dynamics::NewStub(channel_to(daemon->addresses()[0]));
  const auto models_of = [&](const std::string& scene) {
    int n = 0;
    const CalibrationTable table = daemon->scheduler().table();  // a copy: kept alive for the loop
    for (const CalibrationEntry& e : table.entries()) n += e.model == scene;
    return n;
  };
  EXPECT_EQ(models_of("arm"), 0);
  ASSERT_TRUE(register_scene(*stub, arm_request("arm")).ok());
  // one per backend and precision, as for the configured scenes
  EXPECT_GT(models_of("arm"), 0);
  EXPECT_EQ(models_of("arm"), models_of("walk_cfg"));
  grpc::ClientContext ctx;
  v1::GetServerInfoResponse info;
  ASSERT_TRUE(stub->GetServerInfo(&ctx, {}, &info).ok());
  bool routed = false;
  for (const v1::RoutingInfo& r : info.routing()) routed = routed || (r.model() == "arm" && r.crossovers_size() > 0);
  EXPECT_TRUE(routed) << "GetServerInfo routes the registered scene";
  // a calibration afterwards measures it again, with the others
  grpc::ClientContext calibrate_ctx;
  v1::CalibrateResponse calibrated;
  ASSERT_TRUE(stub->Calibrate(&calibrate_ctx, {}, &calibrated).ok());
  EXPECT_EQ(models_of("arm"), models_of("walk_cfg"));
}

TEST(DaemonSceneRegistration, RequestsOnOtherModelsGoOnWhileScenesAreRegistered) {
  std::unique_ptr<Daemon> daemon = start_daemon(registration_options());
  ASSERT_NE(daemon, nullptr);
  auto channel = channel_to(daemon->addresses()[0]);
  auto stub = v1::Dynamics::NewStub(channel);
  constexpr int kScenes = 12;
  std::atomic<bool> done{false};
  std::atomic<int> computed{0}, failed{0};
  // two clients: compute on a model and a configured scene, and read the scene list and server
  // info (the registry and the latency models), for as long as the registrations run
  std::vector<std::thread> clients;
  for (int c = 0; c < 2; ++c) {
    clients.emplace_back([&, c] {
      auto own = v1::Dynamics::NewStub(channel);
      const v1::ComputeRequest arm = make_request("iiwa14", kIiwaNv, 4, 30 + c, "arm", {v1::OUTPUT_DQDD_DQ});
      v1::ComputeRequest trot = make_request("", kHyqNv, 2, 40 + c, "trot", {});
      trot.set_scene("trot_cfg");
      const std::vector<const v1::ComputeRequest*> requests = {&arm, &trot};
      while (!done.load()) {
        for (const v1::ComputeRequest* req : requests) {
          grpc::ClientContext ctx;
          v1::ComputeResponse resp;
          if (own->Compute(&ctx, *req, &resp).ok()) ++computed;
          else ++failed;
        }
        grpc::ClientContext list_ctx, info_ctx;
        v1::ListScenesResponse scenes;
        v1::GetServerInfoResponse info;
        if (!own->ListScenes(&list_ctx, {}, &scenes).ok() || !own->GetServerInfo(&info_ctx, {}, &info).ok()) ++failed;
      }
    });
  }
  for (int i = 0; i < kScenes; ++i) {
    const grpc::Status s = register_scene(*stub, arm_request("arm" + std::to_string(i)));
    EXPECT_TRUE(s.ok()) << i << ": " << s.error_message();
  }
  done = true;
  for (std::thread& t : clients) t.join();
  EXPECT_EQ(failed.load(), 0);
  EXPECT_GT(computed.load(), 0);
  EXPECT_EQ(list_scenes(*stub).scenes_size(), 2 + kScenes);
  // each registered scene computes, on the cpu and the fake cuda
  for (int i = 0; i < kScenes; ++i) {
    v1::ComputeRequest req = make_request("", kIiwaNv, 2, 50, "arm", {});
    req.set_scene("arm" + std::to_string(i));
    req.set_backend(i % 2 == 0 ? v1::BACKEND_CPU : v1::BACKEND_CUDA);
    const v1::ComputeResponse resp = compute(*stub, req);
    EXPECT_EQ(resp.dqdd_dq().data().size(), 2u * kIiwaNv * kIiwaNv * sizeof(double)) << i;
  }
}

TEST(DaemonSceneRegistration, TheSameDefinitionAgainIsFineAnotherUnderTheNameIsRefused) {
  std::unique_ptr<Daemon> daemon = start_daemon(registration_options());
  ASSERT_NE(daemon, nullptr);
  auto stub = v1::Dynamics::NewStub(channel_to(daemon->addresses()[0]));
  v1::Scene first, again;
  ASSERT_TRUE(register_scene(*stub, trot_request("trot_rpc"), &first).ok());
  // as a client does after reconnecting: OK, the same answer, registered once
  v1::RegisterSceneRequest same = trot_request("trot_rpc");
  std::swap(*same.mutable_outputs()->Mutable(0), *same.mutable_outputs()->Mutable(1));
  const grpc::Status s = register_scene(*stub, same, &again);
  ASSERT_TRUE(s.ok()) << s.error_message();
  EXPECT_EQ(again.SerializeAsString(), first.SerializeAsString());
  EXPECT_EQ(list_scenes(*stub).scenes_size(), 3);
  // a configured scene's definition under its name is the same scene too
  ASSERT_TRUE(register_scene(*stub, walk_request("walk_cfg")).ok());
  EXPECT_EQ(daemon->models().registered(), 1u);

  const auto refused = [&](const v1::RegisterSceneRequest& req, const std::string& why) {
    const grpc::Status st = register_scene(*stub, req);
    EXPECT_EQ(st.error_code(), grpc::StatusCode::ALREADY_EXISTS) << st.error_message();
    EXPECT_THAT(st.error_message(), HasSubstr(why));
  };
  v1::RegisterSceneRequest other = trot_request("trot_rpc");
  other.set_gravity(true);
  refused(other, "scene 'trot_rpc' is served already, defined otherwise: gravity: registered off, asked on");
  other = trot_request("trot_rpc");
  std::swap(*other.mutable_force_links(0), *other.mutable_force_links(1));
  refused(other, "force_links: registered [lf_lowerleg, rh_lowerleg], asked [rh_lowerleg, lf_lowerleg]");
  other = walk_request("walk_cfg");
  other.set_locked_values(2, 0.05);
  refused(other, "locked_joints: registered [gripper_left_joint=0, gripper_right_joint=0, head_1_joint=0, "
                 "head_2_joint=0.1], asked [gripper_left_joint=0, gripper_right_joint=0, head_1_joint=0, "
                 "head_2_joint=0.05]");
  refused(arm_request("trot_rpc"), "model: registered 'hyq', asked 'iiwa14'");
  refused(arm_request("panda"), "scene 'panda': 'panda' is the name of a model (models: iiwa14, panda, talos, hyq)");
  EXPECT_EQ(list_scenes(*stub).scenes_size(), 3);
}

TEST(DaemonSceneRegistration, BadScenesAreRefusedAsInAConfiguration) {
  std::unique_ptr<Daemon> daemon = start_daemon(registration_options());
  ASSERT_NE(daemon, nullptr);
  auto stub = v1::Dynamics::NewStub(channel_to(daemon->addresses()[0]));
  const auto refused = [&](const v1::RegisterSceneRequest& req, grpc::StatusCode code, const std::string& why) {
    const grpc::Status s = register_scene(*stub, req);
    EXPECT_EQ(s.error_code(), code) << why << ": " << s.error_message();
    EXPECT_THAT(s.error_message(), HasSubstr(why));
  };
  const grpc::StatusCode kInvalid = grpc::StatusCode::INVALID_ARGUMENT;
  v1::RegisterSceneRequest req = arm_request("bad");
  req.add_locked_joints("elbow");
  req.add_locked_values(0.0);
  refused(req, kInvalid, "scene 'bad': locked joint 'elbow': model 'iiwa14' has no such joint");
  req.set_locked_joints(0, "iiwa_joint_2");
  req.set_locked_values(0, 3.0);
  refused(req, kInvalid, "scene 'bad': locked joint 'iiwa_joint_2': value 3 is outside its limits");
  req.add_locked_values(0.0);
  refused(req, kInvalid, "scene 'bad': locked_values has 2 value(s) for 1 locked_joints");
  req = arm_request("bad");
  for (int j = 1; j <= 7; ++j) {
    req.add_locked_joints("iiwa_joint_" + std::to_string(j));
    req.add_locked_values(0.0);
  }
  refused(req, kInvalid, "scene 'bad': locking every joint of model 'iiwa14' leaves nothing to move");
  req = arm_request("bad");
  req.add_force_links("iiwa_link_0");
  refused(req, kInvalid, "scene 'bad': force link 'iiwa_link_0' is not moved by a joint of the scene");
  req = arm_request("bad");
  req.add_outputs(v1::OUTPUT_UNSPECIFIED);
  refused(req, kInvalid, "scene 'bad': unknown output 'OUTPUT_UNSPECIFIED'");
  req = arm_request("bad");
  req.add_outputs(v1::OUTPUT_QDD);
  req.add_outputs(v1::OUTPUT_QDD);
  refused(req, kInvalid, "scene 'bad': output 'qdd' is listed twice");
  refused(arm_request(""), kInvalid, "a scene needs a name");
  req = arm_request("bad");
  req.set_model("ur5");
  refused(req, grpc::StatusCode::NOT_FOUND,
          "scene 'bad': model 'ur5' is not configured (models: iiwa14, panda, talos, hyq)");
  // a scene is no model to make scenes from
  req.set_model("trot_cfg");
  refused(req, grpc::StatusCode::NOT_FOUND, "model 'trot_cfg' is not configured");

  // nothing was registered, and the daemon serves on; the name is still free
  EXPECT_EQ(list_scenes(*stub).scenes_size(), 2);
  EXPECT_EQ(daemon->models().registered(), 0u);
  ASSERT_TRUE(register_scene(*stub, arm_request("bad")).ok());
}

TEST(DaemonSceneRegistration, RegistrationStopsAtTheLimit) {
  DaemonOptions options = registration_options();
  options.config.limits.max_registered_scenes = 2;
  std::unique_ptr<Daemon> daemon = start_daemon(std::move(options));
  ASSERT_NE(daemon, nullptr);
  auto stub = v1::Dynamics::NewStub(channel_to(daemon->addresses()[0]));
  ASSERT_TRUE(register_scene(*stub, arm_request("a")).ok());
  ASSERT_TRUE(register_scene(*stub, arm_request("b")).ok());
  const grpc::Status s = register_scene(*stub, arm_request("c"));
  EXPECT_EQ(s.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED);
  EXPECT_EQ(s.error_message(), "scene 'c': 2 scenes are registered already (limits.max_registered_scenes = 2)");
  // the configured scenes do not count, and registering one of the two again still answers
  EXPECT_TRUE(register_scene(*stub, arm_request("b")).ok());
  EXPECT_EQ(list_scenes(*stub).scenes_size(), 4);

  DaemonOptions none = registration_options();
  none.config.limits.max_registered_scenes = 0;
  daemon = start_daemon(std::move(none));
  ASSERT_NE(daemon, nullptr);
  stub = v1::Dynamics::NewStub(channel_to(daemon->addresses()[0]));
  EXPECT_EQ(register_scene(*stub, arm_request("a")).error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED);
}

TEST(DaemonSceneRegistration, WithTokensRegistrationNeedsOne) {
  const std::string tokens = "/tmp/rbdgrad_dt_" + std::to_string(getpid()) + "_registration_tokens";
  std::ofstream(tokens) << "mpc tok-mpc-0123456789\n";
  DaemonOptions options = registration_options();
  options.config.auth.tokens_file = tokens;
  std::unique_ptr<Daemon> daemon = start_daemon(std::move(options));
  std::remove(tokens.c_str());
  ASSERT_NE(daemon, nullptr);
  auto stub = v1::Dynamics::NewStub(channel_to(daemon->addresses()[0]));
  EXPECT_EQ(register_scene(*stub, arm_request("a")).error_code(), grpc::StatusCode::UNAUTHENTICATED);
  EXPECT_EQ(register_scene(*stub, arm_request("a"), nullptr, "tok-wrong").error_code(),
            grpc::StatusCode::UNAUTHENTICATED);
  EXPECT_EQ(daemon->models().registered(), 0u);
  EXPECT_TRUE(register_scene(*stub, arm_request("a"), nullptr, "tok-mpc-0123456789").ok());
}

}  // namespace
}  // namespace rbdgrad::server
