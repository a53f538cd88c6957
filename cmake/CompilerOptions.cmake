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
  # GCC 12.0-12.2 (Debian 12's is 12.2) warns inside its own AVX-512 intrinsics, whose undefined
  # vectors initialize themselves (`__m512d __Y = __Y;`, GCC bug 105593, fixed in 12.3): through
  # Eigen that is about 900 false -Wmaybe-uninitialized warnings on a machine with AVX-512, which
  # would hide real ones. The portable build (RBDGRAD_NATIVE=OFF) keeps the warning.
  if(CMAKE_CXX_COMPILER_ID STREQUAL "GNU" AND CMAKE_CXX_COMPILER_VERSION VERSION_GREATER_EQUAL 12
     AND CMAKE_CXX_COMPILER_VERSION VERSION_LESS 12.3)
    target_compile_options(rbdgrad_arch INTERFACE $<$<COMPILE_LANGUAGE:CXX>:-Wno-maybe-uninitialized>)
  endif()
endif()
target_link_libraries(rbdgrad_options INTERFACE rbdgrad_arch)

# Installed binaries and libraries find the project's shared libraries (librbdgrad_client,
# librbdgrad_proto) in <prefix>/lib: from bin/ and from lib/ alike, $ORIGIN/../lib is that folder.
set(CMAKE_INSTALL_RPATH "$ORIGIN/../lib")
