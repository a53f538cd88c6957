// ptxas's report on a compiled kernel (NVRTC's log with --ptxas-options=--verbose), per function:
// its registers, stack frame and spills. The register-cap tests (kernel_source_test.cpp) and
// bench/plugins/cuda_kernel_registers.cpp read a build's spills from it.
#pragma once

#include <string>
#include <vector>

namespace rbdgrad::cuda {

struct PtxasFunction {
  std::string name;      // mangled, as ptxas prints it
  bool entry = false;    // a kernel (ptxas compiled it as an entry function)
  int registers = -1;    // -1 where the log does not say (ptxas prints none for a device function)
  int stack_frame = -1;  // bytes
  int spill_stores = -1;
  int spill_loads = -1;
};

/// The functions of `log` in the order ptxas reports them (empty where the log has no report:
/// compiled without --ptxas-options=--verbose).
std::vector<PtxasFunction> ptxas_functions(const std::string& log);

/// The first entry function of `log`, or a function with every field -1 where there is none.
PtxasFunction ptxas_entry(const std::string& log);

}  // namespace rbdgrad::cuda
