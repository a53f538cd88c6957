#!/usr/bin/env bash
# The service benchmark of issue 3: rbdgradd against the same computation in-process and against a
# trivial gRPC echo of the same payload sizes (echo_server), over TCP and a Unix socket, unary and
# streaming, for N = 1, 16, 64, 128, 1024. Builds nothing: give it a build directory where
# rbdgradd, echo_server, service_load and the CPU plugin are built. Prints one Markdown table per
# transport and the verdict on the goal "added latency at N = 64 <= 1.3x the echo round trip".
#
#   bench/service/run_service_bench.sh BUILD_DIR [--quick] [--no-service] [--raw DIR]
#
#   --quick       a few requests per row (a smoke test, seconds; the numbers mean nothing)
#   --no-service  skip rbdgradd: only the echo floor and the in-process baseline
#   --raw DIR     keep every service_load output (TSV) and the servers' logs in DIR
# Environment: SERVICE_BENCH_ROUNDS (default 3: every measurement is repeated, rounds interleaved,
# and the tables show the median of the rounds' figures, which damps bursts of load from other
# processes), SERVICE_BENCH_REQUESTS (per row and round, default 1000), SERVICE_BENCH_DURATION_S
# (time cap per row and round, default 0.8), SERVICE_BENCH_CONCURRENCY (callers of the throughput run,
# default 4), SERVICE_BENCH_MODEL (default iiwa14), SERVICE_BENCH_N (default 1,16,64,128,1024),
# SERVICE_BENCH_IDLE_US (default 200: the in-process baseline is also measured with this idle time
# between requests, as a client's round trip leaves the daemon's workers idle).
set -euo pipefail

usage() { sed -n '2,18p' "$0" | sed 's/^# \{0,1\}//' >&2; exit 2; }

[[ $# -ge 1 ]] || usage
build=$(cd "$1" && pwd) || usage
shift
quick=0 with_service=1 raw=""
while [[ $# -gt 0 ]]; do
  case "$1" in
    --quick) quick=1 ;;
    --no-service) with_service=0 ;;
    --raw) [[ $# -ge 2 ]] || usage; raw=$2; shift ;;
    *) usage ;;
  esac
  shift
done

rounds=${SERVICE_BENCH_ROUNDS:-3}
requests=${SERVICE_BENCH_REQUESTS:-1000}
duration=${SERVICE_BENCH_DURATION_S:-0.8}
concurrency=${SERVICE_BENCH_CONCURRENCY:-4}
model=${SERVICE_BENCH_MODEL:-iiwa14}
sizes=${SERVICE_BENCH_N:-1,16,64,128,1024}
warmup=50
if [[ $quick == 1 ]]; then rounds=1 requests=20 duration=0.1 warmup=2; fi
idle_us=${SERVICE_BENCH_IDLE_US:-200}
goal=1.3
goal_n=64

daemon=$build/server/rbdgradd
echo_server=$build/bench/service/echo_server
load=$build/bench/service/service_load
for bin in "$echo_server" "$load" $([[ $with_service == 1 ]] && echo "$daemon"); do
  [[ -x $bin ]] || { echo "run_service_bench: $bin is not built" >&2; exit 1; }
done

work=$(mktemp -d /tmp/rbdgrad-service-bench-XXXXXX)
declare -A server_pid=()

# SIGTERM to each server we started, then wait for it; a non-zero exit is reported
stop_servers() {
  local name status=0
  for name in "${!server_pid[@]}"; do
    kill -TERM "${server_pid[$name]}" 2>/dev/null || true
    if ! wait "${server_pid[$name]}"; then
      echo "run_service_bench: $name did not exit cleanly; its log:" >&2
      cat "$work/$name.log" >&2
      status=1
    fi
    unset "server_pid[$name]"
  done
  return $status
}
cleanup() {
  stop_servers || true
  if [[ -n $raw ]]; then mkdir -p "$raw" && cp "$work"/*.tsv "$work"/*.log "$raw"/ 2>/dev/null || true; fi
  rm -rf "$work"
}
trap cleanup EXIT

# start NAME BINARY ARGS...: runs it with the listen flags in the background, waits for its ready file
start() {
  local name=$1 bin=$2
  shift 2
  "$bin" --listen 127.0.0.1:0 --unix-socket "$work/$name.sock" --ready-file "$work/$name.ready" "$@" \
    >"$work/$name.log" 2>&1 &
  server_pid[$name]=$!
  local waited=0
  until [[ -s $work/$name.ready ]]; do
    if ! kill -0 "${server_pid[$name]}" 2>/dev/null; then
      echo "run_service_bench: $name exited before it was ready; its log:" >&2
      cat "$work/$name.log" >&2
      unset "server_pid[$name]"
      exit 1
    fi
    if (( waited >= 300 )); then
      echo "run_service_bench: $name not ready after 30 s; its log:" >&2
      cat "$work/$name.log" >&2
      exit 1
    fi
    sleep 0.1
    waited=$((waited + 1))
  done
}
# address NAME tcp|unix: the gRPC target from NAME's ready file
address() {
  awk -v kind="$2" '$1 == kind { print (kind == "unix" ? "unix:" : "") $2 }' "$work/$1.ready"
}

# measure FILE ARGS...: one service_load run into FILE.r<round>.tsv; its own errors stop the script.
# ROW_REQUESTS=K before it overrides the request count.
measure() {
  local file=$1.r$round
  shift
  if ! "$load" --model "$model" --n "$sizes" --warmup "$warmup" --requests "${ROW_REQUESTS:-$requests}" --duration-s "$duration" \
      --tsv "$@" >"$work/$file.tsv" 2>"$work/$file.err"; then
    echo "run_service_bench: service_load $* failed:" >&2
    cat "$work/$file.err" >&2
    exit 1
  fi
}
# value FILE N COLUMN: one cell of FILE's service_load TSVs, the median over the rounds ("-" when
# there is none); with an even count the lower middle one, so it is always a measured figure
value() {
  local files=("$work/$1".r*.tsv)
  [[ -f ${files[0]} ]] || { echo "-"; return; }
  awk -F'\t' -v n="$2" -v col="$3" '
    FNR == 1 { header = 0 }
    /^#/ { next }
    !header { for (i = 1; i <= NF; ++i) idx[$i] = i; header = 1; next }
    $1 == n && $idx[col] != "-" { v[++count] = $idx[col] + 0; text[count] = $idx[col] }
    END {
      if (!count) { print "-"; exit }
      for (i = 1; i <= count; ++i) order[i] = i
      for (i = 2; i <= count; ++i)  # insertion sort of a handful of rounds
        for (j = i; j > 1 && v[order[j - 1]] > v[order[j]]; --j) { t = order[j]; order[j] = order[j - 1]; order[j - 1] = t }
      print text[order[int((count + 1) / 2)]]
    }' "${files[@]}"
}
# arith A OP B FORMAT: A OP B printed with FORMAT, "-" when either operand is "-"
arith() {
  [[ $1 == "-" || $3 == "-" ]] && { echo "-"; return; }
  awk -v a="$1" -v b="$3" -v op="$2" -v fmt="$4" 'BEGIN { printf fmt, (op == "-") ? a - b : a / b }'
}

start_time=$(date +%s)
[[ $with_service == 1 ]] && start rbdgradd "$daemon"
start echo "$echo_server"

for ((round = 1; round <= rounds; ++round)); do
  # the baseline: the daemon's computation in this process, with the daemon's default thread count
  measure in_process --service in-process
  # the same with the workers idle between requests, as they are in the daemon
  measure in_process_idle --service in-process --idle-us "$idle_us"
  for transport in tcp unix; do
    for mode in unary stream; do
      if [[ $with_service == 1 ]]; then
        target=$(address rbdgradd "$transport")
        [[ -n $target ]] || { echo "run_service_bench: rbdgradd's ready file names no $transport address" >&2; exit 1; }
        measure "service_${transport}_${mode}" --service dynamics --target "$target" --mode "$mode"
        ROW_REQUESTS=$((requests * 2)) measure "service_${transport}_${mode}_c${concurrency}" --service dynamics \
          --target "$target" --mode "$mode" --concurrency "$concurrency"
      fi
      measure "echo_${transport}_${mode}" --service echo --target "$(address echo "$transport")" --mode "$mode"
    done
  done
done
stop_servers
elapsed=$(( $(date +%s) - start_time ))

IFS=, read -r -a n_list <<<"$sizes"
verdicts=() idle_verdicts=()
echo "Model $model, outputs dqdd_dq,dqdd_dqd from tau, f64; p50/p99 with one caller; throughput with $concurrency callers."
echo "Every figure is the median of $rounds rounds (each: $requests requests or ${duration} s per row, $warmup warm-up calls per caller)."
echo "Latencies in µs. added = service p50 - in-process p50; added/echo: the goal is <= $goal at N = $goal_n."
for transport in tcp unix; do
  echo
  echo "### ${transport^^}"
  echo
  echo "| mode | N | p50 | p99 | req/s (1 caller) | states/s ($concurrency callers) | in-process p50 | echo p50 | echo p99 | added | added/echo |"
  echo "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|"
  for mode in unary stream; do
    s=service_${transport}_${mode} e=echo_${transport}_${mode}
    for n in "${n_list[@]}"; do
      p50=$(value "$s" "$n" p50_us) p99=$(value "$s" "$n" p99_us) rps=$(value "$s" "$n" req_per_s)
      sps=$(value "${s}_c${concurrency}" "$n" states_per_s)
      inproc=$(value in_process "$n" p50_us)
      ep50=$(value "$e" "$n" p50_us) ep99=$(value "$e" "$n" p99_us)
      added=$(arith "$p50" - "$inproc" %.1f)
      ratio=$(arith "$added" / "$ep50" %.2f)
      echo "| $mode | $n | $p50 | $p99 | $rps | $sps | $inproc | $ep50 | $ep99 | $added | $ratio |"
      if [[ $n == "$goal_n" ]]; then
        if [[ $ratio == "-" ]]; then
          verdicts+=("${transport^^} $mode, N = $n: not measured (no service run)")
        else
          # decided on the unrounded figures: 1.302 is not <= 1.3 even though it prints as 1.30
          met=$(awk -v a="$added" -v e="$ep50" -v g="$goal" 'BEGIN { print (a <= g * e) ? "met" : "not met" }')
          verdicts+=("${transport^^} $mode, N = $n: added $added µs / echo $ep50 µs = $(arith "$added" / "$ep50" %.3f)x, goal <= ${goal}x: **$met**")
          idle_p50=$(value in_process_idle "$n" p50_us)
          idle_added=$(arith "$p50" - "$idle_p50" %.1f)
          idle_verdicts+=("${transport^^} $mode, N = $n: service $p50 - in-process (idle) $idle_p50 = $idle_added µs, $(arith "$idle_added" / "$ep50" %.2f)x the echo")
        fi
      fi
    done
  done
done

for transport in tcp unix; do
  echo
  echo "### ${transport^^}: where the service's time goes (p50, µs)"
  echo
  echo "server: the timings rbdgradd reports in its responses (accepted -> response ready, of which queued and"
  echo "computing); outside the server: service p50 - server total p50 (transport, gRPC, client)."
  echo
  echo "| mode | N | service p50 | server total | server queue | server compute | in-process compute | in-process compute, idle ${idle_us} µs | outside the server | echo p50 |"
  echo "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|"
  for mode in unary stream; do
    s=service_${transport}_${mode}
    for n in "${n_list[@]}"; do
      p50=$(value "$s" "$n" p50_us) total=$(value "$s" "$n" server_total_p50_us)
      echo "| $mode | $n | $p50 | $total | $(value "$s" "$n" server_queue_p50_us) |" \
           "$(value "$s" "$n" server_compute_p50_us) | $(value in_process "$n" compute_p50_us) |" \
           "$(value in_process_idle "$n" compute_p50_us) |" \
           "$(arith "$p50" - "$total" %.1f) | $(value "echo_${transport}_${mode}" "$n" p50_us) |"
    done
  done
done

echo
echo "### In-process steps (p50, µs)"
echo
echo "| N | from_request | compute | to_response | total | total p99 | compute alone | compute alone p99 | protobuf marshal | total, idle ${idle_us} µs between requests |"
echo "|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|"
for n in "${n_list[@]}"; do
  echo "| $n | $(value in_process "$n" from_request_p50_us) | $(value in_process "$n" compute_p50_us) |" \
       "$(value in_process "$n" to_response_p50_us) | $(value in_process "$n" p50_us) | $(value in_process "$n" p99_us) |" \
       "$(value in_process "$n" compute_alone_p50_us) | $(value in_process "$n" compute_alone_p99_us) |" \
       "$(value in_process "$n" marshal_p50_us) | $(value in_process_idle "$n" p50_us) |"
done

echo
echo "### Goal at N = $goal_n"
echo
for v in "${verdicts[@]}"; do echo "- $v"; done
if [[ ${#idle_verdicts[@]} -gt 0 ]]; then
  echo
  echo "Against the in-process baseline with ${idle_us} µs idle between requests (for the analysis; not the goal's definition):"
  echo
  for v in "${idle_verdicts[@]}"; do echo "- $v"; done
fi
echo
echo "(run took ${elapsed} s)"
