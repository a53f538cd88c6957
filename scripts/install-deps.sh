#!/usr/bin/env bash
# Installs the Debian 12 packages rbdgrad needs to build and test. Idempotent: when every package is
# already installed it changes nothing (and needs no network). Uses sudo only when not root.
set -euo pipefail

packages=(
  build-essential cmake          # compiler, make, CMake >= 3.25
  libeigen3-dev                  # linear algebra (core)
  liburdfdom-dev liburdfdom-headers-dev libconsole-bridge-dev  # URDF parsing (core)
  nlohmann-json3-dev             # JSON Lines state files (io, CLI)
  libspdlog-dev                  # daemon logs (server)
  libprotobuf-dev protobuf-compiler libgrpc++-dev protobuf-compiler-grpc  # service API (proto/)
  libyaml-cpp-dev                # daemon configuration (coming with the service)
  prometheus-cpp-dev             # the daemon's /metrics endpoint (Prometheus text format over HTTP)
  libgtest-dev libgmock-dev      # unit tests
  clang libclang-rt-14-dev llvm-14  # fuzzers (scripts/fuzz.sh): clang, libFuzzer and the sanitizers, llvm-symbolizer
  libbenchmark-dev               # microbenchmarks (bench)
  libxrt-dev                     # FPGA backend: XRT host API (plugins/fpga)
  python3                        # CLI tests compare result files (stdlib only)
  python3-yaml                   # tests/deploy: the deployment files' cross-checks read YAML
  openssl                        # the TLS tests make their certificates at test time
  python3-matplotlib             # the accuracy benchmark's plots (bench/accuracy/plot_accuracy.py)
)

missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [[ ${#missing[@]} -eq 0 ]]; then
  echo "install-deps: all ${#packages[@]} packages already installed"
  exit 0
fi

if [[ $(id -u) -eq 0 ]]; then
  sudo=()
elif command -v sudo >/dev/null; then
  sudo=(sudo)
else
  echo "install-deps: not root and no sudo; install as root: apt-get install ${missing[*]}" >&2
  exit 1
fi
echo "install-deps: installing ${missing[*]}"
export DEBIAN_FRONTEND=noninteractive
"${sudo[@]}" apt-get update
"${sudo[@]}" apt-get install -y --no-install-recommends "${missing[@]}"
