#!/usr/bin/env bash
# Installs the dependencies, builds everything and runs the whole test suite; exits non-zero when a
# test fails. Extra arguments go to ctest, e.g. scripts/test.sh -R '^tools\.'
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."

./scripts/install-deps.sh
./scripts/build.sh
ctest --test-dir build --output-on-failure -j"$(nproc)" "$@"
