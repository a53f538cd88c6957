// Tests for server/grpc_status.cpp.
#include "grpc_status.hpp"

#include <gtest/gtest.h>

namespace rbdgrad::server {
namespace {

TEST(GrpcStatus, EveryCoreCodeMapsToItsGrpcCode) {
  const struct {
    StatusCode core;
    grpc::StatusCode grpc;
  } cases[] = {
      {StatusCode::kInvalidArgument, grpc::StatusCode::INVALID_ARGUMENT},
      {StatusCode::kNotFound, grpc::StatusCode::NOT_FOUND},
      {StatusCode::kFailedPrecondition, grpc::StatusCode::FAILED_PRECONDITION},
      {StatusCode::kOutOfRange, grpc::StatusCode::OUT_OF_RANGE},
      {StatusCode::kUnimplemented, grpc::StatusCode::UNIMPLEMENTED},
      {StatusCode::kUnavailable, grpc::StatusCode::UNAVAILABLE},
      {StatusCode::kInternal, grpc::StatusCode::INTERNAL},
  };
  for (const auto& c : cases) {
    const grpc::Status s = to_grpc_status(Status(c.core, "state 3: field 'q' element 2 is not finite"));
    EXPECT_EQ(s.error_code(), c.grpc) << status_code_name(c.core);
    EXPECT_EQ(s.error_message(), "state 3: field 'q' element 2 is not finite") << status_code_name(c.core);
  }
}

TEST(GrpcStatus, OkIsOkAndAnUnknownCodeIsInternal) {
  EXPECT_TRUE(to_grpc_status(Status::ok()).ok());
  EXPECT_EQ(to_grpc_code(static_cast<StatusCode>(99)), grpc::StatusCode::INTERNAL);
}

TEST(GrpcStatus, UnavailableHasItsCoreNameAndHelper) {
  const Status s = unavailable("backend cuda is not available: not configured");
  EXPECT_EQ(s.code(), StatusCode::kUnavailable);
  EXPECT_EQ(s.to_string(), "unavailable: backend cuda is not available: not configured");
}

}  // namespace
}  // namespace rbdgrad::server
