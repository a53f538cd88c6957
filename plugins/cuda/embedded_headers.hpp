// The device headers (plugins/cuda/device/*.hpp) as the plugin was built with them, by file name:
// NVRTC compiles the robot-specific block kernel from these at model load (kernel_source.cpp).
// The table is generated at build time (embed_device_headers.cmake).
#pragma once

#include <cstddef>

namespace rbdgrad::cuda {

struct EmbeddedHeader {
  const char* name;  // as the headers include each other: "spatial.hpp"
  const char* text;
};

extern const EmbeddedHeader kEmbeddedDeviceHeaders[];
extern const std::size_t kEmbeddedDeviceHeaderCount;

}  // namespace rbdgrad::cuda
