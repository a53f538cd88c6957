// Tests that the client's public headers live next to the core library's and the plugin ABI's in
// one translation unit (no clashing names in namespace rbdgrad), and that the output bits agree.
#include <gtest/gtest.h>

#include "rbdgrad/algorithm/evaluate.hpp"
#include "rbdgrad/client.hpp"
#include "rbdgrad/model.hpp"
#include "rbdgrad/plugin_api.h"
#include "rbdgrad/status.hpp"

namespace {

static_assert(rbdgrad::mask(rbdgrad::Output::kQdd) == rbdgrad::kOutputQdd);
static_assert(rbdgrad::mask(rbdgrad::Output::kQdd) == RBDGRAD_OUTPUT_QDD);
static_assert(rbdgrad::mask(rbdgrad::Output::kMinv) == RBDGRAD_OUTPUT_MINV);
static_assert(rbdgrad::mask(rbdgrad::Output::kDqddDq) == RBDGRAD_OUTPUT_DQDD_DQ);
static_assert(rbdgrad::mask(rbdgrad::Output::kDqddDqd) == RBDGRAD_OUTPUT_DQDD_DQD);
static_assert(rbdgrad::mask(rbdgrad::Output::kTau) == RBDGRAD_OUTPUT_TAU);
static_assert(rbdgrad::mask(rbdgrad::Output::kDtauDq) == RBDGRAD_OUTPUT_DTAU_DQ);
static_assert(rbdgrad::mask(rbdgrad::Output::kDtauDqd) == RBDGRAD_OUTPUT_DTAU_DQD);
static_assert(rbdgrad::mask(rbdgrad::Output::kM) == RBDGRAD_OUTPUT_M);

TEST(ClientHeaders, CoexistWithTheCoreLibrary) {
  const rbdgrad::Status core_status = rbdgrad::invalid_argument("x");
  const rbdgrad::RpcStatus rpc_status(rbdgrad::RpcCode::kInvalidArgument, "x");
  EXPECT_FALSE(core_status.is_ok());
  EXPECT_FALSE(rpc_status.is_ok());
  EXPECT_EQ(rbdgrad::kDefaultServerAddress, "127.0.0.1:50051");
}

}  // namespace
