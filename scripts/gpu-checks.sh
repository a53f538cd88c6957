#!/usr/bin/env bash
# Runs the CUDA plugin's checks on a lent GPU machine from the bundle scripts/gpu-bundle.sh made
# (carried as build-gpu-bundle/, the repository's working tree around it): the GPU tests, the
# daemon's results through the plugin (`rbdgrad compute --backend cuda` on the reference states of
# iiwa14 and talos_reduced, f64 and f32, against the reference), compute-sanitizer's memcheck and
# racecheck on the tests given, the benchmarks given, and the earlier commits' default kernel
# against this one's where the bundle has them (their kernel_us medians printed). Prints each step's
# last lines; its logs and the benchmarks' JSON go to $OUT/gpu-checks.tgz (one file: the device
# tool brings back 8 at most; $OUT defaults to ./gpu-checks-out). A step that fails is said so and
# the next one still runs; the exit status is 1 if any failed.
#
#   bash build-gpu-bundle/gpu-checks.sh [SANITIZER_TEST_FILTER [BENCHMARK_FILTER]]
#
# SANITIZER_TEST_FILTER: a --gtest_filter for plugin_cuda_specialized_kernel_tests under both tools
# (default: the lean and compact builds' tests); BENCHMARK_FILTER: a --benchmark_filter for cuda_batch_bench ('' skips
# it; default: the talos_reduced kernels' comparisons and iiwa14's waves, docs/benchmarks/cuda.md).
# SANITIZER_OPTIONS: more options for compute-sanitizer; default '--launch-count 40': the first 40
# kernel launches checked (the lean build's 128-thread shape first), the rest run unchecked, at
# speed (racecheck on every launch of the lean build's test ran past 4 minutes in run 138; with
# 40, both tests took 44 s in run 133); '' checks them all. STEPS: which of "tests daemon
# sanitizers bench revs" to run (default all), so that a run can fit the device tool's 10 minutes;
# "profile" (only when named) runs Nsight Compute (--set full) on one launch of the kernels named
# by PROFILE_KERNEL (default the block kernel) in the benchmark PROFILE_BENCH, its NVRTC programs
# built with source lines (RBDGRAD_CUDA_LINEINFO): its details and per-source-line pages as text
# in the logs, summed by source line and by pass (scripts/ncu_source_summary.py, per state of
# PROFILE_STATES),
# the report itself beside gpu-checks.tgz (profile.ncu-rep, if it fits the tool). "occupancy"
# (only when named) runs Nsight Compute's launch and occupancy sections alone on that launch: the
# blocks an SM holds and what limits them, in seconds where the full set takes minutes.
set -uo pipefail
here=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
repo=$(cd "$here/.." && pwd)
result=${OUT:-$repo/gpu-checks-out}
out=$(mktemp -d)
mkdir -p "$result"
export LD_LIBRARY_PATH="$here/lib${LD_LIBRARY_PATH:+:$LD_LIBRARY_PATH}"
sanitize=${1:-'*LeanKernel*:*CompactKernel*'}
bench=${2-'cuda_pipeline/1chunks(-dense|-full|-96|-192|-256|-walkcolumns)?/pinned/f(32|64)/talos_reduced/N65536|cuda_compact/|cuda_waves/'}
failed=0
step() {  # step NAME COMMAND...: runs it, its output in $out/NAME.log, its last lines here
  local name=$1 status=0
  shift
  echo "== $name: $*"
  "$@" >"$out/$name.log" 2>&1 || status=$?
  tail -n 3 "$out/$name.log" | sed 's/^/   /'
  if [[ $status -eq 0 ]]; then
    echo "   ok"
  else
    echo "   FAILED (exit $status)"
    failed=1
  fi
  # after every step, so that a run cut off by the device tool's time limit still brings back
  # the steps it finished
  tar czf "$result/gpu-checks.tgz" -C "$out" .
}
sanitizer=$(command -v compute-sanitizer || echo /usr/local/cuda/bin/compute-sanitizer)
read -r -a sanitizer_options <<<"${SANITIZER_OPTIONS---launch-count 40}"

# the test programs read the reference data under the source tree's path of the build, and load
# the plugin from the build's path
source_dir=$(cat "$here/source_dir")
if [[ ! -e "$source_dir/tests/data" ]]; then
  mkdir -p "$(dirname "$source_dir")"
  ln -s "$repo" "$source_dir"
fi
plugin=$(cat "$here/plugin_path")
if [[ ! -e "$plugin" ]]; then
  mkdir -p "$(dirname "$plugin")"
  ln -s "$here/lib/librbdgrad_cuda.so" "$plugin"
fi
echo "bundle of $(tr '\n' ' ' <"$here/commit"), on $(nvidia-smi -L 2>/dev/null | head -n 1), $(date -u +%FT%TZ)" |
  tee "$out/about.txt"

steps=" ${STEPS:-tests daemon sanitizers bench revs} "
if [[ $steps == *" tests "* ]]; then
  step tests "$here/bin/plugin_cuda_tests"
  step specialized "$here/bin/plugin_cuda_specialized_kernel_tests"
  step choice "$here/bin/plugin_cuda_kernel_choice_tests"
fi

# daemon_compute ROBOT PRECISION TOL [compare_results.py options]: the daemon with the bundle's CUDA
# plugin serving ROBOT; `rbdgrad compute --backend cuda` on its reference states, for the gradient
# outputs (the warp and block kernels' request) and for every output (the one-thread kernel's),
# whose results must match the reference within TOL (relative Frobenius error, compare_results.py)
daemon_compute() {
  local robot=$1 precision=$2 tol=$3 work status=0
  shift 3
  work=$(mktemp -d)
  printf 'plugins:\n  - path: %s\n' "$here/lib/librbdgrad_cuda.so" >"$work/config.yaml"
  "$here/bin/rbdgradd" --config "$work/config.yaml" --model "$robot" --listen 127.0.0.1:0 --unix-socket "" \
    --ready-file "$work/ready" >"$work/daemon.log" 2>&1 &
  local pid=$!
  for _ in $(seq 600); do
    [[ -s "$work/ready" ]] && break
    kill -0 "$pid" 2>/dev/null || break
    sleep 0.1
  done
  local server
  server=$(awk '$1 == "tcp" { print $2; exit }' "$work/ready" 2>/dev/null || true)
  if [[ -z "$server" ]]; then
    echo "rbdgradd did not start:"
    cat "$work/daemon.log"
    kill "$pid" 2>/dev/null
    return 1
  fi
  grep -F "cuda" "$work/daemon.log" | head -n 5
  local outputs
  for outputs in qdd,Minv,dqdd_dq,dqdd_dqd qdd,M,Minv,dqdd_dq,dqdd_dqd,tau_id,dtau_dq,dtau_dqd; do
    echo "-- outputs $outputs"
    "$here/bin/rbdgrad" compute --server "$server" --model "$robot" --backend cuda --precision "$precision" \
      --output-type "$precision" --outputs "$outputs" --in "$repo/tests/data/reference/$robot.jsonl" \
      --out "$work/out.jsonl" | tee "$work/compute.txt" || status=1
    grep -q "^backend cuda," "$work/compute.txt" || { echo "not computed by the cuda backend"; status=1; }
    python3 "$repo/tests/tools/compare_results.py" "$work/out.jsonl" "$repo/tests/data/reference/$robot.jsonl" \
      --tol "$tol" --precision "$precision" --outputs "$outputs" "$@" || status=1
  done
  kill -TERM "$pid"
  wait "$pid" || status=1
  return "$status"
}
if [[ $steps == *" daemon "* ]]; then
  for robot in iiwa14 talos_reduced; do
    step "daemon-$robot-f64" daemon_compute "$robot" f64 1e-10
    step "daemon-$robot-f32" daemon_compute "$robot" f32 1e-3 --median-tol 1e-4
  done
fi
if [[ $steps == *" sanitizers "* ]]; then
  step memcheck "$sanitizer" --tool memcheck --error-exitcode 1 "${sanitizer_options[@]}" \
    "$here/bin/plugin_cuda_specialized_kernel_tests" --gtest_filter="$sanitize"
  step racecheck "$sanitizer" --tool racecheck --error-exitcode 1 "${sanitizer_options[@]}" \
    "$here/bin/plugin_cuda_specialized_kernel_tests" --gtest_filter="$sanitize"
fi
if [[ $steps == *" bench "* && -n "$bench" ]]; then
  step bench "$here/bin/cuda_batch_bench" --benchmark_min_time=0.05 --benchmark_filter="$bench" \
    --benchmark_out="$out/bench.json" --benchmark_out_format=json
fi
# earlier commits' benchmark (gpu-bundle.sh REV): the default kernel alone at 65536 talos_reduced
# states (and with M^-1's columns the other way, where the commit has that case: -columns by the
# tree's blocks before they were the default, -walkcolumns a thread a column since), this bundle's
# again after each, so that a drift of the machine shows
kernel_alone='cuda_pipeline/1chunks(-columns|-walkcolumns)?/pinned/f(32|64)/talos_reduced/N65536/'
# the kernel's own time (the kernel_us counter, CUDA events) of each median in a benchmark log:
# the real_time column is end to end, mostly copies
kernel_medians() {
  awk '/_median/ { k = "?"; for (i = 1; i <= NF; i++) if ($i ~ /^kernel_us=/) k = substr($i, 11); print "   ", $1, "kernel_us", k }' "$1"
}
for old in "$here"/bin/cuda_batch_bench-*; do
  [[ $steps == *" revs "* && -e "$old" ]] || continue
  rev=${old##*-}
  step "bench-$rev" "$old" --benchmark_min_time=0.05 --benchmark_filter="$kernel_alone" \
    --benchmark_out="$out/bench-$rev.json" --benchmark_out_format=json
  step "bench-after-$rev" "$here/bin/cuda_batch_bench" --benchmark_min_time=0.05 \
    --benchmark_filter="$kernel_alone" --benchmark_out="$out/bench-after-$rev.json" --benchmark_out_format=json
  echo "== kernel alone: $rev, then this bundle's ($(tr '\n' ' ' <"$here/commit"))"
  kernel_medians "$out/bench-$rev.log"
  kernel_medians "$out/bench-after-$rev.log"
done
ncu=$(command -v ncu || echo /usr/local/cuda/bin/ncu)
profile_bench=${PROFILE_BENCH:-cuda_pipeline/1chunks/pinned/f64/talos_reduced/N65536/}
if [[ $steps == *" occupancy "* ]]; then
  # the launch after the benchmark's first (which sizes the buffers), as profile's
  step occupancy "$ncu" --section LaunchStats --section Occupancy -k "regex:${PROFILE_KERNEL:-block_fused}" \
    --launch-skip 1 --launch-count 1 "$here/bin/cuda_batch_bench" --benchmark_min_time=0.01 \
    --benchmark_filter="$profile_bench"
fi
if [[ $steps == *" profile "* ]]; then
  # the launch after the benchmark's first (which sizes the buffers); the embedded headers' names
  # found under the source tree's device folder
  RBDGRAD_CUDA_LINEINFO=1 step profile "$ncu" --set full --import-source yes \
    --source-folders "$repo/plugins/cuda/device" -k "regex:${PROFILE_KERNEL:-block_fused}" --launch-skip 1 \
    --launch-count 1 -f -o "$result/profile" "$here/bin/cuda_batch_bench" --benchmark_min_time=0.01 \
    --benchmark_filter="$profile_bench"
  step profile-details "$ncu" -i "$result/profile.ncu-rep" --page details --print-units base
  step profile-source "$ncu" -i "$result/profile.ncu-rep" --page source --csv --print-source cuda,sass
  # by source line: the most stalls, and the most shared-memory wavefronts over their ideal; and
  # by pass (the SASS between barriers)
  for by in stall excess pass; do
    step "profile-lines-$by" python3 "$repo/scripts/ncu_source_summary.py" "$out/profile-source.log" \
      --states "${PROFILE_STATES:-65536}" --by "$by" --top 40
  done
fi
tar czf "$result/gpu-checks.tgz" -C "$out" .
exit "$failed"
