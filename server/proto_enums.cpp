// Proto enum <-> internal name and flag conversions.
#include "proto_enums.hpp"

#include "rbdgrad/plugin_api.h"

namespace rbdgrad::server {

namespace v1 = rbdgrad::v1;

bool backend_name(int backend, std::string_view& out) noexcept {
  switch (backend) {
    case v1::BACKEND_AUTO: out = ""; return true;
    case v1::BACKEND_CPU: out = "cpu"; return true;
    case v1::BACKEND_CUDA: out = "cuda"; return true;
    case v1::BACKEND_FPGA: out = "fpga"; return true;
    default: return false;
  }
}

v1::Backend backend_enum(std::string_view name) noexcept {
  if (name == "cpu") return v1::BACKEND_CPU;
  if (name == "cuda") return v1::BACKEND_CUDA;
  if (name == "fpga") return v1::BACKEND_FPGA;
  return v1::BACKEND_AUTO;
}

bool precision_flag(int precision, std::uint32_t& out) noexcept {
  switch (precision) {
    case v1::PRECISION_AUTO: out = 0; return true;
    case v1::PRECISION_F64: out = RBDGRAD_PRECISION_F64; return true;
    case v1::PRECISION_F32: out = RBDGRAD_PRECISION_F32; return true;
    case v1::PRECISION_FIXED: out = RBDGRAD_PRECISION_FIXED_Q16_16; return true;
    default: return false;
  }
}

v1::Precision precision_enum(std::uint32_t flag) noexcept {
  switch (flag) {
    case RBDGRAD_PRECISION_F64: return v1::PRECISION_F64;
    case RBDGRAD_PRECISION_F32: return v1::PRECISION_F32;
    case RBDGRAD_PRECISION_FIXED_Q16_16: return v1::PRECISION_FIXED;
    default: return v1::PRECISION_AUTO;
  }
}

}  // namespace rbdgrad::server
