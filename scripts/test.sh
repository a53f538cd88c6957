#!/usr/bin/env bash
# Installs the dependencies, builds everything and runs the whole test suite, then the fuzzers for a
# short time; exits non-zero when a test or a fuzzer fails. Extra arguments go to ctest, e.g.
# scripts/test.sh -R '^tools\.'
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."

./scripts/install-deps.sh
./scripts/build.sh
ctest --test-dir build --output-on-failure -j"$(nproc)" "$@"
# then the short fuzz run (issue 9): each libFuzzer harness for RBDGRAD_FUZZ_SECONDS (default 20)
# in its own clang build, build-fuzz; skipped when ctest was given a subset or RBDGRAD_FUZZ_SECONDS=0
if [[ $# -eq 0 && ${RBDGRAD_FUZZ_SECONDS:-20} != 0 ]]; then
  ./scripts/fuzz.sh "${RBDGRAD_FUZZ_SECONDS:-20}"
fi
