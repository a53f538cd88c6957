// Scenes through the daemon (issue 8): ListScenes and GetScene describe them, a request that names
// a scene gets what the core library computes on the scene's model (the humanoid with hands and
// head locked, the quadruped without gravity and with forces on two feet, an arm with M^-1 from the
// request), and bad requests are refused while the daemon keeps serving.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <vector>

#include "daemon_test_support.hpp"
#include "model_source.hpp"
#include "rbdgrad/algorithm/evaluate.hpp"
#include "rbdgrad/locked_joints.hpp"

namespace rbdgrad::server {
namespace {

using namespace daemon_testing;
using ::testing::HasSubstr;

constexpr int kTalosNv = 32, kWalkNv = 28, kHyqNv = 12;
const std::vector<std::pair<std::string, double>> kWalkLocks = {
    {"head_1_joint", 0.0}, {"head_2_joint", 0.1}, {"gripper_left_joint", 0.0}, {"gripper_right_joint", 0.0}};

DaemonOptions scene_options() {
  DaemonOptions options = test_options("");
  options.config.models = {{"iiwa14", "", "iiwa14", std::nullopt},
                           {"talos", "", "talos_reduced", std::nullopt},
                           {"hyq", "", "hyq", std::nullopt}};
  SceneConfig walk;
  walk.name = "walk";
  walk.model = "talos";
  walk.locked_joints = kWalkLocks;
  SceneConfig trot;
  trot.name = "trot";
  trot.model = "hyq";
  trot.gravity = false;
  trot.force_links = {"lf_lowerleg", "rh_lowerleg"};
  trot.outputs = {"dqdd_dq"};
  SceneConfig cached;
  cached.name = "cached";
  cached.model = "iiwa14";
  cached.minv = "supplied";
  cached.outputs = {"qdd", "dqdd_dq", "dqdd_dqd"};
  options.config.scenes = {walk, trot, cached};
  return options;
}

Model embedded_model(const std::string& robot) {
  Model m;
  EXPECT_TRUE(cli::load_model(robot, std::nullopt, m).is_ok()) << robot;
  return m;
}

// state k's values of one tensor of states of `per_state` scalars
Eigen::Map<const Eigen::VectorXd> state_of(const std::vector<double>& values, std::size_t k, int per_state) {
  return {values.data() + k * static_cast<std::size_t>(per_state), per_state};
}

// the response's matrix output of state k equals the core's, bit for bit (the CPU backend runs
// the core's code)
void expect_matrix(const std::vector<double>& got, std::size_t k, const Eigen::MatrixXd& want, const std::string& what) {
  const auto n = static_cast<std::size_t>(want.rows());
  ASSERT_GE(got.size(), (k + 1) * n * n) << what;
  for (std::size_t i = 0; i < n; ++i)
    for (std::size_t j = 0; j < n; ++j)
      ASSERT_EQ(got[(k * n + i) * n + j], want(static_cast<Eigen::Index>(i), static_cast<Eigen::Index>(j)))
          << what << ", state " << k << " (" << i << ", " << j << ")";
}

TEST(DaemonScenes, AreListedAndDescribedApartFromTheModels) {
  std::unique_ptr<Daemon> daemon = start_daemon(scene_options());
  ASSERT_NE(daemon, nullptr);
  auto stub = v1::Dynamics::NewStub(channel_to(daemon->addresses()[0]));
  {
    grpc::ClientContext ctx;
    v1::ListModelsResponse models;
    ASSERT_TRUE(stub->ListModels(&ctx, {}, &models).ok());
    ASSERT_EQ(models.models_size(), 3) << "scenes are not models";
  }
  grpc::ClientContext ctx;
  v1::ListScenesResponse scenes;
  ASSERT_TRUE(stub->ListScenes(&ctx, {}, &scenes).ok());
  ASSERT_EQ(scenes.scenes_size(), 3);
  const v1::Scene& walk = scenes.scenes(0);
  EXPECT_EQ(walk.name(), "walk");
  EXPECT_EQ(walk.model(), "talos");
  EXPECT_EQ(walk.nv(), static_cast<std::uint32_t>(kWalkNv));
  ASSERT_EQ(walk.joints_size(), kWalkNv);
  // the kept joints in the model's order: the head's two and the grippers are gone
  const Model talos = embedded_model("talos_reduced");
  int next = 0;
  for (const JointInfo& j : talos.joints) {
    if (j.name.rfind("head_", 0) == 0 || j.name.rfind("gripper_", 0) == 0) continue;
    ASSERT_LT(next, kWalkNv);
    EXPECT_EQ(walk.joints(next++).name(), j.name);
  }
  ASSERT_EQ(walk.locked_joints_size(), 4);
  EXPECT_EQ(walk.locked_joints(1), "head_2_joint");
  EXPECT_EQ(walk.locked_values(1), 0.1);
  EXPECT_TRUE(walk.gravity());
  ASSERT_EQ(walk.outputs_size(), 2);
  EXPECT_EQ(walk.outputs(0), v1::OUTPUT_DQDD_DQ);
  const v1::Scene& trot = scenes.scenes(1);
  EXPECT_FALSE(trot.gravity());
  ASSERT_EQ(trot.force_links_size(), 2);
  EXPECT_EQ(trot.force_links(1), "rh_lowerleg");
  EXPECT_TRUE(scenes.scenes(2).minv_supplied());

  grpc::ClientContext one;
  v1::GetSceneRequest req;
  req.set_name("trot");
  v1::Scene got;
  ASSERT_TRUE(stub->GetScene(&one, req, &got).ok());
  EXPECT_EQ(got.SerializeAsString(), trot.SerializeAsString());
  grpc::ClientContext unknown;
  req.set_name("dance");
  const grpc::Status s = stub->GetScene(&unknown, req, &got);
  EXPECT_EQ(s.error_code(), grpc::StatusCode::NOT_FOUND);
  EXPECT_THAT(s.error_message(), HasSubstr("scene 'dance' is not configured (scenes: walk, trot, cached)"));
}

TEST(DaemonScenes, ARequestNamingASceneGetsTheCoreOnTheScenesModel) {
  std::unique_ptr<Daemon> daemon = start_daemon(scene_options());
  ASSERT_NE(daemon, nullptr);
  auto stub = v1::Dynamics::NewStub(channel_to(daemon->addresses()[0]));
  constexpr std::uint32_t kN = 3;

  // the humanoid: no outputs listed, so the scene's (both gradients); the model may be named
  {
    v1::ComputeRequest req = make_request("talos", kWalkNv, kN, 11, "walk", {});
    req.set_scene("walk");
    v1::ComputeResponse resp;
    grpc::ClientContext ctx;
    const grpc::Status s = stub->Compute(&ctx, req, &resp);
    ASSERT_TRUE(s.ok()) << s.error_message();
    std::vector<LockedJoint> locked;
    for (const auto& [j, v] : kWalkLocks) locked.push_back({j, v});
    Model walk;
    ASSERT_TRUE(lock_joints(embedded_model("talos_reduced"), locked, walk).is_ok());
    Workspace ws(walk);
    const std::vector<double> q = values_of(req.q()), qd = values_of(req.qd()), tau = values_of(req.u());
    const std::vector<double> dq = values_of(resp.dqdd_dq()), dqd = values_of(resp.dqdd_dqd());
    EXPECT_TRUE(resp.qdd().data().empty()) << "only the scene's outputs";
    for (std::size_t k = 0; k < kN; ++k) {
      ASSERT_TRUE(evaluate_outputs<double>(walk, ws, state_of(q, k, kWalkNv), state_of(qd, k, kWalkNv),
                                           state_of(tau, k, kWalkNv), InputKind::kTau, kOutputDqddDq | kOutputDqddDqd)
                      .is_ok());
      expect_matrix(dq, k, ws.dqdd_dq, "walk dqdd_dq");
      expect_matrix(dqd, k, ws.dqdd_dqd, "walk dqdd_dqd");
    }
  }

  // the quadruped: no gravity, forces given for its two force links only
  {
    v1::ComputeRequest req = make_request("", kHyqNv, kN, 12, "trot", {v1::OUTPUT_DQDD_DQ});
    req.set_scene("trot");
    std::vector<double> compact(kN * 2 * 6);
    for (std::size_t e = 0; e < compact.size(); ++e) compact[e] = 0.5 * static_cast<double>(e % 7) - 1.0;
    set_tensor(req.mutable_fext(), compact);
    v1::ComputeResponse resp;
    grpc::ClientContext ctx;
    const grpc::Status s = stub->Compute(&ctx, req, &resp);
    ASSERT_TRUE(s.ok()) << s.error_message();
    Model hyq = embedded_model("hyq");
    hyq.gravity.setZero();
    int lf = -1, rh = -1;
    for (int i = 0; i < hyq.nv; ++i) {
      if (hyq.joints[i].child_link == "lf_lowerleg") lf = i;
      if (hyq.joints[i].child_link == "rh_lowerleg") rh = i;
    }
    ASSERT_GE(lf, 0);
    ASSERT_GE(rh, 0);
    Workspace ws(hyq);
    const std::vector<double> q = values_of(req.q()), qd = values_of(req.qd()), tau = values_of(req.u());
    const std::vector<double> dq = values_of(resp.dqdd_dq());
    for (std::size_t k = 0; k < kN; ++k) {
      std::vector<double> full(6 * kHyqNv, 0.0);
      for (int c = 0; c < 6; ++c) {
        full[6 * lf + c] = compact[(k * 2 + 0) * 6 + c];
        full[6 * rh + c] = compact[(k * 2 + 1) * 6 + c];
      }
      ASSERT_TRUE(evaluate_outputs<double>(hyq, ws, state_of(q, k, kHyqNv), state_of(qd, k, kHyqNv),
                                           state_of(tau, k, kHyqNv), InputKind::kTau, kOutputDqddDq, full.data())
                      .is_ok());
      expect_matrix(dq, k, ws.dqdd_dq, "trot dqdd_dq");
    }
  }

  // the arm with M^-1 from the request (say, cached from the last control step)
  {
    v1::ComputeRequest req = make_request("", kIiwaNv, kN, 13, "cached", {});
    req.set_scene("cached");
    const Model iiwa = embedded_model("iiwa14");
    Workspace ws(iiwa);
    const std::vector<double> q = values_of(req.q()), qd = values_of(req.qd()), tau = values_of(req.u());
    std::vector<double> minv;
    for (std::size_t k = 0; k < kN; ++k) {
      ASSERT_TRUE(evaluate_outputs<double>(iiwa, ws, state_of(q, k, kIiwaNv), state_of(qd, k, kIiwaNv),
                                           state_of(tau, k, kIiwaNv), InputKind::kTau, kOutputMinv)
                      .is_ok());
      for (int i = 0; i < kIiwaNv; ++i)
        for (int j = 0; j < kIiwaNv; ++j) minv.push_back(ws.Minv(i, j));
    }
    set_tensor(req.mutable_minv(), minv);
    v1::ComputeResponse resp;
    grpc::ClientContext ctx;
    const grpc::Status s = stub->Compute(&ctx, req, &resp);
    ASSERT_TRUE(s.ok()) << s.error_message();
    const std::vector<double> dq = values_of(resp.dqdd_dq()), qdd = values_of(resp.qdd());
    ASSERT_EQ(qdd.size(), kN * kIiwaNv);
    for (std::size_t k = 0; k < kN; ++k) {
      const Eigen::Map<const Eigen::MatrixXd> given(minv.data() + k * kIiwaNv * kIiwaNv, kIiwaNv, kIiwaNv);
      const Eigen::MatrixXd supplied = given.transpose();  // row-major on the wire
      ASSERT_TRUE(evaluate_outputs<double>(iiwa, ws, state_of(q, k, kIiwaNv), state_of(qd, k, kIiwaNv),
                                           state_of(tau, k, kIiwaNv), InputKind::kTau,
                                           kOutputQdd | kOutputDqddDq | kOutputDqddDqd, nullptr, &supplied)
                      .is_ok());
      expect_matrix(dq, k, ws.dqdd_dq, "cached dqdd_dq");
      for (int i = 0; i < kIiwaNv; ++i) ASSERT_EQ(qdd[k * kIiwaNv + i], ws.qdd(i)) << "state " << k;
    }
  }
}

TEST(DaemonScenes, BadRequestsAreRefusedAndTheDaemonKeepsServing) {
  std::unique_ptr<Daemon> daemon = start_daemon(scene_options());
  ASSERT_NE(daemon, nullptr);
  auto stub = v1::Dynamics::NewStub(channel_to(daemon->addresses()[0]));
  const auto refused = [&](v1::ComputeRequest req, grpc::StatusCode code, const std::string& why) {
    v1::ComputeResponse resp;
    grpc::ClientContext ctx;
    const grpc::Status s = stub->Compute(&ctx, req, &resp);
    EXPECT_EQ(s.error_code(), code) << why << ": " << s.error_message();
    EXPECT_THAT(s.error_message(), HasSubstr(why));
  };
  v1::ComputeRequest req = make_request("", kHyqNv, 2, 1, "bad", {});
  req.set_scene("dance");
  refused(req, grpc::StatusCode::NOT_FOUND, "request 'bad': scene 'dance' is not configured (scenes: walk, trot, cached)");
  req.set_scene("trot");
  req.add_outputs(v1::OUTPUT_DQDD_DQD);
  refused(req, grpc::StatusCode::INVALID_ARGUMENT, "scene 'trot': output dqdd_dqd is not one the scene computes (dqdd_dq)");
  req.clear_outputs();
  set_tensor(req.mutable_fext(), std::vector<double>(2 * kHyqNv * 6, 0.0));
  refused(req, grpc::StatusCode::INVALID_ARGUMENT, "fext holds 144 values; the scene takes 2 states x 2 force links");
  req.clear_fext();
  req.set_model("iiwa14");
  refused(req, grpc::StatusCode::INVALID_ARGUMENT, "scene 'trot' is made from model 'hyq'");
  req.clear_model();
  // the scene's joint count, not the model's: talos has 32 joints, the scene 28
  v1::ComputeRequest walk = make_request("", kTalosNv, 1, 2, "wide", {});
  walk.set_scene("walk");
  refused(walk, grpc::StatusCode::INVALID_ARGUMENT, "request 'wide'");
  // and the daemon still serves
  v1::ComputeResponse resp;
  grpc::ClientContext ctx;
  EXPECT_TRUE(stub->Compute(&ctx, req, &resp).ok());
  EXPECT_EQ(resp.dqdd_dq().data().size(), 2u * kHyqNv * kHyqNv * sizeof(double));
}

TEST(DaemonScenes, ABadSceneStopsTheStartWithItsName) {
  DaemonOptions options = scene_options();
  options.config.scenes[1].force_links.push_back("trunk");
  std::unique_ptr<Daemon> daemon;
  const Status s = Daemon::create(std::move(options), daemon);
  EXPECT_FALSE(s.is_ok());
  EXPECT_THAT(s.message(), HasSubstr("scene 'trot': force link 'trunk' is not moved by a joint of the scene"));
}

}  // namespace
}  // namespace rbdgrad::server
