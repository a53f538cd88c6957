// The fake Dynamics service of the client tests (see the header).
#include "fake_dynamics_service.hpp"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cmath>
#include <cstring>
#include <thread>
#include <tuple>

#include <grpcpp/security/server_credentials.h>
#include <grpcpp/server_builder.h>

#include "request_batch.hpp"

namespace rbdgrad::testing {

namespace v1 = rbdgrad::v1;

namespace {

const v1::Output kOutputs[] = {v1::OUTPUT_QDD, v1::OUTPUT_MINV,    v1::OUTPUT_DQDD_DQ, v1::OUTPUT_DQDD_DQD,
                               v1::OUTPUT_TAU, v1::OUTPUT_DTAU_DQ, v1::OUTPUT_DTAU_DQD, v1::OUTPUT_M};

// the server's own mapping of outputs to response tensors and shapes
bool is_vector(v1::Output o) { return !server::is_matrix_output(o); }

std::vector<double> doubles(const v1::Tensor& t) {
  std::vector<double> v(t.data().size() / sizeof(double));
  std::memcpy(v.data(), t.data().data(), v.size() * sizeof(double));
  return v;
}

template <class T>
void append(std::string& bytes, T value) {
  bytes.append(reinterpret_cast<const char*>(&value), sizeof value);
}

}  // namespace

double fake_output_value(v1::Output o, const double* q, const double* qd, const double* u, int i, int j) {
  const double base = 1000.0 * static_cast<int>(o);
  if (is_vector(o)) return base + q[i] + 2 * qd[i] + 3 * u[i];
  // i and j enter differently, so a transposed or shifted view shows
  return base + 10.0 * i + j + q[i] * qd[j] + u[j];
}

grpc::Status FakeDynamicsService::answer(grpc::ServerContext* ctx, const v1::ComputeRequest& req,
                                         v1::ComputeResponse& resp) {
  {
    std::lock_guard lock(mutex_);
    received_.push_back(req);
    last_time_left_ = std::chrono::duration_cast<std::chrono::milliseconds>(ctx->deadline() - std::chrono::system_clock::now());
  }
  if (req.model() == "broken") return {grpc::StatusCode::INVALID_ARGUMENT, kBrokenMessage};
  if (req.model() == "unknown") return {grpc::StatusCode::NOT_FOUND, kUnknownMessage};
  if (req.model() == "slow") {
    for (int waited_ms = 0; waited_ms < 5000 && !ctx->IsCancelled(); waited_ms += 5)
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    if (ctx->IsCancelled()) return {grpc::StatusCode::CANCELLED, "cancelled while slow"};
  }
  // the daemon's checks, in short
  const int n = static_cast<int>(req.num_states());
  if (n < 1) return {grpc::StatusCode::INVALID_ARGUMENT, "num_states must be at least 1"};
  // a request of the scene "reach" that lists no outputs gets the scene's
  std::vector<int> outputs(req.outputs().begin(), req.outputs().end());
  if (outputs.empty() && req.scene() == "reach") outputs = {v1::OUTPUT_QDD, v1::OUTPUT_DQDD_DQ};
  if (outputs.empty()) return {grpc::StatusCode::INVALID_ARGUMENT, "no outputs requested"};
  const std::vector<double> q = doubles(req.q()), qd = doubles(req.qd()), u = doubles(req.u());
  const int nv = static_cast<int>(q.size()) / n;
  if (nv < 1 || q.size() != static_cast<std::size_t>(n * nv) || qd.size() != q.size() || u.size() != q.size())
    return {grpc::StatusCode::INVALID_ARGUMENT, "q, qd and u must hold num_states x nv values each"};

  // a NaN in q is refused like the daemon does, naming the state (per-state errors)
  for (std::size_t e = 0; e < q.size(); ++e)
    if (std::isnan(q[e]))
      return {grpc::StatusCode::INVALID_ARGUMENT, "state " + std::to_string(e / static_cast<std::size_t>(nv)) +
                                                      ": field 'q' element " + std::to_string(e % static_cast<std::size_t>(nv)) +
                                                      " is not finite (nan)"};
  const bool f32 = req.output_type() == v1::SCALAR_TYPE_F32;
  for (v1::Output o : kOutputs) {
    bool wanted = false;
    for (int x : outputs) wanted |= x == o;
    if (!wanted) continue;
    v1::Tensor* t = server::response_tensor(resp, o);
    t->set_type(f32 ? v1::SCALAR_TYPE_F32 : v1::SCALAR_TYPE_F64);
    std::string& bytes = *t->mutable_data();
    const int cols = is_vector(o) ? 1 : nv;
    for (int k = 0; k < n; ++k) {
      const std::size_t s = static_cast<std::size_t>(k * nv);
      for (int i = 0; i < nv; ++i) {
        for (int j = 0; j < cols; ++j) {
          const double v = fake_output_value(o, &q[s], &qd[s], &u[s], i, j);
          if (f32) append(bytes, static_cast<float>(v));
          else append(bytes, v);
        }
      }
    }
    if (req.model() == "short") bytes.resize(bytes.size() - (f32 ? sizeof(float) : sizeof(double)));
  }
  resp.set_request_id(req.request_id());
  resp.set_num_states(req.num_states());
  resp.set_backend(req.backend() == v1::BACKEND_AUTO ? v1::BACKEND_CPU : req.backend());
  resp.set_precision(req.precision() == v1::PRECISION_AUTO ? v1::PRECISION_F64 : req.precision());
  resp.mutable_timings()->set_queue_us(kQueueUs);
  resp.mutable_timings()->set_compute_us(kComputeUs);
  resp.mutable_timings()->set_total_us(kTotalUs);
  if (req.request_id() == "split") {
    // as a daemon that split the request: the first state on the cpu, the rest on cuda
    for (const auto& [backend, first, count] : {std::tuple{v1::BACKEND_CPU, 0u, 1u},
                                                std::tuple{v1::BACKEND_CUDA, 1u, req.num_states() - 1}}) {
      v1::BatchPart* part = resp.add_parts();
      part->set_backend(backend);
      part->set_first_state(first);
      part->set_num_states(count);
      part->set_compute_us(10 + first);
    }
  }
  return grpc::Status::OK;
}

void FakeDynamicsService::fail_next(int count, grpc::StatusCode code) {
  std::lock_guard lock(mutex_);
  failures_left_ = count;
  failure_code_ = code;
}

std::vector<std::chrono::steady_clock::time_point> FakeDynamicsService::call_times() const {
  std::lock_guard lock(mutex_);
  return call_times_;
}

grpc::Status FakeDynamicsService::injected() {
  std::lock_guard lock(mutex_);
  call_times_.push_back(std::chrono::steady_clock::now());
  if (failures_left_ <= 0) return grpc::Status::OK;
  --failures_left_;
  return {failure_code_, "injected failure"};
}

grpc::Status FakeDynamicsService::Compute(grpc::ServerContext* ctx, const v1::ComputeRequest* req,
                                          v1::ComputeResponse* resp) {
  if (grpc::Status st = injected(); !st.ok()) return st;
  return answer(ctx, *req, *resp);
}

grpc::Status FakeDynamicsService::ComputeStream(
    grpc::ServerContext* ctx, grpc::ServerReaderWriter<v1::ComputeResponse, v1::ComputeRequest>* stream) {
  {
    std::lock_guard lock(mutex_);
    ++streams_;
  }
  if (grpc::Status st = injected(); !st.ok()) return st;
  v1::ComputeRequest req;
  while (stream->Read(&req)) {
    v1::ComputeResponse resp;
    if (grpc::Status st = answer(ctx, req, resp); !st.ok()) return st;  // the daemon ends the stream so too
    if (!stream->Write(resp)) break;
  }
  return grpc::Status::OK;
}

grpc::Status FakeDynamicsService::ListModels(grpc::ServerContext*, const v1::ListModelsRequest*,
                                             v1::ListModelsResponse* resp) {
  if (grpc::Status st = injected(); !st.ok()) return st;
  auto* a = resp->add_models();
  a->set_name("iiwa14");
  a->set_nv(7);
  a->set_source("<embedded>");
  auto* b = resp->add_models();
  b->set_name("panda");
  b->set_nv(9);
  b->set_source("/robots/panda.urdf");
  return grpc::Status::OK;
}

namespace {
v1::Scene reach_scene() {
  v1::Scene s;
  s.set_name("reach");
  s.set_model("twolink");
  s.set_nv(1);
  v1::Joint* j = s.add_joints();
  j->set_name("shoulder");
  j->set_type("revolute");
  j->set_parent(-1);
  j->set_child_link("upper_arm");
  s.add_locked_joints("wrist");
  s.add_locked_values(0.25);
  s.set_gravity(false);
  s.add_force_links("upper_arm");
  s.add_outputs(v1::OUTPUT_QDD);
  s.add_outputs(v1::OUTPUT_DQDD_DQ);
  s.set_minv_supplied(true);
  return s;
}
}  // namespace

grpc::Status FakeDynamicsService::ListScenes(grpc::ServerContext*, const v1::ListScenesRequest*,
                                             v1::ListScenesResponse* resp) {
  *resp->add_scenes() = reach_scene();
  return grpc::Status::OK;
}

grpc::Status FakeDynamicsService::GetScene(grpc::ServerContext*, const v1::GetSceneRequest* req, v1::Scene* resp) {
  if (req->name() != "reach") return {grpc::StatusCode::NOT_FOUND, "scene '" + req->name() + "' is not configured"};
  *resp = reach_scene();
  return grpc::Status::OK;
}

grpc::Status FakeDynamicsService::RegisterScene(grpc::ServerContext*, const v1::RegisterSceneRequest* req,
                                                v1::Scene* resp) {
  {
    std::lock_guard lock(mutex_);
    registrations_.push_back(*req);
  }
  if (grpc::Status st = injected(); !st.ok()) return st;
  if (req->name() == "twolink") return {grpc::StatusCode::ALREADY_EXISTS, "'twolink' is the name of a model"};
  *resp = reach_scene();
  resp->set_name(req->name());
  return grpc::Status::OK;
}

std::vector<v1::RegisterSceneRequest> FakeDynamicsService::registrations() const {
  std::lock_guard lock(mutex_);
  return registrations_;
}

grpc::Status FakeDynamicsService::GetModel(grpc::ServerContext*, const v1::GetModelRequest* req,
                                           v1::GetModelResponse* resp) {
  if (req->name() != "twolink") return {grpc::StatusCode::NOT_FOUND, "model '" + req->name() + "' is not loaded"};
  resp->set_name("twolink");
  resp->set_nv(2);
  auto* j1 = resp->add_joints();
  j1->set_name("shoulder");
  j1->set_type("revolute");
  j1->set_parent(-1);
  j1->set_parent_link("base");
  j1->set_child_link("upper_arm");
  j1->set_lower_limit(-1.5);
  j1->set_upper_limit(2.5);
  j1->set_effort_limit(80);
  j1->set_velocity_limit(3);
  auto* j2 = resp->add_joints();
  j2->set_name("wrist");
  j2->set_type("continuous");
  j2->set_parent(0);
  j2->set_parent_link("upper_arm");
  j2->set_child_link("hand");
  j2->set_effort_limit(10);
  j2->set_velocity_limit(6);
  for (double g : {0.0, -9.81, 0.5}) resp->add_gravity(g);
  resp->set_summary("model 'twolink': 2 moving joints");
  return grpc::Status::OK;
}

grpc::Status FakeDynamicsService::GetServerInfo(grpc::ServerContext*, const v1::GetServerInfoRequest*,
                                                v1::GetServerInfoResponse* resp) {
  if (grpc::Status st = injected(); !st.ok()) return st;
  resp->set_version("9.8.7-fake");
  auto* cpu = resp->add_backends();
  cpu->set_backend(v1::BACKEND_CPU);
  cpu->set_name("cpu");
  cpu->set_ready(true);
  cpu->add_precisions(v1::PRECISION_F64);
  cpu->add_precisions(v1::PRECISION_F32);
  auto* fpga = resp->add_backends();
  fpga->set_backend(v1::BACKEND_FPGA);
  fpga->set_name("fpga");
  fpga->set_ready(false);
  fpga->set_reason("no XRT device found");
  fpga->add_precisions(v1::PRECISION_FIXED);
  fpga->set_max_batch(4096);
  resp->set_max_states_per_request(1000);
  resp->set_max_message_bytes(uint64_t{5} << 30);  // above 32 bits on purpose
  resp->set_max_concurrent_requests(8);
  return grpc::Status::OK;
}

std::vector<v1::ComputeRequest> FakeDynamicsService::received() const {
  std::lock_guard lock(mutex_);
  return received_;
}

std::chrono::milliseconds FakeDynamicsService::last_time_left() const {
  std::lock_guard lock(mutex_);
  return last_time_left_;
}

int FakeDynamicsService::stream_count() const {
  std::lock_guard lock(mutex_);
  return streams_;
}

FakeServer::FakeServer() {
  grpc::ServerBuilder builder;
  int port = 0;
  builder.AddListeningPort("127.0.0.1:0", grpc::InsecureServerCredentials(), &port);
  builder.RegisterService(&service_);
  server_ = builder.BuildAndStart();
  address_ = "127.0.0.1:" + std::to_string(port);
}

FakeServer::~FakeServer() { server_->Shutdown(std::chrono::system_clock::now() + std::chrono::seconds(1)); }

std::string unused_address() {
  const int fd = ::socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  socklen_t len = sizeof addr;
  ::bind(fd, reinterpret_cast<sockaddr*>(&addr), len);
  ::getsockname(fd, reinterpret_cast<sockaddr*>(&addr), &len);
  const int port = ntohs(addr.sin_port);
  ::close(fd);  // nothing listens there now
  return "127.0.0.1:" + std::to_string(port);
}

}  // namespace rbdgrad::testing
