// rbdgrad::Client: unary calls (sync on the caller's thread, async on the gRPC callback API) and
// the model and server descriptions.
#include <algorithm>
#include <climits>
#include <utility>

#include <grpcpp/create_channel.h>
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
}

Client::Client(std::string address, ClientOptions options) : impl_(std::make_unique<Impl>()) {
  impl_->address = std::move(address);
  impl_->options = options;
  grpc::ChannelArguments args;
  const int max_bytes = static_cast<int>(std::clamp<std::int64_t>(options.max_message_bytes, 0, INT_MAX));
  args.SetMaxReceiveMessageSize(max_bytes);
  args.SetMaxSendMessageSize(max_bytes);
  impl_->channel = grpc::CreateCustomChannel(impl_->address, grpc::InsecureChannelCredentials(), args);
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
