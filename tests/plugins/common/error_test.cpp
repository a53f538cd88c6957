// Tests for plugins/common/error.cpp: status conversion, the error object and the exception guard.
#include "common/error.hpp"

#include <gtest/gtest.h>

#include <stdexcept>

namespace rbdgrad::plugin {
namespace {

TEST(PluginError, StatusCodesMapToAbiCodes) {
  EXPECT_EQ(error_code_from_status(StatusCode::kInvalidArgument), RBDGRAD_ERROR_INVALID_ARGUMENT);
  EXPECT_EQ(error_code_from_status(StatusCode::kOutOfRange), RBDGRAD_ERROR_NUMERICAL);
  EXPECT_EQ(error_code_from_status(StatusCode::kFailedPrecondition), RBDGRAD_ERROR_NUMERICAL);
  EXPECT_EQ(error_code_from_status(StatusCode::kUnimplemented), RBDGRAD_ERROR_UNSUPPORTED);
  EXPECT_EQ(error_code_from_status(StatusCode::kUnavailable), RBDGRAD_ERROR_UNAVAILABLE);
  EXPECT_EQ(error_code_from_status(StatusCode::kNotFound), RBDGRAD_ERROR_INTERNAL);
  EXPECT_EQ(error_code_from_status(StatusCode::kInternal), RBDGRAD_ERROR_INTERNAL);
}

TEST(PluginError, FromStatusKeepsTheMessage) {
  EXPECT_EQ(make_error(Status::ok()), nullptr);
  rbdgrad_error* e = make_error(failed_precondition("joint 3: M is not positive definite"));
  ASSERT_NE(e, nullptr);
  EXPECT_EQ(error_code(e), static_cast<uint32_t>(RBDGRAD_ERROR_NUMERICAL));
  EXPECT_STREQ(error_message(e), "joint 3: M is not positive definite");
  error_delete(e);
  e = make_error(Status(StatusCode::kInvalidArgument, ""));
  EXPECT_STREQ(error_message(e), "error without a message: invalid_argument");
  error_delete(e);
}

TEST(PluginError, NullIsNoError) {
  EXPECT_EQ(static_cast<int>(error_code(nullptr)), 0);
  EXPECT_STREQ(error_message(nullptr), "");
  error_delete(nullptr);
}

TEST(PluginError, GuardedPassesResultsThrough) {
  EXPECT_EQ(guarded([]() -> rbdgrad_error* { return nullptr; }), nullptr);
  EXPECT_EQ(guarded([] { return Status::ok(); }), nullptr);
  rbdgrad_error* e = guarded([] { return unimplemented("no fp16"); });
  EXPECT_EQ(error_code(e), static_cast<uint32_t>(RBDGRAD_ERROR_UNSUPPORTED));
  EXPECT_STREQ(error_message(e), "no fp16");
  error_delete(e);
  int calls = 0;
  guarded([&] { ++calls; });
  EXPECT_EQ(calls, 1);
}

TEST(PluginError, GuardedTurnsExceptionsIntoInternalErrors) {
  rbdgrad_error* e = guarded([]() -> Status { throw std::runtime_error("boom"); });
  EXPECT_EQ(error_code(e), static_cast<uint32_t>(RBDGRAD_ERROR_INTERNAL));
  EXPECT_STREQ(error_message(e), "unexpected exception: boom");
  error_delete(e);
  e = guarded([]() -> rbdgrad_error* { throw 42; });
  EXPECT_EQ(error_code(e), static_cast<uint32_t>(RBDGRAD_ERROR_INTERNAL));
  EXPECT_STREQ(error_message(e), "unexpected exception of unknown type");
  error_delete(e);
  e = guarded([]() -> Status { throw std::bad_alloc(); });
  EXPECT_STREQ(error_message(e), "out of memory");
  error_delete(e);
  guarded([] { throw std::logic_error("dropped"); });  // a void body cannot report: no crash
}

}  // namespace
}  // namespace rbdgrad::plugin
