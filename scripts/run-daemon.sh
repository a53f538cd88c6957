#!/usr/bin/env bash
# Installs the dependencies, builds the daemon (and the rbdgrad CLI that calls it) and runs the daemon
# in the foreground (Ctrl-C or SIGTERM stops it gracefully).
#   scripts/run-daemon.sh [rbdgradd options]     default model: the embedded iiwa14
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."

./scripts/install-deps.sh
./scripts/build.sh rbdgradd rbdgrad_cpu rbdgrad   # the daemon, its CPU backend and the CLI to call it
exec ./build/server/rbdgradd "$@"
