// Tests for plugins/common/options.cpp.
#include "common/options.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <string>
#include <utility>

namespace rbdgrad::plugin {
namespace {

using ::testing::HasSubstr;

TEST(PluginOptions, NoneAndKnownKeys) {
  EXPECT_TRUE(check_options(nullptr, {"threads"}).is_ok());
  const char* keys[] = {"threads"};
  const char* values[] = {"6"};
  const rbdgrad_options o{sizeof(rbdgrad_options), 1, keys, values};
  EXPECT_TRUE(check_options(&o, {"threads"}).is_ok());
  EXPECT_STREQ(find_option(&o, "threads"), "6");
  EXPECT_EQ(find_option(&o, "other"), nullptr);
  std::uint64_t threads = 3;
  ASSERT_TRUE(option_uint(&o, "threads", 1, 64, threads).is_ok());
  EXPECT_EQ(threads, 6u);
  std::uint64_t absent = 9;
  ASSERT_TRUE(option_uint(&o, "other", 1, 64, absent).is_ok());
  EXPECT_EQ(absent, 9u);  // the default stays
}

TEST(PluginOptions, MalformedListsAndValues) {
  const char* keys[] = {"threads", nullptr};
  const char* values[] = {"2", "x"};
  rbdgrad_options o{sizeof(rbdgrad_options), 2, keys, values};
  EXPECT_THAT(check_options(&o, {"threads"}).message(), HasSubstr("options.keys[1] is NULL"));
  o = {sizeof(rbdgrad_options), 1, nullptr, values};
  EXPECT_THAT(check_options(&o, {"threads"}).message(), HasSubstr("options.keys or options.values is NULL"));
  o = {0, 1, keys, values};
  EXPECT_THAT(check_options(&o, {"threads"}).message(), HasSubstr("options.struct_size is 0"));
  const char* unknown[] = {"cores"};
  o = {sizeof(rbdgrad_options), 1, unknown, values};
  EXPECT_THAT(check_options(&o, {"threads"}).message(), HasSubstr("unknown option 'cores' (known: threads)"));
  for (const char* bad : {"abc", "", "0", "65", "-3", "+3", "3 ", "0x4", "18446744073709551616"}) {
    const char* k[] = {"threads"};
    const char* v[] = {bad};
    const rbdgrad_options one{sizeof(rbdgrad_options), 1, k, v};
    std::uint64_t value = 1;
    const Status s = option_uint(&one, "threads", 1, 64, value);
    EXPECT_EQ(s.code(), StatusCode::kInvalidArgument) << bad;
    EXPECT_THAT(s.message(), HasSubstr("option 'threads' is '" + std::string(bad) + "'")) << bad;
    EXPECT_EQ(value, 1u) << bad;
  }
}

TEST(PluginOptions, Booleans) {
  for (const auto& [text, expected] : {std::pair{"true", true}, std::pair{"false", false}}) {
    const char* k[] = {"specialize"};
    const char* v[] = {text};
    const rbdgrad_options one{sizeof(rbdgrad_options), 1, k, v};
    bool value = !expected;
    ASSERT_TRUE(option_bool(&one, "specialize", value).is_ok()) << text;
    EXPECT_EQ(value, expected) << text;
  }
  bool absent = true;
  ASSERT_TRUE(option_bool(nullptr, "specialize", absent).is_ok());
  EXPECT_TRUE(absent);  // the default stays
  for (const char* bad : {"", "True", "1", "yes", "false "}) {
    const char* k[] = {"specialize"};
    const char* v[] = {bad};
    const rbdgrad_options one{sizeof(rbdgrad_options), 1, k, v};
    bool value = true;
    const Status s = option_bool(&one, "specialize", value);
    EXPECT_EQ(s.code(), StatusCode::kInvalidArgument) << bad;
    EXPECT_THAT(s.message(), HasSubstr("option 'specialize' is '" + std::string(bad) + "': expected 'true' or 'false'"));
    EXPECT_TRUE(value) << bad;
  }
}

}  // namespace
}  // namespace rbdgrad::plugin
