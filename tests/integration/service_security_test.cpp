// The real daemon with TLS, mutual TLS and bearer tokens, through the client library's
// ClientOptions::tls and bearer_token (certificates made at test time by
// tests/support/make_test_certs.sh).
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <memory>
#include <string>

#include "../support/test_certificates.hpp"
#include "integration_support.hpp"

namespace rbdgrad::testing {
namespace {

using ::testing::HasSubstr;

constexpr std::uint32_t kGradient = Output::kDqddDq | Output::kDqddDqd;
constexpr const char* kToken = "mpc-token-5f0c9a7e";

class ServiceSecurity : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    certs_ = new TestCertificates();
    const std::string tokens = certs_->write("tokens", std::string("mpc ") + kToken + "\nother other-token-1234\n");
    const std::string common = "models:\n  - name: iiwa14\n    embedded: iiwa14\nlog_level: warn\n"
                               "scheduler:\n  calibrate: off\n";
    tls_daemon_ = new DaemonProcess(RBDGRADD_PATH, common + "tls:\n  cert_file: " + certs_->path("server.pem") +
                                                       "\n  key_file: " + certs_->path("server.key") + "\n");
    mutual_daemon_ = new DaemonProcess(
        RBDGRADD_PATH, common + "tls:\n  cert_file: " + certs_->path("server.pem") + "\n  key_file: " +
                           certs_->path("server.key") + "\n  client_ca_file: " + certs_->path("ca.pem") +
                           "\nauth:\n  tokens_file: " + tokens + "\n");
  }
  static void TearDownTestSuite() {
    delete tls_daemon_;
    delete mutual_daemon_;
    delete certs_;
  }

  static ClientOptions with_tls(const std::string& ca, const std::string& cert = "", const std::string& key = "") {
    ClientOptions o;
    TlsOptions tls;
    tls.ca_file = certs_->path(ca);
    if (!cert.empty()) {
      tls.cert_file = certs_->path(cert);
      tls.key_file = certs_->path(key);
    }
    o.tls = tls;
    return o;
  }

  static RpcStatus compute(const Client& client) {
    const Batch b = random_batch("iiwa14", 7, 3, 11);
    ComputeResult out;
    return client.compute(b.request(kGradient), out);
  }

  static TestCertificates* certs_;
  static DaemonProcess* tls_daemon_;
  static DaemonProcess* mutual_daemon_;
};
TestCertificates* ServiceSecurity::certs_ = nullptr;
DaemonProcess* ServiceSecurity::tls_daemon_ = nullptr;
DaemonProcess* ServiceSecurity::mutual_daemon_ = nullptr;

TEST_F(ServiceSecurity, TlsClientsThatTrustTheCaCompute) {
  const Client trusting(tls_daemon_->tcp_address(), with_tls("ca.pem"));
  const RpcStatus ok = compute(trusting);
  EXPECT_TRUE(ok.is_ok()) << ok.to_string();
  std::string health;
  ASSERT_TRUE(trusting.check_health(health).is_ok());
  EXPECT_EQ(health, "SERVING");

  // the certificate names 127.0.0.1 and localhost; another name must be asked for explicitly
  ClientOptions renamed = with_tls("ca.pem");
  renamed.tls->target_name_override = "localhost";
  EXPECT_TRUE(compute(Client(tls_daemon_->tcp_address(), renamed)).is_ok());
  renamed.tls->target_name_override = "rbdgrad.example.com";
  EXPECT_EQ(compute(Client(tls_daemon_->tcp_address(), renamed)).code(), RpcCode::kUnavailable);

  const RpcStatus plaintext = compute(Client(tls_daemon_->tcp_address()));
  EXPECT_EQ(plaintext.code(), RpcCode::kUnavailable) << plaintext.to_string();
  const RpcStatus other_ca = compute(Client(tls_daemon_->tcp_address(), with_tls("other_ca.pem")));
  EXPECT_EQ(other_ca.code(), RpcCode::kUnavailable) << other_ca.to_string();
  // the Unix socket is plaintext
  EXPECT_TRUE(compute(Client(tls_daemon_->unix_address())).is_ok());
}

TEST_F(ServiceSecurity, MutualTlsAndTokensThroughTheClientLibrary) {
  ClientOptions good = with_tls("ca.pem", "client.pem", "client.key");
  good.bearer_token = kToken;
  const Client client(mutual_daemon_->tcp_address(), good);
  const RpcStatus ok = compute(client);
  EXPECT_TRUE(ok.is_ok()) << ok.to_string();
  EXPECT_EQ(client.list_models().size(), 1u);
  // the stream sends the token too
  ComputeSession session = client.open_session();
  const Batch b = random_batch("iiwa14", 7, 2, 5);
  ComputeResult step;
  const RpcStatus streamed = session.step(b.request(kGradient), step);
  EXPECT_TRUE(streamed.is_ok()) << streamed.to_string();
  EXPECT_TRUE(session.close().is_ok());

  // without a certificate, or with one of another CA, no connection
  ClientOptions no_cert = with_tls("ca.pem");
  no_cert.bearer_token = kToken;
  EXPECT_EQ(compute(Client(mutual_daemon_->tcp_address(), no_cert)).code(), RpcCode::kUnavailable);
  ClientOptions other_cert = with_tls("ca.pem", "other_client.pem", "other_client.key");
  other_cert.bearer_token = kToken;
  EXPECT_EQ(compute(Client(mutual_daemon_->tcp_address(), other_cert)).code(), RpcCode::kUnavailable);

  // a good connection without a token, or with a wrong one
  ClientOptions no_token = with_tls("ca.pem", "client.pem", "client.key");
  const Client anonymous(mutual_daemon_->tcp_address(), no_token);
  const RpcStatus missing = compute(anonymous);
  EXPECT_EQ(missing.code(), RpcCode::kUnauthenticated) << missing.to_string();
  EXPECT_THAT(missing.message(), HasSubstr("missing bearer token"));
  ClientOptions wrong = no_token;
  wrong.bearer_token = "mpc-token-5f0c9a7f";
  const RpcStatus refused = compute(Client(mutual_daemon_->tcp_address(), wrong));
  EXPECT_EQ(refused.code(), RpcCode::kUnauthenticated) << refused.to_string();
  EXPECT_EQ(refused.message(), "invalid bearer token");
  // health needs no token
  std::string health;
  const RpcStatus h = anonymous.check_health(health);
  ASSERT_TRUE(h.is_ok()) << h.to_string();
  EXPECT_EQ(health, "SERVING");

  // over the Unix socket (plaintext) the token is still required
  EXPECT_EQ(compute(Client(mutual_daemon_->unix_address())).code(), RpcCode::kUnauthenticated);
  ClientOptions local;
  local.bearer_token = "other-token-1234";
  EXPECT_TRUE(compute(Client(mutual_daemon_->unix_address(), local)).is_ok());
}

TEST_F(ServiceSecurity, UnreadableTlsFilesFailTheConstructor) {
  ClientOptions o;
  o.tls = TlsOptions{certs_->dir() + "/missing-ca.pem", "", "", ""};
  try {
    Client c(tls_daemon_->tcp_address(), o);
    FAIL() << "constructed";
  } catch (const ClientError& e) {
    EXPECT_EQ(e.code(), RpcCode::kInvalidArgument);
    EXPECT_THAT(e.message(), HasSubstr("tls.ca_file: cannot read '" + certs_->dir() + "/missing-ca.pem'"));
  }
  o.tls = TlsOptions{certs_->path("ca.pem"), certs_->path("client.pem"), "", ""};
  EXPECT_THROW(Client(tls_daemon_->tcp_address(), o), ClientError);
}

}  // namespace
}  // namespace rbdgrad::testing
