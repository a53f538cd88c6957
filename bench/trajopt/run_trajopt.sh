#!/usr/bin/env bash
# The trajectory optimization of issue 7 through a real daemon: starts BUILD_DIR's rbdgradd on a
# free loopback port with iiwa14, the CPU backend, the FPGA backend in C simulation (csim) and the
# CUDA backend when they are built (without a GPU the latter reports itself unavailable and is
# skipped), runs trajopt_bench over every backend and precision the daemon offers and over the
# FPGA kernel's fixed-point formats in-process, and writes trajopt.csv, trajopt.md, the progress
# log and the daemon's log into OUT_DIR. Builds nothing.
#
#   bench/trajopt/run_trajopt.sh BUILD_DIR [OUT_DIR] [trajopt_bench options ...]
#
# OUT_DIR defaults to BUILD_DIR/bench/trajopt/results. Options after it go to trajopt_bench, e.g.
# --quick (a smoke test) or --runs cpu:f64,fpga:fixed,kernel:Q12.20 (trajopt_bench --help lists
# them). Exit status: trajopt_bench's (0: every run computed, and every f64 and f32 run reached the
# goal; fixed point is reported, not required), 1 when the daemon does not start or exits non-zero,
# 2 usage error.
set -euo pipefail

usage() { sed -n '2,15p' "$0" | sed 's/^# \{0,1\}//' >&2; exit 2; }
[[ $# -ge 1 ]] || usage
build=$(cd "$1" && pwd) || usage
shift
out=$build/bench/trajopt/results
if [[ $# -gt 0 && $1 != --* ]]; then out=$1; shift; fi
mkdir -p "$out"
out=$(cd "$out" && pwd)

daemon=$build/server/rbdgradd
tool=$build/bench/trajopt/trajopt_bench
for bin in "$daemon" "$tool"; do [[ -x $bin ]] || { echo "run_trajopt: $bin is not built" >&2; exit 1; }; done
fpga=$build/plugins/fpga/librbdgrad_fpga.so
cuda=$build/plugins/cuda/librbdgrad_cuda.so

work=$(mktemp -d /tmp/rbdgrad-trajopt-XXXXXX)
pid=""
cleanup() {
  [[ -n $pid ]] && kill -TERM "$pid" 2>/dev/null && wait "$pid" 2>/dev/null || true
  rm -rf "$work"
}
trap cleanup EXIT

# the CPU plugin is loaded by default; calibration off: routing does not matter (every request
# names its backend), and it would cost seconds at start-up
{
  echo "models: [{name: iiwa14, embedded: iiwa14}]"
  echo "plugins:"
  [[ -f $fpga ]] && printf '  - path: %s\n    options: {emulation: csim}\n' "$fpga"
  [[ -f $cuda ]] && printf '  - path: %s\n' "$cuda"
  [[ -f $fpga || -f $cuda ]] || echo "  []"
  echo 'scheduler: {calibrate: "off"}'
  echo "log_level: info"
} >"$work/config.yaml"
cp "$work/config.yaml" "$out/daemon.yaml"

"$daemon" --config "$work/config.yaml" --listen 127.0.0.1:0 --unix-socket "" --ready-file "$work/ready" \
  >"$out/daemon.log" 2>&1 &
pid=$!
for _ in $(seq 600); do [[ -s $work/ready ]] && break; kill -0 "$pid" 2>/dev/null || break; sleep 0.1; done
[[ -s $work/ready ]] || { echo "run_trajopt: rbdgradd did not start:" >&2; cat "$out/daemon.log" >&2; exit 1; }
target=$(awk '$1 == "tcp" { print $2; exit }' "$work/ready")

echo "trajopt on rbdgradd at $target, $(nproc) cores, $(date -u +%Y-%m-%dT%H:%M:%SZ)" >&2
status=0
"$tool" --server "$target" --csv "$out/trajopt.csv" --markdown "$out/trajopt.md" "$@" \
  2> >(tee "$out/progress.log" >&2) || status=$?

kill -TERM "$pid"
daemon_status=0
wait "$pid" || daemon_status=$?
pid=""
if [[ $daemon_status != 0 ]]; then
  echo "run_trajopt: rbdgradd exited with status $daemon_status (log: $out/daemon.log)" >&2
  [[ $status != 0 ]] || status=1
fi
[[ $status == 0 ]] || echo "run_trajopt: trajopt_bench failed (status $status); see $out/progress.log" >&2
echo "run_trajopt: results in $out (trajopt.md, trajopt.csv)" >&2
exit "$status"
