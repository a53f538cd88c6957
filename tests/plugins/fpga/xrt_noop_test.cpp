// The FPGA plugin's XRT host path without a card, under XRT's noop shim (XCL_EMULATION_MODE=noop)
// and a metadata-only xclbin (plugins/fpga/xclbin/make_noop_xclbin.sh, built into the build tree):
// the device opens, the xclbin loads, the kernel and its buffers are created, and every chunk's
// run is started and waited for. The noop shim computes nothing, so the test also shows that
// outputs the kernel never wrote are not passed off as results. Its own executable: the XRT
// environment it sets holds for the whole process.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <string>

#include "../../support/test_models.hpp"
#include "../support/plugin_harness.hpp"
#include "common/model_desc.hpp"
#include "host/fpga_instance.hpp"
#include "rbdgrad/fixed_point.hpp"

namespace rbdgrad::testing {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;

constexpr const char* kXrtLibDir = "/usr/lib/x86_64-linux-gnu";

const rbdgrad_plugin_api* api() {
  static const rbdgrad_plugin_entry_fn fn = load_plugin_entry(RBDGRAD_FPGA_PLUGIN_PATH);
  return fn(RBDGRAD_PLUGIN_API_MAJOR, RBDGRAD_PLUGIN_API_MINOR);
}

// XRT looks for its shims in $XILINX_XRT/lib, which Debian does not lay out: a folder of links.
class XrtNoop : public ::testing::Test {
 protected:
  void SetUp() override {
    if (!fs::exists(fs::path(kXrtLibDir) / "libxrt_noop.so.2"))
      GTEST_SKIP() << "XRT's noop shim (" << kXrtLibDir << "/libxrt_noop.so.2, Debian libxrt1) is not installed";
    const fs::path root = fs::path(::testing::TempDir()) / "rbdgrad_xilinx_xrt";
    fs::create_directories(root / "lib");
    for (const auto& entry : fs::directory_iterator(kXrtLibDir)) {
      const std::string name = entry.path().filename().string();
      if (name.rfind("libxrt", 0) == 0 && name.size() > 5 && name.compare(name.size() - 5, 5, ".so.2") == 0) {
        std::error_code ec;
        fs::create_symlink(entry.path(), root / "lib" / name, ec);  // exists from an earlier test: fine
      }
    }
    setenv("XILINX_XRT", root.c_str(), 1);
    setenv("XCL_EMULATION_MODE", "noop", 1);
  }
};

TEST_F(XrtNoop, TheHostPathRunsAndUnwrittenOutputsAreNotResults) {
  const Model model = load_embedded("iiwa14");
  const plugin::ModelDesc desc(model);
  std::optional<PluginError> e;
  InstancePtr instance = create(api(), desc.desc(), {{"xclbin", RBDGRAD_NOOP_XCLBIN}, {"chunk_states", "2"}}, &e);
  ASSERT_TRUE(instance) << e->message;
  rbdgrad_instance_info info{};
  info.struct_size = sizeof(info);
  ASSERT_FALSE(take(api(), api()->describe_instance(instance.get(), &info)));
  EXPECT_STREQ(info.mode, "");  // XRT, not the C simulation
  EXPECT_STREQ(info.device, "FPGA device 0");  // the noop shim answers no info query

  // five states in chunks of two: three runs through both slots
  BatchArrays<std::int32_t> a(5, model.nv);
  for (std::int32_t& x : a.q) x = Q16_16(0.3).raw();
  rbdgrad_batch b = a.batch(RBDGRAD_PRECISION_FIXED_Q16_16, RBDGRAD_INPUT_QDD,
                            RBDGRAD_OUTPUT_DQDD_DQ | RBDGRAD_OUTPUT_DQDD_DQD, false, false);
  e = take(api(), api()->compute(instance.get(), &b));
  ASSERT_TRUE(e);
  EXPECT_EQ(e->code, RBDGRAD_ERROR_INTERNAL);
  EXPECT_THAT(e->message, HasSubstr("state 0: the FPGA kernel did not write its results"));
  EXPECT_THAT(e->message, HasSubstr("and 4 more failed states"));
  for (std::int32_t s : a.state_status) EXPECT_EQ(s, RBDGRAD_ERROR_INTERNAL);
  for (std::int32_t x : a.out(RBDGRAD_OUTPUT_DQDD_DQ)) ASSERT_EQ(x, 77) << "an output was written";
}

TEST_F(XrtNoop, ADeviceTheShimCannotOpenIsUnavailableNamingIt) {
  const plugin::ModelDesc desc(load_embedded("iiwa14"));
  std::optional<PluginError> e;
  EXPECT_FALSE(create(api(), desc.desc(), {{"xclbin", RBDGRAD_NOOP_XCLBIN}, {"device", "0000:65:00.1"}}, &e));
  ASSERT_TRUE(e);
  EXPECT_EQ(e->code, RBDGRAD_ERROR_UNAVAILABLE);
  EXPECT_THAT(e->message, HasSubstr("XRT: cannot open device '0000:65:00.1'"));
}

}  // namespace
}  // namespace rbdgrad::testing
