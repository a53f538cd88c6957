#!/usr/bin/env bash
# The scheduler's load test (issue 6): K concurrent client streams send requests of N states, one
# in flight per stream as MPC loops do, to rbdgradd without and with dynamic batching
# (limits.max_queue_delay_us). Every response is checked against the same computation in-process
# (service_load --reference), so a lost, misrouted or duplicated response fails the run. Prints a
# Markdown table: throughput, latency percentiles, and how many requests shared a backend call
# (from the daemon's /metrics). Builds nothing: give it a build directory with rbdgradd,
# service_load and the plugins.
#
#   bench/service/run_scheduler_load.sh BUILD_DIR [DELAY_US ...]    (default delays: 0 50 200)
#
# Environment: LOAD_STREAMS (default 64), LOAD_N (16), LOAD_REQUESTS (20000 per delay),
# LOAD_DURATION_S (5: time cap per delay), LOAD_MODEL (iiwa14), LOAD_PRECISION (f64),
# LOAD_PREFERRED (256: scheduler.preferred_batch_states), LOAD_TOL (tolerance of the check against
# the in-process CPU result: 1e-9 in f64, none (not checked) otherwise).
set -euo pipefail

usage() { sed -n '2,17p' "$0" | sed 's/^# \{0,1\}//' >&2; exit 2; }
[[ $# -ge 1 ]] || usage
build=$(cd "$1" && pwd) || usage
shift
delays=("$@")
[[ ${#delays[@]} -gt 0 ]] || delays=(0 50 200)
streams=${LOAD_STREAMS:-64}
n=${LOAD_N:-16}
requests=${LOAD_REQUESTS:-20000}
duration=${LOAD_DURATION_S:-5}
model=${LOAD_MODEL:-iiwa14}
precision=${LOAD_PRECISION:-f64}
preferred=${LOAD_PREFERRED:-256}
# the reference is the CPU plugin in-process, compared element by element (relative to
# max(1, |element|)): in f64 every backend agrees to 1e-9; in f32 two backends' roundings differ by
# up to 0.07 in an element of iiwa14's d qdd/d q (its entries reach hundreds), so f32 runs are not
# checked (LOAD_TOL=none) and only count the responses
tol=${LOAD_TOL:-$([[ $precision == f64 ]] && echo 1e-9 || echo none)}
check=(--tol "$tol")
[[ $tol == none ]] && check=(--no-reference)
daemon=$build/server/rbdgradd
load=$build/bench/service/service_load
for bin in "$daemon" "$load"; do [[ -x $bin ]] || { echo "run_scheduler_load: $bin is not built" >&2; exit 1; }; done

work=$(mktemp -d /tmp/rbdgrad-scheduler-load-XXXXXX)
pid=""
cleanup() {
  [[ -n $pid ]] && kill -TERM "$pid" 2>/dev/null && wait "$pid" 2>/dev/null || true
  rm -rf "$work"
}
trap cleanup EXIT

echo "rbdgradd under $streams streams of $model N = $n ($precision), $(nproc) cores, $(date -u +%Y-%m-%dT%H:%M:%SZ)"
echo
echo "| max_queue_delay_us | requests | req/s | states/s | p50 µs | p99 µs | max µs | requests per backend call | backends |"
echo "|---:|---:|---:|---:|---:|---:|---:|---:|---|"
for delay in "${delays[@]}"; do
  cat >"$work/config.yaml" <<YAML
models: [{name: $model, embedded: $model}]
limits: {max_queue_delay_us: $delay}
scheduler: {preferred_batch_states: $preferred}
metrics: {listen: "127.0.0.1:0"}
log_level: info
YAML
  rm -f "$work/ready"
  "$daemon" --config "$work/config.yaml" --listen 127.0.0.1:0 --unix-socket "" --ready-file "$work/ready" \
    >"$work/daemon.log" 2>&1 &
  pid=$!
  for _ in $(seq 600); do [[ -s $work/ready ]] && break; kill -0 "$pid" 2>/dev/null || break; sleep 0.1; done
  [[ -s $work/ready ]] || { echo "run_scheduler_load: rbdgradd did not start:" >&2; cat "$work/daemon.log" >&2; exit 1; }
  target=$(awk '$1 == "tcp" { print $2; exit }' "$work/ready")
  metrics=$(grep -o 'metrics: http://[0-9.:]*/metrics' "$work/daemon.log" | head -1 | sed 's/metrics: //')
  if ! "$load" --service dynamics --target "$target" --mode stream --concurrency "$streams" --model "$model" \
      --n "$n" --precision "$precision" --warmup 20 --requests "$requests" --duration-s "$duration" --tsv \
      --plugin "$build/plugins/cpu/librbdgrad_cpu.so" "${check[@]}" \
      >"$work/load.tsv" 2>"$work/load.err"; then
    echo "run_scheduler_load: service_load failed (delay $delay us):" >&2
    cat "$work/load.err" >&2
    exit 1
  fi
  # requests and backend calls from the daemon's counters: sum of rbdgrad_requests_total (ok) and
  # of rbdgrad_batch_states_count; which backends served
  read -r answered calls backends < <(python3 - "$metrics" <<'PY'
import sys, urllib.request
text = urllib.request.urlopen(sys.argv[1]).read().decode()
answered = calls = 0.0
backends = set()
for line in text.splitlines():
    if line.startswith("rbdgrad_requests_total{") and 'code="ok"' in line:
        answered += float(line.rsplit(" ", 1)[1])
        backends.add(line.split('backend="', 1)[1].split('"', 1)[0])
    elif line.startswith("rbdgrad_batch_states_count{"):
        calls += float(line.rsplit(" ", 1)[1])
print(int(answered), int(calls), ",".join(sorted(backends)) or "-")
PY
)
  awk -F'\t' -v delay="$delay" -v answered="$answered" -v calls="$calls" -v backends="$backends" '
    /^#/ { next }
    !header { for (i = 1; i <= NF; ++i) idx[$i] = i; header = 1; next }
    { printf "| %s | %s | %.0f | %.0f | %s | %s | %s | %.2f | %s |\n", delay, $idx["count"], $idx["req_per_s"],
        $idx["states_per_s"], $idx["p50_us"], $idx["p99_us"], $idx["max_us"], (calls > 0 ? answered / calls : 0), backends }
  ' "$work/load.tsv"
  kill -TERM "$pid"; wait "$pid" || { echo "run_scheduler_load: rbdgradd exited non-zero" >&2; exit 1; }
  pid=""
done
echo
[[ $tol == none ]] && echo "The responses were counted, not checked (LOAD_TOL=none)." ||
  echo "Every response was checked against the in-process computation (service_load --reference, tolerance $tol);"
echo "requests per backend call counts warm-up and measured requests alike."
