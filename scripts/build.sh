#!/usr/bin/env bash
# Configures and builds rbdgrad (Release) into ./build, one job per core.
#   scripts/build.sh [TARGET...]     e.g. scripts/build.sh rbdgradd; everything when none is given
# Extra CMake options can be passed through RBDGRAD_CMAKE_ARGS, e.g. RBDGRAD_CMAKE_ARGS=-DRBDGRAD_NATIVE=OFF.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."

# shellcheck disable=SC2086  # RBDGRAD_CMAKE_ARGS is a list of options
cmake -S . -B build -DCMAKE_BUILD_TYPE=Release ${RBDGRAD_CMAKE_ARGS:-}
targets=()
for t in "$@"; do targets+=(--target "$t"); done
cmake --build build --parallel "$(nproc)" "${targets[@]}"
