// Tests for ptxas_report.cpp: ptxas's per-function report read from NVRTC's log (as CUDA 13's
// ptxas writes it with --verbose). No NVRTC needed.
#include <gtest/gtest.h>

#include <string>

#include "ptxas_report.hpp"

namespace rbdgrad::testing {
namespace {

// a kernel at a register cap, and a device function it calls (not inlined)
const std::string kLog =
    "ptxas info    : Overriding maximum register limit 256 for '_Z6kernelPd' with  64 of maxrregcount option\n"
    "ptxas info    : 427 bytes gmem\n"
    "ptxas info    : Compiling entry function '_Z6kernelPd' for 'sm_90'\n"
    "ptxas info    : Function properties for _Z6kernelPd\n"
    "ptxas         .     96 bytes stack frame, 8 bytes spill stores, 12 bytes spill loads\n"
    "ptxas info    : Used 64 registers, used 1 barriers, 96 bytes cumulative stack size\n"
    "ptxas info    : Compile time = 523.708 ms\n"
    "ptxas info    : Function properties for __internal_trig_reduction_slowpathd\n"
    "ptxas         .     40 bytes stack frame, 0 bytes spill stores, 4 bytes spill loads\n";

TEST(PtxasReport, ReadsEachFunctionsRegistersStackAndSpills) {
  const std::vector<cuda::PtxasFunction> functions = cuda::ptxas_functions(kLog);
  ASSERT_EQ(functions.size(), 2u);
  EXPECT_EQ(functions[0].name, "_Z6kernelPd");
  EXPECT_TRUE(functions[0].entry);
  EXPECT_EQ(functions[0].registers, 64);
  EXPECT_EQ(functions[0].stack_frame, 96);
  EXPECT_EQ(functions[0].spill_stores, 8);
  EXPECT_EQ(functions[0].spill_loads, 12);
  EXPECT_EQ(functions[1].name, "__internal_trig_reduction_slowpathd");
  EXPECT_FALSE(functions[1].entry);
  EXPECT_EQ(functions[1].registers, -1);  // ptxas prints none for a device function
  EXPECT_EQ(functions[1].stack_frame, 40);
  EXPECT_EQ(functions[1].spill_stores, 0);
  EXPECT_EQ(functions[1].spill_loads, 4);
}

TEST(PtxasReport, TheEntryIsTheKernelWhereverItIsReported) {
  // the device function reported first: the entry is still the kernel
  const std::string log =
      "ptxas info    : Function properties for _Z6helperv\n"
      "ptxas         .     0 bytes stack frame, 16 bytes spill stores, 16 bytes spill loads\n"
      "ptxas info    : Compiling entry function '_Z1kv' for 'sm_90'\n"
      "ptxas info    : Function properties for _Z1kv\n"
      "ptxas         .     0 bytes stack frame, 0 bytes spill stores, 0 bytes spill loads\n"
      "ptxas info    : Used 40 registers, used 0 barriers\n";
  const cuda::PtxasFunction entry = cuda::ptxas_entry(log);
  EXPECT_EQ(entry.name, "_Z1kv");
  EXPECT_EQ(entry.registers, 40);
  EXPECT_EQ(entry.spill_stores, 0);
  EXPECT_EQ(entry.spill_loads, 0);
}

TEST(PtxasReport, ALogWithoutTheReportHasNoFunctions) {
  EXPECT_TRUE(cuda::ptxas_functions("").empty());
  EXPECT_TRUE(cuda::ptxas_functions("main.cu(12): warning: variable \"x\" was declared but never referenced\n").empty());
  const cuda::PtxasFunction none = cuda::ptxas_entry("");
  EXPECT_EQ(none.registers, -1);
  EXPECT_EQ(none.spill_stores, -1);
  EXPECT_EQ(none.spill_loads, -1);
}

}  // namespace
}  // namespace rbdgrad::testing
