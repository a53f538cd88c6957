// Shared by the daemon tests (daemon_test.cpp, daemon_lifecycle_test.cpp): request builders,
// tensor access, generic gRPC calls and an in-process daemon on ephemeral ports with the real CPU
// backend and the fake "cuda" one (tests/server/fakes/fake_cuda.cpp).
#pragma once

#include <gtest/gtest.h>
#include <grpcpp/create_channel.h>
#include <grpcpp/generic/generic_stub.h>
#include <grpcpp/grpcpp.h>
#include <unistd.h>

#include <chrono>
#include <cstring>
#include <future>
#include <memory>
#include <random>
#include <string>
#include <thread>
#include <vector>

#include "daemon.hpp"
#include "rbdgrad/v1/dynamics.grpc.pb.h"

namespace rbdgrad::server::daemon_testing {

namespace v1 = rbdgrad::v1;
using Clock = std::chrono::steady_clock;

inline constexpr int kIiwaNv = 7;
inline constexpr int kPandaNv = 9;  // 7 arm joints and 2 fingers
inline const std::vector<v1::Output> kAllOutputs = {
    v1::OUTPUT_QDD, v1::OUTPUT_MINV,     v1::OUTPUT_DQDD_DQ,  v1::OUTPUT_DQDD_DQD,
    v1::OUTPUT_TAU, v1::OUTPUT_DTAU_DQ,  v1::OUTPUT_DTAU_DQD, v1::OUTPUT_M};
// the fake cuda backend has every output but M
inline const std::vector<v1::Output> kCudaOutputs(kAllOutputs.begin(), kAllOutputs.end() - 1);

inline void set_tensor(v1::Tensor* t, const std::vector<double>& values) {
  t->set_type(v1::SCALAR_TYPE_F64);
  t->set_data(std::string(reinterpret_cast<const char*>(values.data()), values.size() * sizeof(double)));
}

inline std::vector<double> values_of(const v1::Tensor& t) {
  EXPECT_EQ(t.type(), v1::SCALAR_TYPE_F64);
  std::vector<double> out(t.data().size() / sizeof(double));
  std::memcpy(out.data(), t.data().data(), out.size() * sizeof(double));
  return out;
}

// N random states (seeded): q, qd in [-1, 1], tau in [-5, 5]
inline v1::ComputeRequest make_request(const std::string& model, int nv, uint32_t n, unsigned seed, const std::string& id,
                                const std::vector<v1::Output>& outputs = kAllOutputs) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  std::vector<double> q(n * nv), qd(n * nv), tau(n * nv);
  for (std::size_t i = 0; i < q.size(); ++i) {
    q[i] = unit(rng);
    qd[i] = unit(rng);
    tau[i] = 5.0 * unit(rng);
  }
  v1::ComputeRequest req;
  req.set_model(model);
  req.set_num_states(n);
  req.set_precision(v1::PRECISION_F64);
  req.set_input_kind(v1::INPUT_KIND_TAU);
  for (v1::Output o : outputs) req.add_outputs(o);
  set_tensor(req.mutable_q(), q);
  set_tensor(req.mutable_qd(), qd);
  set_tensor(req.mutable_u(), tau);
  req.set_request_id(id);
  return req;
}

// element i of tensor field `t`, edited in place
inline void set_value(v1::Tensor* t, std::size_t i, double v) {
  std::memcpy(t->mutable_data()->data() + i * sizeof(double), &v, sizeof(double));
}

inline grpc::ByteBuffer buffer_of(const std::string& bytes) {
  grpc::Slice slice(bytes);
  return grpc::ByteBuffer(&slice, 1);
}

inline std::string string_of(const grpc::ByteBuffer& buffer) {
  std::vector<grpc::Slice> slices;
  std::string out;
  if (!buffer.Dump(&slices).ok()) return out;
  for (const grpc::Slice& s : slices) out.append(reinterpret_cast<const char*>(s.begin()), s.size());
  return out;
}

// A unary call through the generic stub: any method, any bytes.
inline grpc::Status generic_unary(const std::shared_ptr<grpc::Channel>& channel, const std::string& method,
                           const std::string& request, std::string* response) {
  grpc::GenericStub stub(channel);
  grpc::ClientContext ctx;
  ctx.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(10));
  const grpc::ByteBuffer req = buffer_of(request);
  grpc::ByteBuffer resp;
  std::promise<grpc::Status> done;
  stub.UnaryCall(&ctx, method, grpc::StubOptions(), &req, &resp, [&](grpc::Status s) { done.set_value(std::move(s)); });
  grpc::Status status = done.get_future().get();
  if (response != nullptr) *response = string_of(resp);
  return status;
}

inline DaemonOptions test_options(const std::string& socket_name) {
  DaemonOptions options;
  ServerConfig& cfg = options.config;
  cfg.listen.tcp = "127.0.0.1:0";
  cfg.listen.unix_socket = socket_name.empty() ? "" : "/tmp/rbdgrad_dt_" + std::to_string(getpid()) + "_" + socket_name;
  ModelConfig panda{"panda", "", "panda", std::array<double, 3>{0.0, 0.0, -9.8}};
  cfg.models = {{"iiwa14", "", "iiwa14", std::nullopt}, panda};
  cfg.plugins = {{FAKE_CUDA_PATH, {{"device", "0"}}}};
  cfg.workers = 2;
  cfg.limits.max_states_per_request = 1000;
  // no timing at start-up (the routing tests turn it on): auto-routed requests go to the cpu
  cfg.scheduler.calibrate = "off";
  options.cpu_plugin_path = RBDGRAD_CPU_PLUGIN_PATH;
  return options;
}

inline std::unique_ptr<Daemon> start_daemon(DaemonOptions options) {
  std::unique_ptr<Daemon> daemon;
  const Status created = Daemon::create(std::move(options), daemon);
  EXPECT_TRUE(created.is_ok()) << created.to_string();
  if (!created) return nullptr;
  const Status started = daemon->start();
  EXPECT_TRUE(started.is_ok()) << started.to_string();
  return started ? std::move(daemon) : nullptr;
}

inline bool wait_for_in_flight(const Daemon& daemon, std::int64_t n) {
  const auto deadline = Clock::now() + std::chrono::seconds(10);
  while (daemon.service().in_flight() != n) {
    if (Clock::now() > deadline) return false;
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  return true;
}

inline std::shared_ptr<grpc::Channel> channel_to(const ListenAddress& address) {
  return grpc::CreateChannel(address.target(), grpc::InsecureChannelCredentials());
}

// a request the fake cuda backend holds for 300 ms
inline v1::ComputeRequest slow_request(const std::string& id) {
  v1::ComputeRequest req = make_request("iiwa14", kIiwaNv, 2, 5, id, kCudaOutputs);
  req.set_backend(v1::BACKEND_CUDA);
  set_value(req.mutable_q(), 0, 4242.0);
  return req;
}

}  // namespace rbdgrad::server::daemon_testing
