#!/usr/bin/env bash
# Builds the libFuzzer harnesses of fuzz/ (clang, AddressSanitizer + UndefinedBehaviorSanitizer, in
# a build of their own) and runs each for a bounded time on a copy of its seed corpus. Exits
# non-zero when a fuzzer finds a crash, leak, timeout, out-of-memory or sanitizer report, and
# prints the reproducer and the command that replays it. docs/fuzzing.md has the details.
#   scripts/fuzz.sh [SECONDS_PER_FUZZER]     default 30; scripts/test.sh (CI) runs it after ctest
# Environment:
#   RBDGRAD_FUZZ_BUILD_DIR   the clang build (default build-fuzz)
#   RBDGRAD_FUZZ_OUT         each fuzzer's corpus, log and reproducers (default <build dir>/runs)
#   RBDGRAD_FUZZERS          which to run (default "config urdf request")
#   RBDGRAD_FUZZ_KEEP_CORPUS 1: go on from the corpus of the previous run (a longer campaign)
#                            instead of starting again from the seeds
#   RBDGRAD_FUZZ_ARGS        more libFuzzer flags, e.g. "-seed=1" or "-jobs=4 -workers=4"
#   RBDGRAD_FUZZ_BUILD_JOBS  parallel build jobs (default: one per core)
#   RBDGRAD_FUZZ_RSS_LIMIT_MB  memory limit of a fuzzer process (default 2048; ASan's quarantine and
#                            caches take several hundred MiB of it)
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."

seconds=${1:-30}
if ! [[ $seconds =~ ^[1-9][0-9]*$ ]]; then
  echo "usage: scripts/fuzz.sh [SECONDS_PER_FUZZER]" >&2
  exit 2
fi
build=${RBDGRAD_FUZZ_BUILD_DIR:-build-fuzz}
out=${RBDGRAD_FUZZ_OUT:-$build/runs}
read -r -a fuzzers <<< "${RBDGRAD_FUZZERS:-config urdf request}"
read -r -a extra_args <<< "${RBDGRAD_FUZZ_ARGS:-}"
# one input may take this long (ASan and UBSan slow everything several times); then it is a hang
timeout_s=10
rss_limit_mb=${RBDGRAD_FUZZ_RSS_LIMIT_MB:-2048}

for tool in clang clang++; do
  if ! command -v "$tool" >/dev/null; then
    echo "fuzz: $tool not found; scripts/install-deps.sh installs it (clang, libclang-rt-14-dev)" >&2
    exit 1
  fi
done

start=$SECONDS
# only the harnesses and the libraries they link: no tests, benchmarks, daemon or plugins
if [[ ! -f $build/CMakeCache.txt ]]; then
  mkdir -p "$build"
  CC=clang CXX=clang++ cmake -S . -B "$build" -DRBDGRAD_FUZZ=ON -DRBDGRAD_BUILD_TESTS=OFF \
    -DRBDGRAD_BUILD_BENCH=OFF -DCMAKE_BUILD_TYPE=RelWithDebInfo \
    "-DCMAKE_CXX_FLAGS_RELWITHDEBINFO=-O1 -gline-tables-only" >"$build/configure.log" 2>&1 ||
    { cat "$build/configure.log" >&2; exit 1; }
fi
cmake --build "$build" --parallel "${RBDGRAD_FUZZ_BUILD_JOBS:-$(nproc)}" --target fuzzers
echo "fuzz: built in $((SECONDS - start)) s"

# the reports: a symbolized stack, UBSan fatal, LSan without urdfdom's own leak (fuzz/lsan.supp)
symbolizer=$(command -v llvm-symbolizer-14 || command -v llvm-symbolizer || true)
[[ -n $symbolizer ]] && export ASAN_SYMBOLIZER_PATH=$symbolizer
export ASAN_OPTIONS=${ASAN_OPTIONS:+$ASAN_OPTIONS:}detect_leaks=1
export UBSAN_OPTIONS=${UBSAN_OPTIONS:+$UBSAN_OPTIONS:}print_stacktrace=1:halt_on_error=1
export LSAN_OPTIONS=${LSAN_OPTIONS:+$LSAN_OPTIONS:}suppressions=$PWD/fuzz/lsan.supp:print_suppressions=0

failed=()
for name in "${fuzzers[@]}"; do
  bin=$build/fuzz/${name}_fuzzer
  [[ -x $bin ]] || { echo "fuzz: no fuzzer '$name' ($bin)" >&2; exit 2; }
  dir=$out/$name
  corpus=$dir/corpus
  artifacts=$dir/artifacts
  log=$dir/fuzz.log
  # a copy of the seeds, so that the repository is never written: the committed seeds, plus the
  # shipped configurations and robots as they are now, plus the requests the build generated
  if [[ ${RBDGRAD_FUZZ_KEEP_CORPUS:-0} != 1 || ! -d $corpus ]]; then
    rm -rf "$corpus"
    mkdir -p "$corpus"
    cp fuzz/corpus/"$name"/* "$corpus"/ 2>/dev/null || true
    case $name in
      config)
        cp configs/*.yaml "$corpus"/
        if [[ -f deploy/systemd/rbdgradd.yaml ]]; then cp deploy/systemd/rbdgradd.yaml "$corpus"/deploy.yaml; fi ;;
      urdf) cp robots/*.urdf "$corpus"/ ;;
      request) cp "$build"/fuzz/request_seeds/*.pb "$corpus"/ ;;
    esac
  fi
  rm -rf "$artifacts"
  mkdir -p "$artifacts"
  args=(-max_total_time="$seconds" -timeout="$timeout_s" -rss_limit_mb="$rss_limit_mb"
        -artifact_prefix="$artifacts/" -print_final_stats=1)
  [[ -f fuzz/$name.dict ]] && args+=(-dict="fuzz/$name.dict")
  t0=$SECONDS
  rc=0
  "$bin" "${args[@]}" "${extra_args[@]}" "$corpus" >"$log" 2>&1 || rc=$?
  # slow-unit-* are reports, not failures; anything else there is a reproducer
  mapfile -t found < <(find "$artifacts" -type f ! -name 'slow-unit-*' | sort)
  stats=$(grep -E '^#[0-9]+' "$log" | tail -1)  # libFuzzer's last status: runs, coverage, corpus, exec/s
  if [[ $rc -ne 0 || ${#found[@]} -gt 0 ]]; then
    failed+=("$name")
    # the report from its first line (sanitizer, libFuzzer's crash, timeout or OOM), else the log's end
    first=$(grep -n -m1 -E '==[0-9]+==ERROR|runtime error:|ERROR: libFuzzer|ALARM: working' "$log" | cut -d: -f1 || true)
    echo "fuzz: $name FAILED (exit $rc) after $((SECONDS - t0)) s; from $log:"
    if [[ -n $first ]]; then tail -n +"$first" "$log" | head -n 150; else tail -n 60 "$log"; fi | sed 's/^/  | /'
    for f in "${found[@]}"; do
      echo "fuzz: $name reproducer: $f"
      echo "fuzz:   replay: RBDGRAD_FUZZ_VERBOSE=1 LSAN_OPTIONS=$LSAN_OPTIONS $bin $f"
    done
  else
    echo "fuzz: $name ok in $((SECONDS - t0)) s: $stats"
  fi
done

echo "fuzz: done in $((SECONDS - start)) s (${seconds} s per fuzzer)"
if [[ ${#failed[@]} -gt 0 ]]; then
  echo "fuzz: FAILED: ${failed[*]} (logs and reproducers under $out)" >&2
  exit 1
fi
