// rbdgrad::Client: unary calls (sync on the caller's thread, async on the gRPC callback API) and
// the model and server descriptions.
#include <algorithm>
#include <climits>
#include <fstream>
#include <future>
#include <sstream>
#include <utility>

#include <grpcpp/create_channel.h>
#include <grpcpp/generic/generic_stub.h>
#include <grpcpp/security/credentials.h>
#include <grpcpp/support/channel_arguments.h>

#include "client_impl.hpp"
#include "compute_result_impl.hpp"
#include "info_decoding.hpp"
#include "request_encoding.hpp"

namespace rbdgrad {

namespace {

using Clock = std::chrono::steady_clock;

double microseconds_since(Clock::time_point start) {
  return std::chrono::duration<double, std::micro>(Clock::now() - start).count();
}

// One asynchronous call: everything gRPC needs until the completion callback, which deletes it.
struct AsyncCall {
  grpc::ClientContext ctx;
  v1::ComputeRequest msg;
  ComputeResult result;
  detail::ExpectedResult expected;
  Clock::time_point start;
  Client::ComputeCallback done;
};

// Runs a unary call `method` of the stub into `response`, with the client's deadline rules.
template <class Request, class Response, class Method>
RpcStatus unary(const Client::Impl& impl, Method method, const Request& request, Response& response,
                std::optional<std::chrono::nanoseconds> timeout) {
  grpc::ClientContext ctx;
  impl.prepare(ctx, timeout);
  return detail::from_grpc((impl.stub.get()->*method)(&ctx, request, &response));
}

}  // namespace

namespace detail {

std::chrono::system_clock::time_point deadline_after(std::chrono::nanoseconds timeout) {
  constexpr std::chrono::nanoseconds kLongest = std::chrono::hours(24 * 365);
  return std::chrono::system_clock::now() +
         std::chrono::duration_cast<std::chrono::system_clock::duration>(std::clamp(timeout, std::chrono::nanoseconds(0), kLongest));
}

}  // namespace detail

Client::Impl::~Impl() {
  std::unique_lock lock(async_mutex);
  async_released.wait(lock, [this] { return async_in_flight == 0; });
}

void Client::Impl::async_started() {
  std::lock_guard lock(async_mutex);
  ++async_in_flight;
}

void Client::Impl::async_finished() {
  // notified under the lock: the destructor cannot return (and free the condition variable) first
  std::lock_guard lock(async_mutex);
  if (--async_in_flight == 0) async_released.notify_all();
}

void Client::Impl::prepare(grpc::ClientContext& ctx, std::optional<std::chrono::nanoseconds> timeout) const {
  ctx.set_deadline(detail::deadline_after(timeout_or_default(timeout)));
  ctx.set_wait_for_ready(options.wait_for_ready);
  add_token(ctx);
}

void Client::Impl::add_token(grpc::ClientContext& ctx) const {
  if (!authorization.empty()) ctx.AddMetadata("authorization", authorization);
}

namespace {

// A file of TlsOptions, whole ("" for no file); ClientError naming the option and the file.
std::string read_tls_file(const char* option, const std::string& path) {
  if (path.empty()) return "";
  std::ifstream in(path, std::ios::binary);
  std::ostringstream text;
  if (in) text << in.rdbuf();
  if (!in || text.str().empty())
    throw ClientError({RpcCode::kInvalidArgument, std::string("client: tls.") + option + ": cannot read '" + path + "'"});
  return text.str();
}

// "grpc.health.v1.HealthCheckResponse.ServingStatus" by number
const char* serving_status_name(std::uint64_t v) {
  switch (v) {
    case 0: return "UNKNOWN";
    case 1: return "SERVING";
    case 2: return "NOT_SERVING";
    case 3: return "SERVICE_UNKNOWN";
  }
  return "UNKNOWN";
}

bool read_varint(const std::string& bytes, std::size_t& at, std::uint64_t& out) {
  out = 0;
  for (int shift = 0; at < bytes.size() && shift < 64; shift += 7) {
    const auto b = static_cast<unsigned char>(bytes[at++]);
    out |= std::uint64_t{b & 0x7fu} << shift;
    if ((b & 0x80u) == 0) return true;
  }
  return false;
}

// HealthCheckResponse's field 1 (status, an enum); the other fields skipped. False when malformed.
bool decode_serving_status(const std::string& bytes, std::uint64_t& status) {
  status = 0;  // proto3: an absent field is UNKNOWN
  std::size_t at = 0;
  while (at < bytes.size()) {
    std::uint64_t key = 0, value = 0;
    if (!read_varint(bytes, at, key)) return false;
    switch (key & 7) {
      case 0:
        if (!read_varint(bytes, at, value)) return false;
        if ((key >> 3) == 1) status = value;
        break;
      case 1: at += 8; break;
      case 2:
        if (!read_varint(bytes, at, value) || value > bytes.size() - std::min(at, bytes.size())) return false;
        at += value;
        break;
      case 5: at += 4; break;
      default: return false;
    }
  }
  return at == bytes.size();
}

}  // namespace

Client::Client(std::string address, ClientOptions options) : impl_(std::make_unique<Impl>()) {
  impl_->address = std::move(address);
  impl_->options = options;
  if (!options.bearer_token.empty()) impl_->authorization = "Bearer " + options.bearer_token;
  grpc::ChannelArguments args;
  const int max_bytes = static_cast<int>(std::clamp<std::int64_t>(options.max_message_bytes, 0, INT_MAX));
  args.SetMaxReceiveMessageSize(max_bytes);
  args.SetMaxSendMessageSize(max_bytes);
  std::shared_ptr<grpc::ChannelCredentials> credentials = grpc::InsecureChannelCredentials();
  if (options.tls) {
    const TlsOptions& tls = *options.tls;
    if (tls.cert_file.empty() != tls.key_file.empty())
      throw ClientError({RpcCode::kInvalidArgument, "client: tls.cert_file and tls.key_file go together"});
    grpc::SslCredentialsOptions ssl;
    ssl.pem_root_certs = read_tls_file("ca_file", tls.ca_file);
    ssl.pem_cert_chain = read_tls_file("cert_file", tls.cert_file);
    ssl.pem_private_key = read_tls_file("key_file", tls.key_file);
    if (!tls.target_name_override.empty()) args.SetSslTargetNameOverride(tls.target_name_override);
    credentials = grpc::SslCredentials(ssl);
  }
  impl_->channel = grpc::CreateCustomChannel(impl_->address, credentials, args);
  impl_->stub = v1::Dynamics::NewStub(impl_->channel);
}

Client::~Client() = default;
Client::Client(Client&&) noexcept = default;
Client& Client::operator=(Client&&) noexcept = default;

const std::string& Client::address() const noexcept { return impl_->address; }
const ClientOptions& Client::options() const noexcept { return impl_->options; }

ComputeResult Client::compute(const ComputeRequest& req) const {
  ComputeResult result;
  if (RpcStatus st = compute(req, result); !st) throw ClientError(std::move(st));
  return result;
}

RpcStatus Client::compute(const ComputeRequest& req, ComputeResult& out) const {
  const Clock::time_point start = Clock::now();
  // one request message per thread, reused: its byte buffers keep their capacity between calls
  thread_local v1::ComputeRequest msg;
  ComputeResult::Impl& result = detail::ResultAccess::reset_for_call(out);
  if (RpcStatus st = detail::encode_request(req, msg); !st) return st;
  grpc::ClientContext ctx;
  impl_->prepare(ctx, req.timeout);
  if (grpc::Status st = impl_->stub->Compute(&ctx, msg, &result.response); !st.ok()) return detail::from_grpc(st);
  return detail::adopt_response(detail::expected_result(req), result, microseconds_since(start));
}

void Client::compute_async(const ComputeRequest& req, ComputeCallback done) const {
  auto call = std::make_unique<AsyncCall>();
  call->start = Clock::now();
  if (RpcStatus st = detail::encode_request(req, call->msg); !st) {
    done(std::move(st), ComputeResult());
    return;
  }
  call->expected = detail::expected_result(req);
  call->done = std::move(done);
  impl_->prepare(call->ctx, req.timeout);
  ComputeResult::Impl& result = detail::ResultAccess::reset_for_call(call->result);
  AsyncCall* raw = call.release();  // owned by the callback from here
  impl_->async_started();
  impl_->stub->async()->Compute(&raw->ctx, &raw->msg, &result.response, [raw, r = &result, impl = impl_.get()](
                                                                             grpc::Status grpc_status) {
    std::unique_ptr<AsyncCall> owned(raw);
    RpcStatus st = grpc_status.ok() ? detail::adopt_response(owned->expected, *r, microseconds_since(owned->start))
                                    : detail::from_grpc(grpc_status);
    if (!st) detail::ResultAccess::invalidate(owned->result);
    // The call's own objects go before the caller hears of the answer: its ClientContext holds a
    // reference to the channel, whose last reference must not be dropped on this gRPC thread
    // (~Impl waits for this).
    ComputeResult answer = std::move(owned->result);
    Client::ComputeCallback callback = std::move(owned->done);
    owned.reset();
    impl->async_finished();
    callback(std::move(st), std::move(answer));
  });
}

std::future<ComputeResult> Client::compute_async(const ComputeRequest& req) const {
  auto promise = std::make_shared<std::promise<ComputeResult>>();
  std::future<ComputeResult> future = promise->get_future();
  compute_async(req, [promise](RpcStatus status, ComputeResult result) {
    if (status) promise->set_value(std::move(result));
    else promise->set_exception(std::make_exception_ptr(ClientError(std::move(status))));
  });
  return future;
}

RpcStatus Client::list_models(std::vector<ServedModel>& out, std::optional<std::chrono::nanoseconds> timeout) const {
  v1::ListModelsResponse response;
  RpcStatus st = unary(*impl_, &v1::Dynamics::Stub::ListModels, v1::ListModelsRequest(), response, timeout);
  if (st) out = detail::decode(response);
  return st;
}

RpcStatus Client::get_model(const std::string& name, ModelDescription& out,
                            std::optional<std::chrono::nanoseconds> timeout) const {
  v1::GetModelRequest request;
  request.set_name(name);
  v1::GetModelResponse response;
  RpcStatus st = unary(*impl_, &v1::Dynamics::Stub::GetModel, request, response, timeout);
  if (st) out = detail::decode(response);
  return st;
}

RpcStatus Client::list_scenes(std::vector<SceneDescription>& out,
                              std::optional<std::chrono::nanoseconds> timeout) const {
  v1::ListScenesResponse response;
  RpcStatus st = unary(*impl_, &v1::Dynamics::Stub::ListScenes, v1::ListScenesRequest(), response, timeout);
  if (st) {
    out.clear();
    for (const v1::Scene& s : response.scenes()) out.push_back(detail::decode(s));
  }
  return st;
}

RpcStatus Client::get_scene(const std::string& name, SceneDescription& out,
                            std::optional<std::chrono::nanoseconds> timeout) const {
  v1::GetSceneRequest request;
  request.set_name(name);
  v1::Scene response;
  RpcStatus st = unary(*impl_, &v1::Dynamics::Stub::GetScene, request, response, timeout);
  if (st) out = detail::decode(response);
  return st;
}

RpcStatus Client::server_info(ServerInfo& out, std::optional<std::chrono::nanoseconds> timeout) const {
  v1::GetServerInfoResponse response;
  RpcStatus st = unary(*impl_, &v1::Dynamics::Stub::GetServerInfo, v1::GetServerInfoRequest(), response, timeout);
  if (st) out = detail::decode(response);
  return st;
}

RpcStatus Client::check_health(std::string& status, const std::string& service,
                               std::optional<std::chrono::nanoseconds> timeout) const {
  // Through the generic stub, the messages encoded by hand: Debian ships no generated code for
  // grpc.health.v1, and a second copy of its descriptors in a process that has one aborts.
  // HealthCheckRequest is {string service = 1}; HealthCheckResponse is {ServingStatus status = 1}.
  std::string request;
  if (!service.empty()) {
    request.push_back('\x0a');
    for (std::uint64_t n = service.size(); ; n >>= 7) {
      request.push_back(static_cast<char>((n & 0x7f) | (n > 0x7f ? 0x80 : 0)));
      if (n <= 0x7f) break;
    }
    request += service;
  }
  grpc::Slice slice(request);
  const grpc::ByteBuffer request_bytes(&slice, 1);
  grpc::ByteBuffer response_bytes;
  grpc::ClientContext ctx;
  impl_->prepare(ctx, timeout);
  grpc::GenericStub stub(impl_->channel);
  std::promise<grpc::Status> done;
  stub.UnaryCall(&ctx, "/grpc.health.v1.Health/Check", grpc::StubOptions(), &request_bytes, &response_bytes,
                 [&done](grpc::Status st) { done.set_value(std::move(st)); });
  const grpc::Status st = done.get_future().get();
  if (!st.ok()) return detail::from_grpc(st);
  std::vector<grpc::Slice> slices;
  std::string bytes;
  if (response_bytes.Dump(&slices).ok())
    for (const grpc::Slice& s : slices) bytes.append(reinterpret_cast<const char*>(s.begin()), s.size());
  std::uint64_t value = 0;
  if (!decode_serving_status(bytes, value))
    return {RpcCode::kInternal, "client: the health check's response could not be read"};
  status = serving_status_name(value);
  return RpcStatus::ok();
}

RpcStatus Client::calibrate(std::vector<std::string>& log, ServerInfo& info,
                           std::optional<std::chrono::nanoseconds> timeout) const {
  v1::CalibrateResponse response;
  RpcStatus st = unary(*impl_, &v1::Dynamics::Stub::Calibrate, v1::CalibrateRequest(), response, timeout);
  if (st) {
    log.assign(response.log().begin(), response.log().end());
    info = detail::decode(response.info());
  }
  return st;
}

std::vector<ServedModel> Client::list_models(std::optional<std::chrono::nanoseconds> timeout) const {
  std::vector<ServedModel> out;
  if (RpcStatus st = list_models(out, timeout); !st) throw ClientError(std::move(st));
  return out;
}

ModelDescription Client::get_model(const std::string& name, std::optional<std::chrono::nanoseconds> timeout) const {
  ModelDescription out;
  if (RpcStatus st = get_model(name, out, timeout); !st) throw ClientError(std::move(st));
  return out;
}

std::vector<SceneDescription> Client::list_scenes(std::optional<std::chrono::nanoseconds> timeout) const {
  std::vector<SceneDescription> out;
  if (RpcStatus st = list_scenes(out, timeout); !st) throw ClientError(std::move(st));
  return out;
}

SceneDescription Client::get_scene(const std::string& name, std::optional<std::chrono::nanoseconds> timeout) const {
  SceneDescription out;
  if (RpcStatus st = get_scene(name, out, timeout); !st) throw ClientError(std::move(st));
  return out;
}

ServerInfo Client::server_info(std::optional<std::chrono::nanoseconds> timeout) const {
  ServerInfo out;
  if (RpcStatus st = server_info(out, timeout); !st) throw ClientError(std::move(st));
  return out;
}

}  // namespace rbdgrad
