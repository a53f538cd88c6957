// Tests for the daemon's security and per-client limits (server/access_control.cpp, daemon.cpp):
// TLS and mutual TLS with certificates made at test time, bearer tokens on every call but health,
// the request rate and concurrency of each client, the insecure-address rule and the derived
// message size limit. Each test has a daemon of its own.
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <grpcpp/security/credentials.h>

#include <chrono>
#include <future>
#include <thread>

#include "../support/test_certificates.hpp"
#include "daemon_test_support.hpp"
#include "message_size.hpp"

namespace rbdgrad::server {
namespace {

using namespace daemon_testing;  // the shared helpers of daemon_test_support.hpp
namespace v1 = rbdgrad::v1;
using ::testing::HasSubstr;
using ::testing::Not;
using rbdgrad::testing::TestCertificates;

// made once for the whole program (openssl takes a moment), removed at exit
const TestCertificates& certs() {
  static const TestCertificates made;
  return made;
}

std::shared_ptr<grpc::Channel> tls_channel(const std::string& target, const std::string& ca_file,
                                           const std::string& cert_file = "", const std::string& key_file = "") {
  grpc::SslCredentialsOptions ssl;
  ssl.pem_root_certs = certs().read(ca_file);
  if (!cert_file.empty()) {
    ssl.pem_cert_chain = certs().read(cert_file);
    ssl.pem_private_key = certs().read(key_file);
  }
  return grpc::CreateChannel(target, grpc::SslCredentials(ssl));
}

// One small Compute; `token` "" = no authorization metadata.
grpc::Status compute(const std::shared_ptr<grpc::Channel>& channel, const std::string& token = "",
                     const std::string& id = "r") {
  auto stub = v1::Dynamics::NewStub(channel);
  grpc::ClientContext ctx;
  ctx.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(10));
  if (!token.empty()) ctx.AddMetadata("authorization", "Bearer " + token);
  v1::ComputeResponse resp;
  return stub->Compute(&ctx, make_request("iiwa14", kIiwaNv, 2, 1, id), &resp);
}

grpc::Status list_models(const std::shared_ptr<grpc::Channel>& channel, const std::string& token = "") {
  auto stub = v1::Dynamics::NewStub(channel);
  grpc::ClientContext ctx;
  if (!token.empty()) ctx.AddMetadata("authorization", "Bearer " + token);
  v1::ListModelsResponse resp;
  return stub->ListModels(&ctx, v1::ListModelsRequest(), &resp);
}

// One request on a ComputeStream: the stream's final status (OK after its response).
grpc::Status stream_one(const std::shared_ptr<grpc::Channel>& channel, const std::string& token = "") {
  auto stub = v1::Dynamics::NewStub(channel);
  grpc::ClientContext ctx;
  ctx.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(10));
  if (!token.empty()) ctx.AddMetadata("authorization", "Bearer " + token);
  auto stream = stub->ComputeStream(&ctx);
  stream->Write(make_request("iiwa14", kIiwaNv, 1, 1, "s"));
  stream->WritesDone();
  v1::ComputeResponse resp;
  while (stream->Read(&resp)) {
  }
  return stream->Finish();
}

// ServerReflectionInfo with one list_services request, on the generic stub; the final status
grpc::Status reflection_call(const std::shared_ptr<grpc::Channel>& channel, const std::string& token,
                             std::string& response_text) {
  grpc::GenericStub stub(channel);
  grpc::CompletionQueue cq;
  grpc::ClientContext ctx;
  ctx.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(10));
  if (!token.empty()) ctx.AddMetadata("authorization", "Bearer " + token);
  auto call = stub.PrepareCall(&ctx, "/grpc.reflection.v1alpha.ServerReflection/ServerReflectionInfo", &cq);
  void* tag = nullptr;
  bool ok = false;
  // each step may fail once the server has refused the call: the status says why
  call->StartCall(reinterpret_cast<void*>(1));
  cq.Next(&tag, &ok);
  call->Write(buffer_of(std::string("\x3a\x00", 2)), reinterpret_cast<void*>(2));
  cq.Next(&tag, &ok);
  call->WritesDone(reinterpret_cast<void*>(3));
  cq.Next(&tag, &ok);
  grpc::ByteBuffer response;
  call->Read(&response, reinterpret_cast<void*>(4));
  cq.Next(&tag, &ok);
  response_text = ok ? string_of(response) : "";
  grpc::Status status;
  call->Finish(&status, reinterpret_cast<void*>(5));
  cq.Next(&tag, &ok);
  return status;
}

DaemonOptions tls_options(bool mutual) {
  DaemonOptions options = test_options("");
  options.config.tls.cert_file = certs().path("server.pem");
  options.config.tls.key_file = certs().path("server.key");
  if (mutual) options.config.tls.client_ca_file = certs().path("ca.pem");
  return options;
}

Status create_only(DaemonOptions options) {
  std::unique_ptr<Daemon> daemon;
  return Daemon::create(std::move(options), daemon);
}

// --- TLS ---

TEST(DaemonTls, ServesTlsToClientsThatTrustItsCa) {
  DaemonOptions options = tls_options(false);
  options.config.listen.unix_socket = "/tmp/rbdgrad_dt_" + std::to_string(getpid()) + "_tls.sock";
  std::unique_ptr<Daemon> daemon = start_daemon(std::move(options));
  ASSERT_NE(daemon, nullptr);
  const std::string target = daemon->addresses()[0].target();

  const grpc::Status trusted = compute(tls_channel(target, "ca.pem"));
  EXPECT_TRUE(trusted.ok()) << trusted.error_message();
  // the certificate is for localhost too
  const grpc::Status by_name =
      compute(tls_channel("localhost:" + std::to_string(daemon->tcp_port()), "ca.pem"));
  EXPECT_TRUE(by_name.ok()) << by_name.error_message();

  const grpc::Status plaintext = compute(channel_to(daemon->addresses()[0]));
  EXPECT_EQ(plaintext.error_code(), grpc::StatusCode::UNAVAILABLE) << plaintext.error_message();
  const grpc::Status other_ca = compute(tls_channel(target, "other_ca.pem"));
  EXPECT_EQ(other_ca.error_code(), grpc::StatusCode::UNAVAILABLE) << other_ca.error_message();

  // the Unix socket stays plaintext: its file's permissions guard it
  const grpc::Status unix_socket = compute(channel_to(daemon->addresses()[1]));
  EXPECT_TRUE(unix_socket.ok()) << unix_socket.error_message();
}

TEST(DaemonTls, MutualTlsNeedsAClientCertificateFromItsCa) {
  std::unique_ptr<Daemon> daemon = start_daemon(tls_options(true));
  ASSERT_NE(daemon, nullptr);
  const std::string target = daemon->addresses()[0].target();

  const grpc::Status with_cert = compute(tls_channel(target, "ca.pem", "client.pem", "client.key"));
  EXPECT_TRUE(with_cert.ok()) << with_cert.error_message();

  const grpc::Status without_cert = compute(tls_channel(target, "ca.pem"));
  EXPECT_EQ(without_cert.error_code(), grpc::StatusCode::UNAVAILABLE) << without_cert.error_message();
  const grpc::Status other_cert = compute(tls_channel(target, "ca.pem", "other_client.pem", "other_client.key"));
  EXPECT_EQ(other_cert.error_code(), grpc::StatusCode::UNAVAILABLE) << other_cert.error_message();
}

TEST(DaemonTls, UnreadableOrWrongFilesAreNamedAtStart) {
  DaemonOptions missing = tls_options(false);
  missing.config.tls.cert_file = certs().dir() + "/nonexistent.pem";
  const Status s = create_only(std::move(missing));
  EXPECT_EQ(s.code(), StatusCode::kNotFound);
  EXPECT_THAT(s.message(), HasSubstr("tls.cert_file: cannot read '" + certs().dir() + "/nonexistent.pem'"));

  DaemonOptions not_pem = tls_options(false);
  not_pem.config.tls.key_file = certs().write("not_a_key.txt", "hello\n");
  EXPECT_THAT(create_only(std::move(not_pem)).message(),
              HasSubstr("tls.key_file: '" + certs().path("not_a_key.txt") + "' holds no PEM block"));

  DaemonOptions no_ca = tls_options(true);
  no_ca.config.tls.client_ca_file = "/nonexistent/ca.pem";
  EXPECT_THAT(create_only(std::move(no_ca)).message(), HasSubstr("tls.client_ca_file: cannot read '/nonexistent/ca.pem'"));

  DaemonOptions half = test_options("");
  half.config.tls.cert_file = certs().path("server.pem");
  EXPECT_THAT(create_only(std::move(half)).message(), HasSubstr("tls.cert_file and tls.key_file go together"));
}

// --- the address rule ---

TEST(DaemonSecurity, ANonLoopbackAddressNeedsTlsOrInsecure) {
  DaemonOptions any = test_options("");
  any.config.listen.tcp = "0.0.0.0:0";
  const Status refused = create_only(any);
  EXPECT_EQ(refused.code(), StatusCode::kInvalidArgument);
  EXPECT_THAT(refused.message(), HasSubstr("listen.tcp '0.0.0.0:0' is not a loopback address and TLS is off"));
  EXPECT_THAT(refused.message(), HasSubstr("listen.insecure: true"));

  DaemonOptions insecure = any;
  insecure.config.listen.insecure = true;
  std::unique_ptr<Daemon> plain = start_daemon(std::move(insecure));
  ASSERT_NE(plain, nullptr);
  const grpc::Status st = compute(grpc::CreateChannel("127.0.0.1:" + std::to_string(plain->tcp_port()),
                                                      grpc::InsecureChannelCredentials()));
  EXPECT_TRUE(st.ok()) << st.error_message();
  plain.reset();

  DaemonOptions tls = tls_options(false);
  tls.config.listen.tcp = "0.0.0.0:0";
  std::unique_ptr<Daemon> secure = start_daemon(std::move(tls));
  ASSERT_NE(secure, nullptr);
  const grpc::Status over_tls = compute(tls_channel("127.0.0.1:" + std::to_string(secure->tcp_port()), "ca.pem"));
  EXPECT_TRUE(over_tls.ok()) << over_tls.error_message();
}

// --- tokens ---

DaemonOptions auth_options() {
  DaemonOptions options = test_options("");
  options.config.auth.tokens_file = certs().write("tokens", "# test clients\nleft tok-left-0123456789\nright tok-right-0123456789\n");
  return options;
}

TEST(DaemonAuth, EveryCallButHealthNeedsAValidToken) {
  std::unique_ptr<Daemon> daemon = start_daemon(auth_options());
  ASSERT_NE(daemon, nullptr);
  const auto channel = channel_to(daemon->addresses()[0]);

  const grpc::Status missing = compute(channel);
  EXPECT_EQ(missing.error_code(), grpc::StatusCode::UNAUTHENTICATED);
  EXPECT_EQ(missing.error_message(),
            "missing bearer token: this server needs the call metadata 'authorization: Bearer TOKEN'");
  const grpc::Status wrong = compute(channel, "tok-left-012345678");
  EXPECT_EQ(wrong.error_code(), grpc::StatusCode::UNAUTHENTICATED);
  EXPECT_EQ(wrong.error_message(), "invalid bearer token");
  EXPECT_TRUE(compute(channel, "tok-left-0123456789").ok());
  EXPECT_TRUE(compute(channel, "tok-right-0123456789").ok());

  EXPECT_EQ(list_models(channel).error_code(), grpc::StatusCode::UNAUTHENTICATED);
  EXPECT_TRUE(list_models(channel, "tok-right-0123456789").ok());
  const grpc::Status stream_refused = stream_one(channel);
  EXPECT_EQ(stream_refused.error_code(), grpc::StatusCode::UNAUTHENTICATED) << stream_refused.error_message();
  const grpc::Status stream_ok = stream_one(channel, "tok-left-0123456789");
  EXPECT_TRUE(stream_ok.ok()) << stream_ok.error_message();

  // the health service answers without a token (Kubernetes probes carry none)
  std::string health;
  const grpc::Status h = generic_unary(channel, "/grpc.health.v1.Health/Check", "", &health);
  ASSERT_TRUE(h.ok()) << h.error_message();
  EXPECT_EQ(health, std::string("\x08\x01", 2));

  // reflection is guarded as well (by the interceptor: it is not our service)
  std::string listed;
  const grpc::Status refl_refused = reflection_call(channel, "", listed);
  EXPECT_EQ(refl_refused.error_code(), grpc::StatusCode::UNAUTHENTICATED) << refl_refused.error_message();
  EXPECT_THAT(refl_refused.error_message(), HasSubstr("missing bearer token"));
  EXPECT_THAT(listed, Not(HasSubstr("rbdgrad.v1.Dynamics")));
  const grpc::Status refl_ok = reflection_call(channel, "tok-left-0123456789", listed);
  EXPECT_TRUE(refl_ok.ok()) << refl_ok.error_message();
  EXPECT_THAT(listed, HasSubstr("rbdgrad.v1.Dynamics"));

  // 2 Compute, 1 ListModels, 1 stream, 1 reflection refused
  EXPECT_THAT(daemon->metrics().text(), HasSubstr("rbdgrad_rejected_requests_total{reason=\"unauthenticated\"} 5"));
}

TEST(DaemonAuth, TokensFileProblemsStopTheStartNamingTheFile) {
  DaemonOptions missing = test_options("");
  missing.config.auth.tokens_file = "/nonexistent/tokens";
  EXPECT_THAT(create_only(std::move(missing)).message(), HasSubstr("auth.tokens_file: cannot read '/nonexistent/tokens'"));
  DaemonOptions bad = test_options("");
  bad.config.auth.tokens_file = certs().write("bad_tokens", "left tok-a\nright\n");
  EXPECT_THAT(create_only(std::move(bad)).message(),
              HasSubstr("auth.tokens_file '" + certs().path("bad_tokens") + "' line 2: expected 'NAME TOKEN'"));
}

// --- per-client limits ---

TEST(DaemonClientLimits, TheThirdQuickRequestOverTheRateIsRefused) {
  DaemonOptions options = test_options("");
  options.config.limits.client_requests_per_second = 0.01;  // no token comes back during the test
  options.config.limits.client_burst = 2;
  std::unique_ptr<Daemon> daemon = start_daemon(std::move(options));
  ASSERT_NE(daemon, nullptr);
  const auto channel = channel_to(daemon->addresses()[0]);
  EXPECT_TRUE(compute(channel).ok());
  EXPECT_TRUE(list_models(channel).ok());
  const grpc::Status third = compute(channel);
  EXPECT_EQ(third.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED);
  // without tokens the client is the peer's address
  EXPECT_EQ(third.error_message(),
            "client 'ipv4:127.0.0.1' is over its request rate (limits.client_requests_per_second = 0.01, "
            "limits.client_burst = 2)");
  EXPECT_THAT(daemon->metrics().text(), HasSubstr("rbdgrad_rejected_requests_total{reason=\"client_rate\"} 1"));
  // the health service is not counted
  EXPECT_TRUE(generic_unary(channel, "/grpc.health.v1.Health/Check", "", nullptr).ok());
}

TEST(DaemonClientLimits, EachTokenNameHasItsOwnBucket) {
  DaemonOptions options = auth_options();
  options.config.limits.client_requests_per_second = 0.01;
  options.config.limits.client_burst = 2;
  std::unique_ptr<Daemon> daemon = start_daemon(std::move(options));
  ASSERT_NE(daemon, nullptr);
  const auto channel = channel_to(daemon->addresses()[0]);
  EXPECT_TRUE(compute(channel, "tok-left-0123456789").ok());
  EXPECT_TRUE(compute(channel, "tok-left-0123456789").ok());
  const grpc::Status left = compute(channel, "tok-left-0123456789");
  EXPECT_EQ(left.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED);
  EXPECT_THAT(left.error_message(), HasSubstr("client 'left' is over its request rate"));
  // same connection, another token: another client
  EXPECT_TRUE(compute(channel, "tok-right-0123456789").ok());
  EXPECT_TRUE(stream_one(channel, "tok-right-0123456789").ok());
  const grpc::Status right = stream_one(channel, "tok-right-0123456789");
  EXPECT_EQ(right.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED);
  EXPECT_EQ(right.error_message(),
            "stream message 0: client 'right' is over its request rate (limits.client_requests_per_second = 0.01, "
            "limits.client_burst = 2)");
}

TEST(DaemonClientLimits, ConcurrentRequestsBeyondTheClientsLimitAreRefused) {
  DaemonOptions options = auth_options();
  options.config.limits.client_max_concurrent = 1;
  std::unique_ptr<Daemon> daemon = start_daemon(std::move(options));
  ASSERT_NE(daemon, nullptr);
  const auto channel = channel_to(daemon->addresses()[0]);
  auto stub = v1::Dynamics::NewStub(channel);

  grpc::ClientContext slow_ctx;
  slow_ctx.AddMetadata("authorization", "Bearer tok-left-0123456789");
  v1::ComputeResponse slow_resp;
  std::promise<grpc::Status> slow_done;
  const v1::ComputeRequest slow = slow_request("slow");  // the fake cuda holds it 300 ms
  stub->async()->Compute(&slow_ctx, &slow, &slow_resp, [&](grpc::Status s) { slow_done.set_value(std::move(s)); });
  ASSERT_TRUE(wait_for_in_flight(*daemon, 1));

  const grpc::Status second = compute(channel, "tok-left-0123456789");
  EXPECT_EQ(second.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED);
  EXPECT_EQ(second.error_message(), "client 'left' has too many requests in flight (limits.client_max_concurrent = 1)");
  const grpc::Status streamed = stream_one(channel, "tok-left-0123456789");
  EXPECT_EQ(streamed.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED);
  EXPECT_THAT(streamed.error_message(), HasSubstr("stream message 0: client 'left' has too many requests in flight"));
  // not a compute request: not counted against the limit
  EXPECT_TRUE(list_models(channel, "tok-left-0123456789").ok());
  // another client is not held up by this one
  EXPECT_TRUE(compute(channel, "tok-right-0123456789").ok());

  EXPECT_TRUE(slow_done.get_future().get().ok());
  ASSERT_TRUE(wait_for_in_flight(*daemon, 0));
  EXPECT_TRUE(compute(channel, "tok-left-0123456789").ok());
  EXPECT_THAT(daemon->metrics().text(), HasSubstr("rbdgrad_rejected_requests_total{reason=\"client_concurrency\"} 2"));
}

// --- the message size limit ---

TEST(DaemonLimits, MaxMessageBytesIsDerivedFromTheLargestModelUnlessSet) {
  std::unique_ptr<Daemon> daemon = start_daemon(test_options(""));
  ASSERT_NE(daemon, nullptr);
  // 1000 states of panda (nv 9), the larger of the two models
  const auto expected = static_cast<std::int64_t>(largest_compute_message_bytes(1000, kPandaNv));
  EXPECT_EQ(daemon->max_message_bytes(), expected);
  auto stub = v1::Dynamics::NewStub(channel_to(daemon->addresses()[0]));
  grpc::ClientContext ctx;
  v1::GetServerInfoResponse info;
  ASSERT_TRUE(stub->GetServerInfo(&ctx, v1::GetServerInfoRequest(), &info).ok());
  EXPECT_EQ(info.max_message_bytes(), static_cast<std::uint64_t>(expected));
  // the largest request allowed, every output asked for, goes through both ways
  grpc::ClientContext big_ctx;
  v1::ComputeResponse big;
  const grpc::Status st = stub->Compute(&big_ctx, make_request("panda", kPandaNv, 1000, 3, "big"), &big);
  EXPECT_TRUE(st.ok()) << st.error_message();

  DaemonOptions configured = test_options("");
  configured.config.limits.max_message_bytes = 123456;
  std::unique_ptr<Daemon> fixed = start_daemon(std::move(configured));
  ASSERT_NE(fixed, nullptr);
  EXPECT_EQ(fixed->max_message_bytes(), 123456);
}

}  // namespace
}  // namespace rbdgrad::server
