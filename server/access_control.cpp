// Token authentication, per-client token buckets and concurrency, and the interceptor that guards
// the services without handlers of ours.
#include "access_control.hpp"

#include <grpc/grpc.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <fstream>
#include <set>
#include <sstream>
#include <utility>

#include <spdlog/spdlog.h>

namespace rbdgrad::server {
namespace {

using Clock = std::chrono::steady_clock;

// beyond this many peers (no authentication), the idle ones with a full bucket are forgotten
constexpr std::size_t kMaxRememberedPeers = 4096;

constexpr std::string_view kMissingToken =
    "missing bearer token: this server needs the call metadata 'authorization: Bearer TOKEN'";
constexpr std::string_view kInvalidToken = "invalid bearer token";

bool starts_with_ci(std::string_view text, std::string_view prefix) {
  if (text.size() < prefix.size()) return false;
  for (std::size_t i = 0; i < prefix.size(); ++i)
    if (std::tolower(static_cast<unsigned char>(text[i])) != std::tolower(static_cast<unsigned char>(prefix[i])))
      return false;
  return true;
}

std::string number_text(double v) {
  std::ostringstream os;
  os << v;
  return os.str();
}

}  // namespace

Status load_tokens_file(const std::string& path, std::vector<ClientToken>& out) {
  std::ifstream in(path);
  if (!in) return not_found("auth.tokens_file: cannot read '" + path + "'");
  std::vector<ClientToken> tokens;
  std::set<std::string> names, values;
  std::string line;
  for (int number = 1; std::getline(in, line); ++number) {
    const std::string where = "auth.tokens_file '" + path + "' line " + std::to_string(number) + ": ";
    std::istringstream fields(line);
    std::string name, token, extra;
    if (!(fields >> name)) continue;  // blank
    if (name[0] == '#') continue;
    if (!(fields >> token) || (fields >> extra)) return invalid_argument(where + "expected 'NAME TOKEN'");
    for (char c : token) {
      // it travels in an HTTP/2 header
      if (c < 0x21 || c > 0x7e) return invalid_argument(where + "the token has a character that is not printable ASCII");
    }
    if (!names.insert(name).second) return invalid_argument(where + "duplicate name '" + name + "'");
    // two names for one token: which client called would be a guess
    if (!values.insert(token).second) return invalid_argument(where + "the token of '" + name + "' is another name's too");
    tokens.push_back({std::move(name), std::move(token)});
  }
  if (in.bad()) return not_found("auth.tokens_file: cannot read '" + path + "'");
  if (tokens.empty()) return invalid_argument("auth.tokens_file '" + path + "': no 'NAME TOKEN' line: nobody could call");
  out = std::move(tokens);
  return Status::ok();
}

std::string peer_without_port(const std::string& peer) {
  if (peer.rfind("unix:", 0) == 0) return peer;
  const auto colon = peer.rfind(':');
  if (colon == std::string::npos || colon + 1 == peer.size()) return peer;
  const bool numeric = std::all_of(peer.begin() + static_cast<std::ptrdiff_t>(colon) + 1, peer.end(),
                                   [](char c) { return c >= '0' && c <= '9'; });
  // "ipv4:10.0.0.7:51234", "ipv6:[::1]:51234": the port follows the last colon (after ']' for v6)
  if (!numeric || (peer.find('[') != std::string::npos && peer[colon - 1] != ']')) return peer;
  return peer.substr(0, colon);
}

bool constant_time_equal(std::string_view a, std::string_view b) noexcept {
  const std::size_t n = std::max(a.size(), b.size());
  unsigned char diff = a.size() == b.size() ? 0 : 1;
  for (std::size_t i = 0; i < n; ++i) {
    const unsigned char x = i < a.size() ? static_cast<unsigned char>(a[i]) : 0;
    const unsigned char y = i < b.size() ? static_cast<unsigned char>(b[i]) : 0;
    diff |= static_cast<unsigned char>(x ^ y);
  }
  return diff == 0;
}

AccessControl::Ticket& AccessControl::Ticket::operator=(Ticket&& other) noexcept {
  if (this != &other) {
    release();
    client_ = std::move(other.client_);
  }
  return *this;
}

void AccessControl::Ticket::release() noexcept {
  if (!client_) return;
  {
    std::lock_guard lock(client_->mutex);
    --client_->in_flight;
  }
  client_.reset();
}

AccessControl::AccessControl(std::vector<ClientToken> tokens, const LimitsConfig& limits, Metrics* metrics)
    : tokens_(std::move(tokens)),
      rate_(limits.client_requests_per_second),
      burst_(limits.client_burst > 0 ? static_cast<double>(limits.client_burst)
                                     : std::max(1.0, limits.client_requests_per_second)),
      max_concurrent_(limits.client_max_concurrent),
      metrics_(metrics) {
  // the token names are the only clients there can be: made once, never forgotten
  for (const ClientToken& t : tokens_) clients_.emplace(t.name, std::make_shared<Client>(t.name));
}

grpc::Status AccessControl::authenticate(const std::multimap<grpc::string_ref, grpc::string_ref>& metadata,
                                         std::string& client_name) {
  std::string_view presented;
  bool found = false;
  const auto it = metadata.find("authorization");
  if (it != metadata.end()) {
    const std::string_view value(it->second.data(), it->second.size());
    if (starts_with_ci(value, "bearer ")) {
      presented = value.substr(7);
      while (!presented.empty() && presented.front() == ' ') presented.remove_prefix(1);
      found = !presented.empty();
    }
  }
  if (found) {
    // every token is compared, in constant time each: the time says nothing of which one matched
    std::size_t match = tokens_.size();
    for (std::size_t i = 0; i < tokens_.size(); ++i) {
      const bool equal = constant_time_equal(presented, tokens_[i].token);
      match = equal ? i : match;
    }
    if (match < tokens_.size()) {
      client_name = tokens_[match].name;
      return grpc::Status::OK;
    }
  }
  const std::string_view why = found ? kInvalidToken : kMissingToken;
  if (metrics_ != nullptr) metrics_->record_rejection("unauthenticated");
  return {grpc::StatusCode::UNAUTHENTICATED, std::string(why)};
}

grpc::Status AccessControl::identify(const grpc::ServerContextBase& ctx, std::shared_ptr<Client>& client) {
  client.reset();
  if (auth_enabled()) {
    std::string name;
    if (grpc::Status st = authenticate(ctx.client_metadata(), name); !st.ok()) {
      spdlog::debug("call from {} refused: {}", ctx.peer(), st.error_message());
      return st;
    }
    client = clients_.at(name);  // made in the constructor, never changed: no lock needed
    return grpc::Status::OK;
  }
  if (limits_enabled()) client = find_or_add(peer_without_port(ctx.peer()));
  return grpc::Status::OK;
}

std::shared_ptr<AccessControl::Client> AccessControl::find_or_add(const std::string& name) {
  std::lock_guard lock(clients_mutex_);
  auto it = clients_.find(name);
  if (it != clients_.end()) return it->second;
  if (clients_.size() >= kMaxRememberedPeers) {
    // a peer nobody holds (no call under way) whose bucket has refilled is as good as new
    const auto now = Clock::now();
    for (auto i = clients_.begin(); i != clients_.end();) {
      bool idle = i->second.use_count() == 1;
      if (idle && rate_ > 0) {
        std::lock_guard client_lock(i->second->mutex);
        const double elapsed = std::chrono::duration<double>(now - i->second->refilled).count();
        idle = i->second->tokens < 0 || i->second->tokens + elapsed * rate_ >= burst_;
      }
      i = idle ? clients_.erase(i) : std::next(i);
    }
  }
  return clients_.emplace(name, std::make_shared<Client>(name)).first->second;
}

grpc::Status AccessControl::admit(const std::shared_ptr<Client>& client, Ticket* ticket, std::string_view what) {
  if (!client || !limits_enabled()) return grpc::Status::OK;
  const char* reason = nullptr;
  {
    std::lock_guard lock(client->mutex);
    const auto now = Clock::now();
    if (client->tokens < 0) {
      client->tokens = burst_;
      client->refilled = now;
    } else if (rate_ > 0) {
      const double elapsed = std::chrono::duration<double>(now - client->refilled).count();
      client->tokens = std::min(burst_, client->tokens + elapsed * rate_);
      client->refilled = now;
    }
    // the concurrency limit first: a request refused for it keeps its token
    if (ticket != nullptr && max_concurrent_ > 0 && client->in_flight >= max_concurrent_) {
      reason = "client_concurrency";
    } else if (rate_ > 0 && client->tokens < 1) {
      reason = "client_rate";
    } else {
      if (rate_ > 0) client->tokens -= 1;
      if (ticket != nullptr && max_concurrent_ > 0) {
        ++client->in_flight;
        *ticket = Ticket();
        ticket->client_ = client;
      }
      return grpc::Status::OK;
    }
  }
  if (metrics_ != nullptr) metrics_->record_rejection(reason);
  std::string message(what);
  if (std::string_view(reason) == "client_rate") {
    message += "client '" + client->name + "' is over its request rate (limits.client_requests_per_second = " +
               number_text(rate_) + ", limits.client_burst = " + number_text(burst_) + ")";
  } else {
    message += "client '" + client->name + "' has too many requests in flight (limits.client_max_concurrent = " +
               std::to_string(max_concurrent_) + ")";
  }
  spdlog::debug("request refused: {}", message);
  return {grpc::StatusCode::RESOURCE_EXHAUSTED, message};
}

void AccessControl::count_global_rejection() const {
  if (metrics_ != nullptr) metrics_->record_rejection("max_concurrent_requests");
}

namespace {

// Cancels the call with UNAUTHENTICATED once its metadata is in, when it carries no valid token.
class AuthInterceptor final : public grpc::experimental::Interceptor {
 public:
  AuthInterceptor(AccessControl& access, grpc::experimental::ServerRpcInfo* info) : access_(access), info_(info) {}

  void Intercept(grpc::experimental::InterceptorBatchMethods* methods) override {
    if (methods->QueryInterceptionHookPoint(grpc::experimental::InterceptionHookPoints::POST_RECV_INITIAL_METADATA)) {
      grpc::ServerContextBase* ctx = info_->server_context();
      std::string client;
      const grpc::Status st = access_.authenticate(*methods->GetRecvInitialMetadata(), client);
      if (!st.ok()) spdlog::debug("call {} from {} refused: {}", info_->method(), ctx->peer(), st.error_message());
      // The interceptor API has no way to fail a server call with a status of our choice; gRPC
      // core's cancel-with-status sends exactly that status and message to the client, and the
      // service's handler then sees a cancelled call (no message reaches it).
      if (!st.ok())
        grpc_call_cancel_with_status(ctx->c_call(), static_cast<grpc_status_code>(st.error_code()),
                                     st.error_message().c_str(), nullptr);
    }
    methods->Proceed();
  }

 private:
  AccessControl& access_;
  grpc::experimental::ServerRpcInfo* info_;
};

}  // namespace

grpc::experimental::Interceptor* AuthInterceptorFactory::CreateServerInterceptor(
    grpc::experimental::ServerRpcInfo* info) {
  const std::string_view method = info->method() == nullptr ? "" : info->method();
  // health is exempt (probes carry no token); the Dynamics handlers check for themselves
  if (method.rfind("/grpc.health.v1.Health/", 0) == 0 || method.rfind("/rbdgrad.v1.Dynamics/", 0) == 0) return nullptr;
  if (!access_.auth_enabled()) return nullptr;
  return new AuthInterceptor(access_, info);
}

}  // namespace rbdgrad::server
