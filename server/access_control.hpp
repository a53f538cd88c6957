// Who may call the daemon and how much: bearer-token authentication (auth.tokens_file) and the
// per-client limits (limits.client_*). The Dynamics handlers call identify() and admit() first
// thing; the other services but health (i.e. reflection) are guarded by AuthInterceptorFactory.
// A client is its token's NAME when authentication is on, else the peer's address without port.
#pragma once

#include <chrono>
#include <cstdint>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <string_view>
#include <unordered_map>
#include <vector>

#include <grpcpp/server_context.h>
#include <grpcpp/support/server_interceptor.h>
#include <grpcpp/support/status.h>
#include <grpcpp/support/string_ref.h>

#include "config.hpp"
#include "metrics.hpp"
#include "rbdgrad/status.hpp"

namespace rbdgrad::server {

struct ClientToken {
  std::string name;
  std::string token;
};

/// Reads a tokens file: each non-empty line not starting with '#' is "NAME TOKEN" (whitespace
/// between them and around). Errors (invalid_argument, not_found for an unreadable file) name the
/// file and the line, never a token: a line without exactly two fields, a token with a character
/// that is not printable ASCII, a duplicate name or token, a file without any token.
Status load_tokens_file(const std::string& path, std::vector<ClientToken>& out);

/// "ipv4:10.0.0.7:51234" -> "ipv4:10.0.0.7", "ipv6:[::1]:5" -> "ipv6:[::1]"; a Unix socket's peer
/// ("unix:...") and anything without a numeric port stay as they are.
std::string peer_without_port(const std::string& peer);

/// a == b, in a time that depends on the lengths only (not on where they differ).
bool constant_time_equal(std::string_view a, std::string_view b) noexcept;

class AccessControl {
 public:
  // One client's share of the limits.
  struct Client {
    explicit Client(std::string name_in) : name(std::move(name_in)) {}
    const std::string name;
    std::mutex mutex;
    double tokens = -1;  // the bucket; < 0 until first used (then full)
    std::chrono::steady_clock::time_point refilled{};
    std::int64_t in_flight = 0;  // compute requests admitted and not yet released
  };

  // A compute request's place within its client's concurrency limit, given back when destroyed
  // (with the request). Empty = nothing to give back.
  class Ticket {
   public:
    Ticket() = default;
    Ticket(Ticket&& other) noexcept : client_(std::move(other.client_)) {}
    Ticket& operator=(Ticket&& other) noexcept;
    Ticket(const Ticket&) = delete;
    Ticket& operator=(const Ticket&) = delete;
    ~Ticket() { release(); }
    void release() noexcept;

   private:
    friend class AccessControl;
    std::shared_ptr<Client> client_;
  };

  /// `tokens` empty = no authentication. `metrics` (may be null) counts the rejections.
  AccessControl(std::vector<ClientToken> tokens, const LimitsConfig& limits, Metrics* metrics);

  bool auth_enabled() const noexcept { return !tokens_.empty(); }
  bool limits_enabled() const noexcept { return rate_ > 0 || max_concurrent_ > 0; }

  /// The caller of `ctx`: with authentication, the client whose token the metadata
  /// "authorization: Bearer TOKEN" carries, else UNAUTHENTICATED (counted and logged, naming no
  /// token); without, the peer's address. `client` stays null when neither authentication nor
  /// per-client limits are on (nothing to check then).
  grpc::Status identify(const grpc::ServerContextBase& ctx, std::shared_ptr<Client>& client);
  /// The token check alone, on a call's metadata (the interceptor's view): sets `client_name`, or
  /// counts the rejection and returns UNAUTHENTICATED. Authentication must be on.
  grpc::Status authenticate(const std::multimap<grpc::string_ref, grpc::string_ref>& metadata,
                            std::string& client_name);

  /// One request of `client` (identify's; null = always admitted): takes a token from its bucket
  /// and, for a compute request (`ticket` not null), a place among its client_max_concurrent,
  /// held by *ticket. Over a limit: RESOURCE_EXHAUSTED naming the limit and the client (counted),
  /// `what` prefixing the message ("stream message 3: ").
  grpc::Status admit(const std::shared_ptr<Client>& client, Ticket* ticket, std::string_view what = {});

  /// Counts (and logs at debug) a call refused by max_concurrent_requests, with the others.
  void count_global_rejection() const;

 private:
  std::shared_ptr<Client> find_or_add(const std::string& name);

  std::vector<ClientToken> tokens_;
  const double rate_;
  const double burst_;
  const std::int64_t max_concurrent_;
  Metrics* const metrics_;
  std::mutex clients_mutex_;  // guards clients_ (the peers come and go; the token names are fixed)
  std::unordered_map<std::string, std::shared_ptr<Client>> clients_;
};

/// With authentication on, guards every service but the Dynamics one (whose handlers check for
/// themselves) and the gRPC health service (exempt, for probes): a call without a valid token is
/// cancelled with UNAUTHENTICATED as soon as its metadata arrives. In practice: server reflection.
class AuthInterceptorFactory final : public grpc::experimental::ServerInterceptorFactoryInterface {
 public:
  explicit AuthInterceptorFactory(AccessControl& access) : access_(access) {}
  grpc::experimental::Interceptor* CreateServerInterceptor(grpc::experimental::ServerRpcInfo* info) override;

 private:
  AccessControl& access_;
};

}  // namespace rbdgrad::server
