#!/usr/bin/env bash
# Installs the dependencies, builds the daemon and runs it in the foreground (Ctrl-C stops it).
#   scripts/run-daemon.sh [rbdgradd options]     default model: the embedded iiwa14
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."

./scripts/install-deps.sh
./scripts/build.sh rbdgradd
exec ./build/server/rbdgradd "$@"
