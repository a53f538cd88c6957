// rbdgrad::Client: unary calls (sync on the caller's thread, async on the gRPC callback API) and
// the model and server descriptions.
#include <arpa/inet.h>

#include <algorithm>
#include <climits>
#include <cmath>
#include <fstream>
#include <future>
#include <random>
#include <sstream>
#include <thread>
#include <utility>

#include <grpc/impl/codegen/grpc_types.h>
#include <grpcpp/alarm.h>
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

// One asynchronous call: everything gRPC needs until the completion callback of its last attempt,
// which deletes it.
struct AsyncCall {
  std::unique_ptr<grpc::ClientContext> ctx;  // the current attempt's (a context serves one call)
  v1::ComputeRequest msg;
  ComputeResult result;
  ComputeResult::Impl* response = nullptr;  // result's Impl, which the attempt fills
  detail::ExpectedResult expected;
  Clock::time_point start;
  std::chrono::system_clock::time_point deadline;  // of the whole call, every attempt
  std::uint32_t attempts = 0;
  // the pauses between attempts; kept until the call ends, so that none is destroyed in its own
  // callback
  std::vector<std::unique_ptr<grpc::Alarm>> alarms;
  Client::ComputeCallback done;
};

// Runs `attempt(ctx)` (one gRPC call on a fresh context) until it succeeds or the retry policy
// says stop (see Client::Impl::retry_delay), every attempt under the deadline of the first;
// `attempts`, when given, gets the number of attempts made. Returns the last attempt's status.
template <class Attempt>
grpc::Status with_retries(const Client::Impl& impl, std::optional<std::chrono::nanoseconds> timeout,
                          Attempt&& attempt, std::uint32_t* attempts = nullptr) {
  const std::chrono::system_clock::time_point deadline = detail::deadline_after(impl.timeout_or_default(timeout));
  for (int n = 1;; ++n) {
    grpc::ClientContext ctx;
    impl.prepare_until(ctx, deadline);
    grpc::Status st = attempt(ctx);
    if (attempts) *attempts = static_cast<std::uint32_t>(n);
    if (st.ok()) return st;
    const std::optional<std::chrono::nanoseconds> delay = impl.retry_delay(st.error_code(), n, deadline);
    if (!delay) return st;
    std::this_thread::sleep_for(*delay);
  }
}

// Runs a unary call `method` of the stub into `response`, with the client's deadline and retry
// rules (every unary Dynamics call is a pure function of its request: retrying it is safe).
template <class Request, class Response, class Method>
RpcStatus unary(const Client::Impl& impl, Method method, const Request& request, Response& response,
                std::optional<std::chrono::nanoseconds> timeout) {
  return detail::from_grpc(with_retries(impl, timeout, [&](grpc::ClientContext& ctx) {
    return (impl.stub.get()->*method)(&ctx, request, &response);
  }));
}

// The last attempt of an asynchronous call is done: hand the result to the caller.
void finish_async(Client::Impl* impl, AsyncCall* raw, const grpc::Status& grpc_status) {
  std::unique_ptr<AsyncCall> owned(raw);
  RpcStatus st = grpc_status.ok() ? detail::adopt_response(owned->expected, *owned->response, microseconds_since(owned->start))
                                  : detail::from_grpc(grpc_status);
  if (st) owned->response->timings.attempts = owned->attempts;
  else detail::ResultAccess::invalidate(owned->result);
  // The call's own objects go before the caller hears of the answer: its ClientContext holds a
  // reference to the channel, whose last reference must not be dropped on this gRPC thread
  // (~Impl waits for this).
  ComputeResult answer = std::move(owned->result);
  Client::ComputeCallback callback = std::move(owned->done);
  owned.reset();
  impl->async_finished();
  callback(std::move(st), std::move(answer));
}

// Sends one attempt of an asynchronous call; on UNAVAILABLE with a retry left, an alarm sends the
// next one after the pause (no thread waits).
void start_attempt(Client::Impl* impl, AsyncCall* raw) {
  raw->ctx = std::make_unique<grpc::ClientContext>();
  impl->prepare_until(*raw->ctx, raw->deadline);
  ++raw->attempts;
  raw->response = &detail::ResultAccess::reset_for_call(raw->result);
  impl->stub->async()->Compute(raw->ctx.get(), &raw->msg, &raw->response->response, [raw, impl](grpc::Status st) {
    if (!st.ok()) {
      if (const std::optional<std::chrono::nanoseconds> delay =
              impl->retry_delay(st.error_code(), static_cast<int>(raw->attempts), raw->deadline)) {
        raw->ctx.reset();
        grpc::Alarm& alarm = *raw->alarms.emplace_back(std::make_unique<grpc::Alarm>());
        // (a cancelled alarm, at gRPC's shutdown, still sends: that attempt then fails and ends the call)
        alarm.Set(std::chrono::system_clock::now() + *delay, [raw, impl](bool) { start_attempt(impl, raw); });
        return;
      }
    }
    finish_async(impl, raw, st);
  });
}

}  // namespace

namespace detail {

std::chrono::system_clock::time_point deadline_after(std::chrono::nanoseconds timeout) {
  constexpr std::chrono::nanoseconds kLongest = std::chrono::hours(24 * 365);
  return std::chrono::system_clock::now() +
         std::chrono::duration_cast<std::chrono::system_clock::duration>(std::clamp(timeout, std::chrono::nanoseconds(0), kLongest));
}

std::string target_of(const std::vector<std::string>& addresses) {
  if (addresses.empty()) throw ClientError({RpcCode::kInvalidArgument, "client: no server address"});
  if (addresses.size() == 1) return addresses.front();
  std::string family, target;
  for (const std::string& a : addresses) {
    std::string f;
    const std::size_t colon = a.rfind(':');
    if (colon != std::string::npos && colon > 0 && colon + 1 < a.size() && colon + 6 >= a.size() &&
        std::all_of(a.begin() + static_cast<std::ptrdiff_t>(colon) + 1, a.end(), [](char c) { return c >= '0' && c <= '9'; })) {
      const std::string host = a.substr(0, colon);
      in_addr v4{};
      in6_addr v6{};
      if (host.size() > 2 && host.front() == '[' && host.back() == ']' &&
          inet_pton(AF_INET6, host.substr(1, host.size() - 2).c_str(), &v6) == 1)
        f = "ipv6";
      else if (inet_pton(AF_INET, host.c_str(), &v4) == 1)
        f = "ipv4";
    }
    if (f.empty())
      throw ClientError({RpcCode::kInvalidArgument, "client: server address '" + a +
                                                        "' of a list is not IPV4:PORT or [IPV6]:PORT (for a host "
                                                        "name, give one target \"dns:///NAME:PORT\")"});
    if (family.empty()) family = f;
    if (f != family)
      throw ClientError({RpcCode::kInvalidArgument, "client: the server addresses mix IPv4 and IPv6 ('" + a + "')"});
    target += (target.empty() ? "" : ",") + a;
  }
  return family + ":" + target;
}

}  // namespace detail

std::chrono::nanoseconds retry_backoff(const RetryPolicy& policy, int retry, double u) noexcept {
  const double cap = std::max(0.0, static_cast<double>(policy.max_backoff.count()));
  double b = std::max(0.0, static_cast<double>(policy.initial_backoff.count())) *
             std::pow(std::max(1.0, policy.multiplier), std::max(0, retry - 1));
  if (!(b <= cap)) b = cap;  // beyond the cap, or overflowed to infinity
  const double jitter = std::clamp(policy.jitter, 0.0, 1.0);
  return std::chrono::nanoseconds(static_cast<std::int64_t>(b * (1.0 - jitter * std::clamp(u, 0.0, 1.0))));
}

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

void Client::Impl::prepare_until(grpc::ClientContext& ctx, std::chrono::system_clock::time_point deadline) const {
  ctx.set_deadline(deadline);
  ctx.set_wait_for_ready(options.wait_for_ready);
  add_token(ctx);
}

std::optional<std::chrono::nanoseconds> Client::Impl::retry_delay(int code, int attempts_made,
                                                                  std::chrono::system_clock::time_point deadline) const {
  if (code != static_cast<int>(grpc::StatusCode::UNAVAILABLE)) return std::nullopt;
  const RetryPolicy& policy = options.retry;
  if (attempts_made < policy.max_attempts) {
    thread_local std::mt19937_64 rng{std::random_device{}()};
    const std::chrono::nanoseconds delay = retry_backoff(policy, attempts_made, std::uniform_real_distribution<double>(0, 1)(rng));
    if (std::chrono::system_clock::now() + delay < deadline) {
      retries.fetch_add(1, std::memory_order_relaxed);
      return delay;
    }
  }
  gave_up.fetch_add(1, std::memory_order_relaxed);
  return std::nullopt;
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
  const RetryPolicy& retry = options.retry;
  if (retry.max_attempts < 1 || retry.initial_backoff.count() < 0 || retry.max_backoff.count() < 0 ||
      !(retry.multiplier >= 1.0) || !(retry.jitter >= 0.0 && retry.jitter <= 1.0))
    throw ClientError({RpcCode::kInvalidArgument,
                       "client: retry: max_attempts >= 1, backoffs >= 0, multiplier >= 1, jitter in [0, 1]"});
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
  // The load-balancing policy, as the channel's service config (one a DNS TXT record might give is
  // ignored): round_robin spreads calls over every address the target resolves to.
  const std::string& target = impl_->address;
  const auto scheme = [&target](const char* s) { return target.rfind(s, 0) == 0; };
  const bool round_robin =
      options.load_balancing == LoadBalancing::kRoundRobin ||
      (options.load_balancing == LoadBalancing::kAuto && (scheme("ipv4:") || scheme("ipv6:") || scheme("dns:")));
  if (round_robin || options.load_balancing == LoadBalancing::kPickFirst) {
    args.SetServiceConfigJSON(round_robin ? R"({"loadBalancingConfig": [{"round_robin": {}}]})"
                                          : R"({"loadBalancingConfig": [{"pick_first": {}}]})");
    args.SetInt(GRPC_ARG_SERVICE_CONFIG_DISABLE_RESOLUTION, 1);
  }
  impl_->channel = grpc::CreateCustomChannel(impl_->address, credentials, args);
  impl_->stub = v1::Dynamics::NewStub(impl_->channel);
}

Client::Client(const std::vector<std::string>& addresses, ClientOptions options)
    : Client(detail::target_of(addresses), std::move(options)) {}

Client::Client(std::initializer_list<std::string> addresses, ClientOptions options)
    : Client(std::vector<std::string>(addresses), std::move(options)) {}

Client::~Client() = default;
Client::Client(Client&&) noexcept = default;
Client& Client::operator=(Client&&) noexcept = default;

const std::string& Client::address() const noexcept { return impl_->address; }
const ClientOptions& Client::options() const noexcept { return impl_->options; }

RetryStats Client::retry_stats() const noexcept {
  return {impl_->retries.load(std::memory_order_relaxed), impl_->gave_up.load(std::memory_order_relaxed)};
}

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
  std::uint32_t attempts = 1;
  const grpc::Status grpc_status = with_retries(
      *impl_, req.timeout, [&](grpc::ClientContext& ctx) { return impl_->stub->Compute(&ctx, msg, &result.response); },
      &attempts);
  if (!grpc_status.ok()) return detail::from_grpc(grpc_status);
  RpcStatus st = detail::adopt_response(detail::expected_result(req), result, microseconds_since(start));
  result.timings.attempts = attempts;
  return st;
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
  call->deadline = detail::deadline_after(impl_->timeout_or_default(req.timeout));
  AsyncCall* raw = call.release();  // owned by the attempts' callbacks from here
  impl_->async_started();
  start_attempt(impl_.get(), raw);
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

RpcStatus Client::register_scene(const SceneDefinition& scene, SceneDescription& out,
                                 std::optional<std::chrono::nanoseconds> timeout) const {
  // retried like the others: registering the same definition again is answered OK
  v1::RegisterSceneRequest request;
  if (RpcStatus st = detail::encode_scene_definition(scene, request); !st) return st;
  v1::Scene response;
  RpcStatus st = unary(*impl_, &v1::Dynamics::Stub::RegisterScene, request, response, timeout);
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
  grpc::GenericStub stub(impl_->channel);
  const grpc::Status st = with_retries(*impl_, timeout, [&](grpc::ClientContext& ctx) {
    std::promise<grpc::Status> done;
    stub.UnaryCall(&ctx, "/grpc.health.v1.Health/Check", grpc::StubOptions(), &request_bytes, &response_bytes,
                   [&done](grpc::Status s) { done.set_value(std::move(s)); });
    return done.get_future().get();
  });
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
  // not retried: calibrating is no pure function, and its UNAVAILABLE means another calibration runs
  v1::CalibrateResponse response;
  grpc::ClientContext ctx;
  impl_->prepare(ctx, timeout);
  RpcStatus st = detail::from_grpc(impl_->stub->Calibrate(&ctx, v1::CalibrateRequest(), &response));
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

SceneDescription Client::register_scene(const SceneDefinition& scene,
                                        std::optional<std::chrono::nanoseconds> timeout) const {
  SceneDescription out;
  if (RpcStatus st = register_scene(scene, out, timeout); !st) throw ClientError(std::move(st));
  return out;
}

ServerInfo Client::server_info(std::optional<std::chrono::nanoseconds> timeout) const {
  ServerInfo out;
  if (RpcStatus st = server_info(out, timeout); !st) throw ClientError(std::move(st));
  return out;
}

}  // namespace rbdgrad
