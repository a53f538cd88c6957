// The FPGA backend through the real daemon, in emulation=csim: it serves fixed-point gradients and
// says everywhere that it is the C simulation (server info, the response), states that leave the
// Q16.16 range come back computed on the CPU in f64 and listed as such, and a daemon whose FPGA
// plugin has no card configured says why and goes on serving on the CPU.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>

#include "integration_support.hpp"

namespace rbdgrad::testing {
namespace {

using ::testing::ElementsAre;
using ::testing::HasSubstr;

constexpr std::uint32_t kGradient = Output::kQdd | Output::kDqddDq | Output::kDqddDqd;

const BackendStatus* find_backend(const ServerInfo& info, const std::string& name) {
  const auto it = std::find_if(info.backends.begin(), info.backends.end(),
                               [&](const BackendStatus& b) { return b.name == name; });
  return it == info.backends.end() ? nullptr : &*it;
}

TEST(ServiceFpga, CsimServesFixedPointAndSaysSo) {
  const DaemonProcess daemon(RBDGRADD_PATH, daemon_config(std::string("plugins:\n  - path: ") +
                                                          RBDGRAD_FPGA_PLUGIN_PATH + "\n    options: {emulation: csim}\n"));
  Client client(daemon.tcp_address());
  const ServerInfo info = client.server_info();
  const BackendStatus* fpga = find_backend(info, "fpga");
  ASSERT_NE(fpga, nullptr);
  EXPECT_TRUE(fpga->ready) << fpga->reason;
  EXPECT_EQ(fpga->mode, "csim");
  EXPECT_THAT(fpga->device, HasSubstr("C simulation"));

  const Model model = load_embedded("panda");
  Batch batch = random_batch("panda", model.nv, 9, 11);
  ComputeRequest req = batch.request(kGradient, ComputeInput::kQdd, Precision::kFixed);
  req.backend = Backend::kFpga;
  ComputeResult fixed;
  ASSERT_TRUE(client.compute(req, fixed)) << "csim compute";
  EXPECT_EQ(fixed.backend(), Backend::kFpga);
  EXPECT_EQ(fixed.backend_mode(), "csim");
  EXPECT_EQ(fixed.precision(), Precision::kFixed);
  EXPECT_TRUE(fixed.fallback_states().empty());
  // Q16.16 gradients of panda stay within 2.6e-3 of double on the reference states (docs/fpga.md);
  // these random states are of the same size
  const auto expected = expected_outputs(model, batch, kGradient, false);
  for (std::uint32_t k = 0; k < batch.n; ++k) {
    const Eigen::Map<const Eigen::MatrixXd> ref(expected.at(mask(Output::kDqddDq)).data() + k * model.nv * model.nv,
                                                model.nv, model.nv);
    EXPECT_LT(relative_error(fixed.dqdd_dq(k).transpose(), ref), 1e-2) << "state " << k;
  }

  // states 2 and 5 spin at 300 rad/s: the kernel flags them and the CPU computes them in f64
  for (std::uint32_t k : {2u, 5u})
    for (int i = 0; i < model.nv; ++i) batch.qd[k * static_cast<std::size_t>(model.nv) + static_cast<std::size_t>(i)] = 300;
  req = batch.request(kGradient, ComputeInput::kQdd, Precision::kFixed);
  req.backend = Backend::kFpga;
  ComputeResult mixed;
  ASSERT_TRUE(client.compute(req, mixed)) << "fallback";
  EXPECT_THAT(std::vector<std::uint32_t>(mixed.fallback_states().begin(), mixed.fallback_states().end()),
              ElementsAre(2u, 5u));
  EXPECT_EQ(mixed.fallback_backend(), Backend::kCpu);
  EXPECT_EQ(mixed.fallback_precision(), Precision::kF64);
  const auto f64 = expected_outputs(model, batch, kGradient, false);
  for (std::uint32_t k = 0; k < batch.n; ++k) {
    const std::size_t at = k * static_cast<std::size_t>(model.nv * model.nv);
    if (k == 2 || k == 5) {
      // the CPU backend in f64 is the core library, bit for bit
      for (int e = 0; e < model.nv * model.nv; ++e)
        EXPECT_EQ(mixed.block(Output::kDqddDq)[at + static_cast<std::size_t>(e)], f64.at(mask(Output::kDqddDq))[at + static_cast<std::size_t>(e)]);
    } else {
      EXPECT_TRUE(mixed.dqdd_dq(k) == fixed.dqdd_dq(k)) << "state " << k << " is the kernel's";
    }
  }
}

TEST(ServiceFpga, WithoutACardItIsUnavailableAndTheDaemonServes) {
  const DaemonProcess daemon(RBDGRADD_PATH, daemon_config(std::string("plugins:\n  - path: ") +
                                                          RBDGRAD_FPGA_PLUGIN_PATH + "\n"));
  Client client(daemon.tcp_address());
  const BackendStatus* fpga = find_backend(client.server_info(), "fpga");
  ASSERT_NE(fpga, nullptr);
  EXPECT_FALSE(fpga->ready);
  EXPECT_THAT(fpga->reason, HasSubstr("xclbin"));
  EXPECT_THAT(daemon.log(), HasSubstr("backend fpga: unavailable"));

  const Model model = load_embedded("iiwa14");
  const Batch batch = random_batch("iiwa14", model.nv, 4, 3);
  ComputeRequest req = batch.request(kGradient, ComputeInput::kTau, Precision::kFixed);
  req.backend = Backend::kFpga;
  ComputeResult out;
  const RpcStatus s = client.compute(req, out);
  EXPECT_EQ(s.code(), RpcCode::kUnavailable);
  EXPECT_THAT(s.message(), HasSubstr("backend fpga is not available"));
  req.backend = Backend::kCpu;
  EXPECT_TRUE(client.compute(req, out)) << "the CPU still serves";
}

}  // namespace
}  // namespace rbdgrad::testing
