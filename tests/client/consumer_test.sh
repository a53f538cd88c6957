#!/usr/bin/env bash
# Tests the installed CMake package of the client library, run by CTest:
#   consumer_test.sh BUILD_DIR SOURCE_DIR
# installs the "client" component of BUILD_DIR into a temporary prefix, builds the consumer
# project tests/client/consumer against it with find_package(rbdgrad), and runs it.
set -euo pipefail

build=${1:?usage: consumer_test.sh BUILD_DIR SOURCE_DIR}
source_dir=${2:?usage: consumer_test.sh BUILD_DIR SOURCE_DIR}
work="$(mktemp -d "${TMPDIR:-/tmp}/rbdgrad-consumer.XXXXXX")"
trap 'rm -rf "$work"' EXIT
fail() { echo "FAIL: $*" >&2; exit 1; }

cmake --install "$build" --prefix "$work/prefix" --component client >"$work/install.log" \
  || { cat "$work/install.log"; fail "install"; }
for f in lib/librbdgrad_client.so lib/librbdgrad_proto.so include/rbdgrad/client.hpp \
         include/rbdgrad/client_export.hpp lib/cmake/rbdgrad/rbdgradConfig.cmake \
         lib/cmake/rbdgrad/rbdgradConfigVersion.cmake; do
  [[ -e "$work/prefix/$f" ]] || fail "not installed: $f"
done
# the public headers name no gRPC or protobuf header
if grep -lE '#include <(grpc|google/protobuf)' "$work/prefix"/include/rbdgrad/*.hpp; then
  fail "a public header includes gRPC or protobuf"
fi

# a plain build: no ccache, no project flags; the consumer is one small file
cmake -S "$source_dir/tests/client/consumer" -B "$work/build" -DCMAKE_PREFIX_PATH="$work/prefix" \
  -DCMAKE_BUILD_TYPE=Release >"$work/configure.log" 2>&1 || { cat "$work/configure.log"; fail "configure"; }
cmake --build "$work/build" >"$work/build.log" 2>&1 || { cat "$work/build.log"; fail "build"; }

# the installed library finds librbdgrad_proto through its own RUNPATH ($ORIGIN/../lib)
if ldd "$work/prefix/lib/librbdgrad_client.so" | grep -q "not found"; then
  ldd "$work/prefix/lib/librbdgrad_client.so"; fail "unresolved libraries"
fi
# an address where nothing listens: a port bound and released
port=$(python3 -c 'import socket; s = socket.socket(); s.bind(("127.0.0.1", 0)); print(s.getsockname()[1])')
"$work/build/rbdgrad_consumer" "127.0.0.1:$port"
echo "PASS: consumer"
