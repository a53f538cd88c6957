// Tests for server/access_control.cpp (tokens file, token check, per-client limits) and
// server/message_size.cpp (the derived limits.max_message_bytes).
#include "access_control.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <climits>
#include <filesystem>
#include <fstream>
#include <map>

#include "message_size.hpp"
#include "metrics.hpp"
#include "model_registry.hpp"

namespace rbdgrad::server {
namespace {

using ::testing::HasSubstr;
using ::testing::Not;

using Metadata = std::multimap<grpc::string_ref, grpc::string_ref>;

// a file of this test's own, removed with it
class TempFile {
 public:
  explicit TempFile(const std::string& text)
      : path_((std::filesystem::temp_directory_path() /
               ("rbdgrad_tokens_" + std::to_string(getpid()) + "_" + std::to_string(counter_++)))
                  .string()) {
    std::ofstream(path_) << text;
  }
  ~TempFile() { std::filesystem::remove(path_); }
  const std::string& path() const { return path_; }

 private:
  static inline int counter_ = 0;
  std::string path_;
};

TEST(TokensFile, ReadsNamesAndTokensSkippingCommentsAndBlankLines) {
  TempFile file("# clients of the lab\n\nmpc-left  s3cret-left\n\t mpc-right\ts3cret-right  \n   # indented comment\n");
  std::vector<ClientToken> tokens;
  const Status s = load_tokens_file(file.path(), tokens);
  ASSERT_TRUE(s.is_ok()) << s.to_string();
  ASSERT_EQ(tokens.size(), 2u);
  EXPECT_EQ(tokens[0].name, "mpc-left");
  EXPECT_EQ(tokens[0].token, "s3cret-left");
  EXPECT_EQ(tokens[1].name, "mpc-right");
  EXPECT_EQ(tokens[1].token, "s3cret-right");
}

TEST(TokensFile, ErrorsNameTheFileAndTheLineButNoToken) {
  std::vector<ClientToken> tokens;
  const Status missing = load_tokens_file("/nonexistent/tokens.txt", tokens);
  EXPECT_EQ(missing.code(), StatusCode::kNotFound);
  EXPECT_THAT(missing.message(), HasSubstr("auth.tokens_file: cannot read '/nonexistent/tokens.txt'"));

  const std::pair<const char*, const char*> bad[] = {
      {"a tok-a\n# x\nlonely\n", "line 3: expected 'NAME TOKEN'"},
      {"a tok-a b\n", "line 1: expected 'NAME TOKEN'"},
      {"a tok-a\na tok-b\n", "line 2: duplicate name 'a'"},
      {"a tok-same\nb tok-same\n", "line 2: the token of 'b' is another name's too"},
      {"a tok\x01x\n", "line 1: the token has a character that is not printable ASCII"},
      {"# only comments\n\n", "no 'NAME TOKEN' line"},
  };
  for (const auto& [text, want] : bad) {
    TempFile file(text);
    const Status s = load_tokens_file(file.path(), tokens);
    ASSERT_FALSE(s.is_ok()) << text;
    EXPECT_EQ(s.code(), StatusCode::kInvalidArgument);
    EXPECT_THAT(s.message(), HasSubstr("auth.tokens_file '" + file.path() + "'")) << text;
    EXPECT_THAT(s.message(), HasSubstr(want)) << text;
    EXPECT_THAT(s.message(), Not(HasSubstr("tok-"))) << "a token in the message: " << s.message();
  }
}

TEST(PeerWithoutPort, DropsTheNumericPortOnly) {
  EXPECT_EQ(peer_without_port("ipv4:10.0.0.7:51234"), "ipv4:10.0.0.7");
  EXPECT_EQ(peer_without_port("ipv6:[::1]:40000"), "ipv6:[::1]");
  EXPECT_EQ(peer_without_port("ipv6:[fe80::1]"), "ipv6:[fe80::1]");
  EXPECT_EQ(peer_without_port("unix:/tmp/rbdgradd.sock"), "unix:/tmp/rbdgradd.sock");
  EXPECT_EQ(peer_without_port("unix:"), "unix:");
  EXPECT_EQ(peer_without_port("something"), "something");
}

TEST(ConstantTimeEqual, ComparesWholeStrings) {
  EXPECT_TRUE(constant_time_equal("", ""));
  EXPECT_TRUE(constant_time_equal("abc", "abc"));
  EXPECT_FALSE(constant_time_equal("abc", "abd"));
  EXPECT_FALSE(constant_time_equal("abc", "ab"));
  EXPECT_FALSE(constant_time_equal("ab", "abc"));
  EXPECT_FALSE(constant_time_equal("", "a"));
  // a prefix padded with zeros is still another string
  EXPECT_FALSE(constant_time_equal(std::string("ab\0", 3), "ab"));
}

TEST(AccessControl, AuthenticatesTheBearerTokenOfTheMetadata) {
  AccessControl access({{"left", "tok-left"}, {"right", "tok-right"}}, LimitsConfig{}, nullptr);
  EXPECT_TRUE(access.auth_enabled());
  EXPECT_FALSE(access.limits_enabled());
  std::string name;
  const auto check = [&](const std::string& value) {
    Metadata md;
    if (!value.empty()) md.emplace("authorization", value);
    return access.authenticate(md, name);
  };
  ASSERT_TRUE(check("Bearer tok-right").ok());
  EXPECT_EQ(name, "right");
  ASSERT_TRUE(check("bearer tok-left").ok()) << "the scheme is case-insensitive";
  EXPECT_EQ(name, "left");

  const grpc::Status missing = check("");
  EXPECT_EQ(missing.error_code(), grpc::StatusCode::UNAUTHENTICATED);
  EXPECT_THAT(missing.error_message(), HasSubstr("missing bearer token"));
  const grpc::Status basic = check("Basic dG9rLWxlZnQ=");
  EXPECT_EQ(basic.error_code(), grpc::StatusCode::UNAUTHENTICATED);
  const grpc::Status wrong = check("Bearer tok-lefty");
  EXPECT_EQ(wrong.error_code(), grpc::StatusCode::UNAUTHENTICATED);
  EXPECT_EQ(wrong.error_message(), "invalid bearer token");
  EXPECT_EQ(check("Bearer ").error_code(), grpc::StatusCode::UNAUTHENTICATED);
}

TEST(AccessControl, RateLimitRefusesBeyondTheBurstAndCountsIt) {
  std::unique_ptr<Metrics> metrics;
  ASSERT_TRUE(Metrics::create("", [] { return std::vector<QueueSample>{}; }, [] { return 0; }, metrics).is_ok());
  LimitsConfig limits;
  limits.client_requests_per_second = 0.01;  // one token per 100 s: none comes back during the test
  limits.client_burst = 2;
  AccessControl access({}, limits, metrics.get());
  ASSERT_TRUE(access.limits_enabled());
  auto a = std::make_shared<AccessControl::Client>("ipv4:10.0.0.1");
  auto b = std::make_shared<AccessControl::Client>("ipv4:10.0.0.2");
  EXPECT_TRUE(access.admit(a, nullptr).ok());
  EXPECT_TRUE(access.admit(a, nullptr).ok());
  const grpc::Status third = access.admit(a, nullptr, "stream message 2: ");
  EXPECT_EQ(third.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED);
  EXPECT_EQ(third.error_message(),
            "stream message 2: client 'ipv4:10.0.0.1' is over its request rate "
            "(limits.client_requests_per_second = 0.01, limits.client_burst = 2)");
  // another client has a bucket of its own
  EXPECT_TRUE(access.admit(b, nullptr).ok());
  EXPECT_THAT(metrics->text(), HasSubstr("rbdgrad_rejected_requests_total{reason=\"client_rate\"} 1"));
  // without a client (neither auth nor limits apply) everything passes
  EXPECT_TRUE(access.admit(nullptr, nullptr).ok());
}

TEST(AccessControl, BurstDefaultsToTheRateAtLeastOne) {
  LimitsConfig limits;
  limits.client_requests_per_second = 0.001;
  AccessControl slow({}, limits, nullptr);
  auto c = std::make_shared<AccessControl::Client>("c");
  EXPECT_TRUE(slow.admit(c, nullptr).ok());
  EXPECT_EQ(slow.admit(c, nullptr).error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED);

  limits.client_requests_per_second = 3;
  AccessControl fast({}, limits, nullptr);
  auto d = std::make_shared<AccessControl::Client>("d");
  for (int i = 0; i < 3; ++i) EXPECT_TRUE(fast.admit(d, nullptr).ok()) << i;
}

TEST(AccessControl, ConcurrencyLimitHoldsAPlaceUntilTheTicketGoes) {
  std::unique_ptr<Metrics> metrics;
  ASSERT_TRUE(Metrics::create("", [] { return std::vector<QueueSample>{}; }, [] { return 0; }, metrics).is_ok());
  LimitsConfig limits;
  limits.client_max_concurrent = 1;
  AccessControl access({{"mpc", "tok"}}, limits, metrics.get());
  auto c = std::make_shared<AccessControl::Client>("mpc");
  AccessControl::Ticket first;
  ASSERT_TRUE(access.admit(c, &first).ok());
  AccessControl::Ticket second;
  const grpc::Status refused = access.admit(c, &second);
  EXPECT_EQ(refused.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED);
  EXPECT_EQ(refused.error_message(),
            "client 'mpc' has too many requests in flight (limits.client_max_concurrent = 1)");
  // calls that are not compute requests (no ticket) are not counted
  EXPECT_TRUE(access.admit(c, nullptr).ok());
  {
    AccessControl::Ticket moved = std::move(first);
    EXPECT_EQ(access.admit(c, &second).error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED);
  }  // the place is given back with the ticket
  EXPECT_TRUE(access.admit(c, &second).ok());
  EXPECT_THAT(metrics->text(), HasSubstr("rbdgrad_rejected_requests_total{reason=\"client_concurrency\"} 2"));
}

TEST(MessageSize, LargestRequestOrResponsePlusTheMargin) {
  // iiwa14, one state: the response (8 * (2*7 + 6*49) + 5 bytes) is larger than the request
  // (8 * (3*7 + 49 + 6*7))
  EXPECT_EQ(largest_compute_message_bytes(1, 7), 2469u + kMessageMarginBytes);
  EXPECT_EQ(largest_compute_message_bytes(1000, 7), 2'469'000u + kMessageMarginBytes);
  EXPECT_EQ(largest_compute_message_bytes(10, 0), 50u + kMessageMarginBytes);
}

TEST(MessageSize, DerivedFromTheLargestModelAndClampedToGrpcsLimit) {
  ModelRegistry models;
  ASSERT_TRUE(ModelRegistry::load({{"iiwa14", "", "iiwa14", std::nullopt, {}}, {"talos", "", "talos_reduced", std::nullopt, {}}},
                                  models)
                  .is_ok());
  const auto nv = static_cast<std::uint64_t>(models.find("talos")->model.nv);
  std::string how;
  EXPECT_EQ(derived_max_message_bytes(models, 100, how),
            static_cast<std::int64_t>(largest_compute_message_bytes(100, nv)));
  EXPECT_THAT(how, HasSubstr("max_states_per_request = 100 states of model 'talos' (nv " + std::to_string(nv) + ";"));
  // 65536 talos states would take gigabytes: gRPC's int is the limit
  EXPECT_EQ(derived_max_message_bytes(models, 65536, how), INT_MAX);
  EXPECT_THAT(how, HasSubstr("above gRPC's largest message"));
}

}  // namespace
}  // namespace rbdgrad::server
