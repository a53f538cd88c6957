# Warnings and optimisation flags shared by every rbdgrad target (through rbdgrad_options).
add_library(rbdgrad_options INTERFACE)
target_compile_options(rbdgrad_options INTERFACE
  $<$<COMPILE_LANGUAGE:CXX>:-Wall -Wextra -Wpedantic -Wshadow -Wnon-virtual-dtor>)
if(CMAKE_BUILD_TYPE STREQUAL "Release")
  # the dynamics kernels are small fixed-size loops: -O3 unrolls and vectorises them
  target_compile_options(rbdgrad_options INTERFACE $<$<COMPILE_LANGUAGE:CXX>:-O3>)
endif()
# -march=native changes the alignment of Eigen's fixed-size types (AVX): everything that shares
# Eigen types with the core must be compiled the same way, so rbdgrad_core exports this flag.
add_library(rbdgrad_arch INTERFACE)
if(RBDGRAD_NATIVE)
  target_compile_options(rbdgrad_arch INTERFACE $<$<COMPILE_LANGUAGE:CXX>:-march=native>)
endif()
target_link_libraries(rbdgrad_options INTERFACE rbdgrad_arch)

# Installed binaries and libraries find the project's shared libraries (librbdgrad_client,
# librbdgrad_proto) in <prefix>/lib: from bin/ and from lib/ alike, $ORIGIN/../lib is that folder.
set(CMAKE_INSTALL_RPATH "$ORIGIN/../lib")
