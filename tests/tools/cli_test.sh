#!/usr/bin/env bash
# Tests for tools/cli (the rbdgrad CLI) and server/main.cpp (rbdgradd), run by CTest:
#   cli_test.sh CASE [ARGS...]
# with RBDGRAD, RBDGRADD (built binaries), PYTHON and SOURCE_DIR in the environment.
set -euo pipefail

: "${RBDGRAD:?}" "${RBDGRADD:?}" "${PYTHON:?}" "${SOURCE_DIR:?}"
HERE="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
REFERENCE_DIR="$SOURCE_DIR/tests/data/reference"
WORK="$(mktemp -d "${TMPDIR:-/tmp}/rbdgrad-cli-test.XXXXXX")"
DAEMON_PID=""
cleanup() {
  if [[ -n "$DAEMON_PID" ]]; then kill -KILL "$DAEMON_PID" 2>/dev/null || true; fi
  rm -rf "$WORK"
}
trap cleanup EXIT

fail() { echo "FAIL: $*" >&2; exit 1; }

# expect_exit CODE CMD...: runs CMD (stdout/stderr to $WORK/stdout, $WORK/stderr) and checks its exit code
expect_exit() {
  local want=$1; shift
  local got=0
  "$@" >"$WORK/stdout" 2>"$WORK/stderr" || got=$?
  if [[ $got -ne $want ]]; then
    echo "--- stdout"; cat "$WORK/stdout"; echo "--- stderr"; cat "$WORK/stderr"
    fail "exit code $got, expected $want: $*"
  fi
}

# expect_in FILE TEXT: FILE contains TEXT (fixed string)
expect_in() {
  grep -qF -- "$2" "$1" || { echo "--- $1"; cat "$1"; fail "'$2' not found in $(basename "$1")"; }
}

# a copy of the first N reference states of ROBOT, edited by a Python snippet working on `states`
make_states() {
  local robot=$1 n=$2 edit=$3 out=$4
  "$PYTHON" - "$REFERENCE_DIR/$robot.jsonl" "$n" "$out" <<PY
import json, sys
lines = [json.loads(l) for l in open(sys.argv[1]) if l.strip()]
header, states = lines[0], lines[1:1 + int(sys.argv[2])]
$edit
with open(sys.argv[3], "w") as f:
    for obj in [header] + states:
        f.write(json.dumps(obj) + "\n")   # writes NaN / Infinity tokens as Python does
PY
}

# every output of every reference state within a relative Frobenius error
case_eval_reference() {
  local robot=$1 precision=$2 tol=$3; shift 3
  expect_exit 0 "$RBDGRAD" eval --model "$robot" --in "$REFERENCE_DIR/$robot.jsonl" --out "$WORK/out.jsonl" \
    --precision "$precision"
  "$PYTHON" "$HERE/compare_results.py" "$WORK/out.jsonl" "$REFERENCE_DIR/$robot.jsonl" --tol "$tol" \
    --precision "$precision" --outputs qdd,M,Minv,dqdd_dq,dqdd_dqd,tau_id,dtau_dq,dtau_dqd "$@"
}

# states with qdd instead of tau: qdd is the input, every output still matches the reference
case_eval_qdd_input() {
  make_states iiwa14 32 'for s in states: del s["tau"]' "$WORK/in.jsonl"
  expect_exit 0 "$RBDGRAD" eval --in "$WORK/in.jsonl" --out "$WORK/out.jsonl"
  "$PYTHON" "$HERE/compare_results.py" "$WORK/out.jsonl" "$REFERENCE_DIR/iiwa14.jsonl" --tol 1e-10
}

# --outputs subsets take other algorithm paths (forward_dynamics, crba, rnea alone): same values
case_eval_output_subsets() {
  local outputs
  for outputs in qdd M tau_id qdd,M M,tau_id M,dtau_dq qdd,dtau_dqd Minv M,dqdd_dq tau_id,dtau_dq; do
    expect_exit 0 "$RBDGRAD" eval --model panda --in "$REFERENCE_DIR/panda.jsonl" --out "$WORK/out.jsonl" \
      --outputs "$outputs"
    "$PYTHON" "$HERE/compare_results.py" "$WORK/out.jsonl" "$REFERENCE_DIR/panda.jsonl" --tol 1e-10 \
      --outputs "$outputs" >"$WORK/compare" || { cat "$WORK/compare"; fail "--outputs $outputs"; }
  done
  # listed in any order and repeated: written in the canonical order, once
  expect_exit 0 "$RBDGRAD" eval --model panda --in "$REFERENCE_DIR/panda.jsonl" --out "$WORK/out.jsonl" \
    --outputs tau_id,qdd,tau_id
  "$PYTHON" "$HERE/compare_results.py" "$WORK/out.jsonl" "$REFERENCE_DIR/panda.jsonl" --tol 1e-10 --outputs qdd,tau_id
}

# a bad state gets an error object naming state and field; the others are still computed; exit 1
case_eval_bad_states() {
  make_states iiwa14 4 '
states[1]["qd"][2] = float("nan")
states[2]["q"] = states[2]["q"][:6]
del states[3]["tau"]; del states[3]["qdd"]' "$WORK/in.jsonl"
  expect_exit 1 "$RBDGRAD" eval --in "$WORK/in.jsonl" --out "$WORK/out.jsonl"
  expect_in "$WORK/stderr" "1 of 4 states evaluated, 3 failed"
  "$PYTHON" - "$WORK/out.jsonl" <<'PY'
import json, sys
header, *states = [json.loads(l) for l in open(sys.argv[1])]
by_index = {s["index"]: s for s in states}
assert sorted(by_index) == [0, 1, 2, 3], sorted(by_index)
assert "error" not in by_index[0] and len(by_index[0]["dqdd_dq"]) == 49, by_index[0].keys()
assert by_index[1] == {"index": 1, "error": "state 1: field 'qd' element 2 is not finite (nan)"}, by_index[1]
assert by_index[2] == {"index": 2, "error": "state 2: field 'q' has 6 values, expected 7"}, by_index[2]
assert by_index[3]["error"].startswith("state 3:") and "'tau'" in by_index[3]["error"], by_index[3]
print("OK")
PY
}

# Q16.16: saturation is an error value for that state, not a silent clamp
case_eval_fixed_point() {
  make_states iiwa14 3 '
states[1]["qd"] = [900.0] * 7          # velocity products far beyond 32768
states[2]["q"][0] = 1e6                # not representable in Q16.16' "$WORK/in.jsonl"
  expect_exit 1 "$RBDGRAD" eval --in "$WORK/in.jsonl" --out "$WORK/out.jsonl" --precision fixed
  "$PYTHON" - "$WORK/out.jsonl" <<'PY'
import json, sys
header, *states = [json.loads(l) for l in open(sys.argv[1])]
assert header["precision"] == "fixed", header
s0, s1, s2 = states
assert "error" not in s0 and len(s0["M"]) == 49, s0
assert s1["index"] == 1 and "fixed-point overflow" in s1["error"], s1
assert s2["error"] == "state 2: out_of_range: field 'q' element 0 (1000000) is outside the range of fixed", s2
print("OK")
PY
  # M alone (crba) stays in range: within the resolution of Q16.16
  expect_exit 0 "$RBDGRAD" eval --in "$REFERENCE_DIR/iiwa14.jsonl" --out "$WORK/out.jsonl" --precision fixed --outputs M
  "$PYTHON" "$HERE/compare_results.py" "$WORK/out.jsonl" "$REFERENCE_DIR/iiwa14.jsonl" --tol 1e-2 --precision fixed
}

# usage errors exit 2 with a usage line; file and model errors exit 1 with the reader's message
case_usage_errors() {
  local in="$REFERENCE_DIR/iiwa14.jsonl" out="$WORK/out.jsonl"
  expect_exit 2 "$RBDGRAD"
  expect_in "$WORK/stderr" "usage: rbdgrad"
  expect_exit 2 "$RBDGRAD" frobnicate
  expect_in "$WORK/stderr" "unknown command 'frobnicate'"
  expect_exit 2 "$RBDGRAD" eval --out "$out"
  expect_in "$WORK/stderr" "--in is required"
  expect_exit 2 "$RBDGRAD" eval --in "$in" --out "$out" --precision f16
  expect_in "$WORK/stderr" "unknown precision 'f16'"
  expect_exit 2 "$RBDGRAD" eval --in "$in" --out "$out" --outputs qdd,jacobian
  expect_in "$WORK/stderr" "unknown output 'jacobian'"
  expect_exit 2 "$RBDGRAD" eval --in "$in" --out "$out" --gravity 0,-9.81
  expect_in "$WORK/stderr" "--gravity"
  expect_exit 2 "$RBDGRAD" eval --in "$in" --out "$out" --bogus
  expect_in "$WORK/stderr" "unknown option '--bogus'"
  expect_exit 2 "$RBDGRAD" eval --in "$in" --in "$in" --out "$out"
  expect_in "$WORK/stderr" "given twice"
  expect_exit 2 "$RBDGRAD" eval --in
  expect_in "$WORK/stderr" "needs a value"
  [[ ! -e "$out" ]] || fail "a usage error wrote $out"
  # not usage errors
  expect_exit 1 "$RBDGRAD" eval --in "$WORK/missing.jsonl" --out "$out"
  expect_in "$WORK/stderr" "missing.jsonl"
  printf '{"robot":"x","nv":7}\n{"index":0,"q":[1,2,\n' >"$WORK/bad.jsonl"
  expect_exit 1 "$RBDGRAD" eval --in "$WORK/bad.jsonl" --out "$out"
  expect_in "$WORK/stderr" "bad.jsonl:2"
  expect_exit 1 "$RBDGRAD" eval --model no_such_robot --in "$in" --out "$out"
  expect_in "$WORK/stderr" "not an embedded robot"
  # help and version succeed
  expect_exit 0 "$RBDGRAD" --help
  expect_in "$WORK/stdout" "eval"
  expect_exit 0 "$RBDGRAD" eval --help
  expect_in "$WORK/stdout" "--precision f64|f32|fixed"
  expect_exit 0 "$RBDGRAD" --version
  expect_in "$WORK/stdout" "rbdgrad 0."
}

# --gravity reaches the model: the header says so, and the input header's different gravity is flagged
case_eval_gravity() {
  expect_exit 0 "$RBDGRAD" eval --in "$REFERENCE_DIR/iiwa14.jsonl" --out "$WORK/out.jsonl" --gravity 0,0,0 --outputs qdd
  expect_in "$WORK/stderr" "warning: the input header has gravity"
  expect_in "$WORK/out.jsonl" '"gravity":[0.0,0.0,0.0]'
  # without gravity the same torques give other accelerations than the reference's
  if "$PYTHON" "$HERE/compare_results.py" "$WORK/out.jsonl" "$REFERENCE_DIR/iiwa14.jsonl" --tol 1e-6 >/dev/null; then
    fail "qdd unchanged by --gravity 0,0,0"
  fi
  # the reference's own gravity, spelt out: no warning, reference values
  expect_exit 0 "$RBDGRAD" eval --in "$REFERENCE_DIR/iiwa14.jsonl" --out "$WORK/out.jsonl" --gravity 0,0,-9.81 --outputs qdd
  if grep -qF warning "$WORK/stderr"; then fail "unexpected warning: $(cat "$WORK/stderr")"; fi
  "$PYTHON" "$HERE/compare_results.py" "$WORK/out.jsonl" "$REFERENCE_DIR/iiwa14.jsonl" --tol 1e-10
}

case_model_summary() {
  expect_exit 0 "$RBDGRAD" model --model panda
  expect_in "$WORK/stdout" "model 'panda'"
  expect_in "$WORK/stdout" "9 moving joints"
  expect_exit 0 "$RBDGRAD" model --model "$SOURCE_DIR/robots/hyq.urdf"
  expect_in "$WORK/stdout" "12 moving joints"
}

case_daemon_once() {
  expect_exit 0 "$RBDGRADD" --once
  expect_in "$WORK/stdout" "model 'iiwa14' (iiwa14.urdf): 7 moving joints"
  expect_in "$WORK/stdout" "iiwa_joint_7"
  expect_in "$WORK/stdout" "backend cpu: ready (in-process core library)"
  expect_exit 1 "$RBDGRADD" --once --model no_such_robot
  expect_exit 2 "$RBDGRADD" --bogus
}

# the daemon runs until SIGTERM, then exits 0
case_daemon_signal() {
  "$RBDGRADD" >"$WORK/log" 2>&1 &
  local pid=$!
  for _ in $(seq 100); do grep -qF "backend cpu: ready" "$WORK/log" && break; sleep 0.1; done
  kill -0 "$pid" 2>/dev/null || fail "rbdgradd exited before a signal: $(cat "$WORK/log")"
  kill -TERM "$pid"
  local rc=0; wait "$pid" || rc=$?
  [[ $rc -eq 0 ]] || fail "rbdgradd exit code $rc after SIGTERM"
  expect_in "$WORK/log" "shutting down"
}

# --- the daemon's commands (info, calibrate, models, compute) -----------------------------------

# start_daemon [RBDGRADD FLAGS...]: rbdgradd on an ephemeral loopback port; sets SERVER to its address
start_daemon() {
  "$RBDGRADD" --listen 127.0.0.1:0 --unix-socket "" --ready-file "$WORK/ready" "$@" >"$WORK/daemon.log" 2>&1 &
  DAEMON_PID=$!
  for _ in $(seq 200); do
    [[ -s "$WORK/ready" ]] && break
    kill -0 "$DAEMON_PID" 2>/dev/null || fail "rbdgradd exited at start: $(cat "$WORK/daemon.log")"
    sleep 0.05
  done
  SERVER=$(awk '$1 == "tcp" { print $2; exit }' "$WORK/ready" 2>/dev/null || true)
  [[ -n "$SERVER" ]] || fail "rbdgradd wrote no tcp address to its ready file: $(cat "$WORK/daemon.log")"
}

# stop_daemon: SIGTERM, and the daemon must exit 0
stop_daemon() {
  kill -TERM "$DAEMON_PID"
  local rc=0; wait "$DAEMON_PID" || rc=$?
  DAEMON_PID=""
  [[ $rc -eq 0 ]] || fail "rbdgradd exit code $rc after SIGTERM: $(tail -5 "$WORK/daemon.log")"
}

# usage errors exit 2; an absent server is a failed call (exit 1, the gRPC code), not a usage error
case_server_commands_usage() {
  local none=127.0.0.1:1   # nothing listens on port 1 of the loopback
  expect_exit 2 "$RBDGRAD" compute --server "$none"
  expect_in "$WORK/stderr" "--n or --in is required"
  expect_exit 2 "$RBDGRAD" compute --n 4 --in x.jsonl
  expect_in "$WORK/stderr" "give --n or --in, not both"
  expect_exit 2 "$RBDGRAD" compute --n 0
  expect_in "$WORK/stderr" "--n: '0' is not a positive number of states"
  expect_exit 2 "$RBDGRAD" compute --n 4 --precision f16
  expect_in "$WORK/stderr" "unknown precision 'f16'"
  expect_exit 2 "$RBDGRAD" compute --n 4 --backend tpu
  expect_in "$WORK/stderr" "unknown backend 'tpu'"
  expect_exit 2 "$RBDGRAD" compute --n 4 --outputs qdd,jacobian
  expect_in "$WORK/stderr" "unknown output 'jacobian'"
  expect_exit 2 "$RBDGRAD" compute --n 4 --output-type f16
  expect_exit 2 "$RBDGRAD" compute --n 4 --input force
  expect_exit 2 "$RBDGRAD" compute --in x.jsonl --seed 3
  expect_in "$WORK/stderr" "--seed goes with --n"
  expect_exit 2 "$RBDGRAD" --server "$none" compute --server "$none" --n 4
  expect_in "$WORK/stderr" "option '--server' given twice"
  expect_exit 2 "$RBDGRAD" --server
  expect_exit 2 "$RBDGRAD" --server "$none"
  expect_exit 2 "$RBDGRAD" --server "$none" eval --in x --out y
  expect_in "$WORK/stderr" "unknown option '--server'"
  expect_exit 2 "$RBDGRAD" info --bogus
  expect_exit 2 "$RBDGRAD" calibrate --bogus
  expect_exit 2 "$RBDGRAD" models --timeout -1
  expect_exit 0 "$RBDGRAD" compute --help
  expect_in "$WORK/stdout" "--precision auto|f64|f32|fixed"
  expect_exit 0 "$RBDGRAD" --help
  expect_in "$WORK/stdout" "compute"
  # no server: the call fails with the gRPC code, before or after the command alike
  expect_exit 1 "$RBDGRAD" --server "$none" compute --n 4
  expect_in "$WORK/stderr" "UNAVAILABLE"
  expect_exit 1 "$RBDGRAD" compute --n 4 --server="$none"
  expect_in "$WORK/stderr" "UNAVAILABLE"
  expect_exit 1 "$RBDGRAD" info --server "$none"
  expect_in "$WORK/stderr" "rbdgrad info: UNAVAILABLE"
  expect_exit 1 "$RBDGRAD" models --server "unix:$WORK/no.sock"
  expect_in "$WORK/stderr" "rbdgrad models: UNAVAILABLE"
}

# info and models describe the running daemon
case_daemon_info_models() {
  start_daemon
  expect_exit 0 "$RBDGRAD" --server "$SERVER" info
  expect_in "$WORK/stdout" "server $SERVER: rbdgrad 0."
  expect_in "$WORK/stdout" "cpu: ready, precisions f64"
  expect_in "$WORK/stdout" "latency iiwa14 f64: "
  expect_in "$WORK/stdout" "routing (cost policy):"
  expect_in "$WORK/stdout" "states per request"
  # measured again on demand: one line per model, then the same report
  expect_exit 0 "$RBDGRAD" calibrate --server "$SERVER"
  expect_in "$WORK/stdout" "calibration: cpu iiwa14 f64: "
  expect_in "$WORK/stdout" "routing (cost policy):"
  expect_exit 0 "$RBDGRAD" models --server "$SERVER"
  expect_in "$WORK/stdout" "NAME"
  grep -qE '^iiwa14 +7 ' "$WORK/stdout" || fail "models: $(cat "$WORK/stdout")"
  stop_daemon
}

# the issue's first request: random states, a summary with timings and checks
case_daemon_compute_random() {
  start_daemon
  expect_exit 0 "$RBDGRAD" --server "$SERVER" compute --model iiwa14 --n 64
  expect_in "$WORK/stdout" "model iiwa14 (nv 7) on $SERVER: 64 of 64 states computed in 1 request"
  expect_in "$WORK/stdout" "backend cpu, precision f64"
  expect_in "$WORK/stdout" "server timings: queue"
  expect_in "$WORK/stdout" "client round trip:"
  expect_in "$WORK/stdout" "checks: all outputs finite"
  # the same seed gives the same results; the file is eval's format
  expect_exit 0 "$RBDGRAD" compute --server "$SERVER" --n 16 --seed 5 --out "$WORK/a.jsonl"
  expect_exit 0 "$RBDGRAD" compute --server "$SERVER" --n 16 --seed 5 --out "$WORK/b.jsonl" --precision f32 --output-type f32
  expect_exit 0 "$RBDGRAD" compute --server "$SERVER" --n 16 --seed 5 --out "$WORK/c.jsonl"
  cmp -s <(tail -n +2 "$WORK/a.jsonl") <(tail -n +2 "$WORK/c.jsonl") || fail "same seed, other results"
  "$PYTHON" - "$WORK/a.jsonl" "$WORK/b.jsonl" <<'PY'
import json, math, sys
(ha, *a), (hb, *b) = ([json.loads(l) for l in open(p)] for p in sys.argv[1:3])
assert ha["nv"] == 7 and ha["precision"] == "f64" and hb["precision"] == "f32", (ha, hb)
assert ha["outputs"] == ["qdd", "M", "Minv", "dqdd_dq", "dqdd_dqd", "tau_id", "dtau_dq", "dtau_dqd"], ha["outputs"]
assert len(a) == 16 and [s["index"] for s in a] == list(range(16)), len(a)
for sa, sb in zip(a, b):
    assert sa["kind"] == "random" and len(sa["dqdd_dq"]) == 49, sa.keys()
    for k in ha["outputs"]:  # f32 agrees with f64 to float accuracy
        d = math.sqrt(sum((x - y) ** 2 for x, y in zip(sa[k], sb[k])))
        assert d <= 1e-3 * (1 + math.sqrt(sum(x * x for x in sa[k]))), (k, d)
print("OK")
PY
  # qdd input and a subset of outputs
  expect_exit 0 "$RBDGRAD" compute --server "$SERVER" --n 8 --input qdd --outputs tau_id,dtau_dq --out "$WORK/d.jsonl"
  "$PYTHON" -c 'import json,sys; h,*s=[json.loads(l) for l in open(sys.argv[1])]; assert h["outputs"]==["tau_id","dtau_dq"]; assert set(s[0])=={"index","kind","tau_id","dtau_dq"}, s[0]' "$WORK/d.jsonl"
  # an unknown model: the server's code and message
  expect_exit 1 "$RBDGRAD" compute --server "$SERVER" --model no_such_robot --n 4
  expect_in "$WORK/stderr" "NOT_FOUND"
  expect_in "$WORK/stderr" "no_such_robot"
  stop_daemon
}

# scenes: rbdgrad scenes describes them, compute --scene uses the scene's joints and outputs
case_daemon_scenes() {
  cat > "$WORK/scenes.yaml" <<'YAML'
models:
  - {name: talos, embedded: talos_reduced}
  - {name: hyq, embedded: hyq}
scenes:
  - name: walk
    model: talos
    locked_joints: {head_1_joint: 0, head_2_joint: 0, gripper_left_joint: 0, gripper_right_joint: 0}
  - {name: trot, model: hyq, gravity: false, force_links: [lf_lowerleg], outputs: [qdd, dqdd_dq]}
scheduler: {calibrate: "off"}
YAML
  start_daemon --config "$WORK/scenes.yaml"
  expect_exit 0 "$RBDGRAD" scenes --server "$SERVER"
  expect_in "$WORK/stdout" "walk: model talos, 28 joints, gravity on, M^-1 computed"
  expect_in "$WORK/stdout" "locked: head_1_joint=0 head_2_joint=0 gripper_left_joint=0 gripper_right_joint=0"
  expect_in "$WORK/stdout" "trot: model hyq, 12 joints, gravity off"
  expect_in "$WORK/stdout" "force links (fext order): lf_lowerleg"
  expect_exit 0 "$RBDGRAD" compute --server "$SERVER" --scene walk --n 5 --out "$WORK/walk.jsonl"
  expect_in "$WORK/stdout" "scene walk (nv 28)"
  expect_in "$WORK/stdout" "5 of 5 states computed"
  "$PYTHON" -c 'import json,sys; h,*s=[json.loads(l) for l in open(sys.argv[1])]; assert h["outputs"]==["dqdd_dq","dqdd_dqd"], h; assert h["nv"]==28, h; assert len(s)==5 and len(s[0]["dqdd_dq"])==28*28, s[0].keys()' "$WORK/walk.jsonl"
  expect_exit 0 "$RBDGRAD" compute --server "$SERVER" --scene trot --n 3 --out "$WORK/trot.jsonl"
  "$PYTHON" -c 'import json,sys; h,*s=[json.loads(l) for l in open(sys.argv[1])]; assert h["outputs"]==["qdd","dqdd_dq"], h; assert h["gravity"]==[0,0,0], h' "$WORK/trot.jsonl"
  # an output the scene does not compute, an unknown scene, --model with --scene
  expect_exit 1 "$RBDGRAD" compute --server "$SERVER" --scene trot --n 3 --outputs dqdd_dqd
  expect_in "$WORK/stderr" "output dqdd_dqd is not one the scene computes (qdd, dqdd_dq)"
  expect_exit 1 "$RBDGRAD" compute --server "$SERVER" --scene dance --n 3
  expect_in "$WORK/stderr" "NOT_FOUND"
  expect_in "$WORK/stderr" "scene 'dance' is not configured (scenes: walk, trot)"
  expect_exit 2 "$RBDGRAD" compute --server "$SERVER" --scene walk --model talos --n 3
  expect_in "$WORK/stderr" "give --model or --scene, not both"
  stop_daemon
}

# `rbdgrad register-scene`: a scene registered with the running daemon is listed and computes as
# the configured scene of the same definition; again is fine, a conflict and bad scenes are not
case_daemon_register_scene() {
  expect_exit 2 "$RBDGRAD" register-scene --model hyq
  expect_in "$WORK/stderr" "give the scene's NAME first"
  expect_exit 2 "$RBDGRAD" register-scene trot
  expect_in "$WORK/stderr" "--model is required"
  expect_exit 2 "$RBDGRAD" register-scene trot --model hyq --lock lf_haa_joint
  expect_in "$WORK/stderr" "--lock: 'lf_haa_joint' is not JOINT=VALUE"
  expect_exit 2 "$RBDGRAD" register-scene trot --model hyq --outputs qdd,jacobian
  expect_in "$WORK/stderr" "--outputs: unknown output 'jacobian'"
  expect_exit 0 "$RBDGRAD" register-scene --help
  expect_in "$WORK/stdout" "--force-links LIST"
  cat > "$WORK/register.yaml" <<'YAML'
models:
  - {name: talos, embedded: talos_reduced}
  - {name: hyq, embedded: hyq}
scenes:
  - {name: trot_cfg, model: hyq, gravity: false, force_links: [lf_lowerleg], outputs: [qdd, dqdd_dq]}
scheduler: {calibrate: "off"}
YAML
  start_daemon --config "$WORK/register.yaml"
  expect_exit 0 "$RBDGRAD" register-scene trot --server "$SERVER" --model hyq --no-gravity \
    --force-links lf_lowerleg --outputs dqdd_dq,qdd
  expect_in "$WORK/stdout" "registered trot: model hyq, 12 joints, gravity off, M^-1 computed"
  expect_in "$WORK/stdout" "force links (fext order): lf_lowerleg"
  # again, as after a reconnection
  expect_exit 0 "$RBDGRAD" register-scene trot --server "$SERVER" --model hyq --no-gravity \
    --force-links lf_lowerleg --outputs qdd,dqdd_dq
  expect_exit 0 "$RBDGRAD" --server "$SERVER" register-scene walk --model talos \
    --lock head_1_joint=0,head_2_joint=0.1,gripper_left_joint=0,gripper_right_joint=0 --minv-supplied
  expect_in "$WORK/stdout" "registered walk: model talos, 28 joints, gravity on, M^-1 from each request"
  expect_in "$WORK/stdout" "locked: head_1_joint=0 head_2_joint=0.1 gripper_left_joint=0 gripper_right_joint=0"
  expect_exit 0 "$RBDGRAD" scenes --server "$SERVER"
  expect_in "$WORK/stdout" "trot_cfg: model hyq, 12 joints, gravity off"
  expect_in "$WORK/stdout" "trot: model hyq, 12 joints, gravity off"
  expect_in "$WORK/stdout" "walk: model talos, 28 joints"
  # the registered scene and its configured twin compute the same numbers
  expect_exit 0 "$RBDGRAD" compute --server "$SERVER" --scene trot --n 3 --seed 5 --out "$WORK/trot.jsonl"
  expect_in "$WORK/stdout" "3 of 3 states computed"
  expect_exit 0 "$RBDGRAD" compute --server "$SERVER" --scene trot_cfg --n 3 --seed 5 --out "$WORK/trot_cfg.jsonl"
  "$PYTHON" -c 'import json,sys; a,b=[[json.loads(l) for l in open(f)][1:] for f in sys.argv[1:]]; assert [(s["qdd"],s["dqdd_dq"]) for s in a]==[(s["qdd"],s["dqdd_dq"]) for s in b]' \
    "$WORK/trot.jsonl" "$WORK/trot_cfg.jsonl" || fail "the registered scene's results differ from the configured one's"
  # the name with another definition, a model's name, bad scenes
  expect_exit 1 "$RBDGRAD" register-scene trot --server "$SERVER" --model hyq --force-links lf_lowerleg --outputs qdd,dqdd_dq
  expect_in "$WORK/stderr" "ALREADY_EXISTS"
  expect_in "$WORK/stderr" "gravity: registered off, asked on"
  expect_exit 1 "$RBDGRAD" register-scene hyq --server "$SERVER" --model hyq
  expect_in "$WORK/stderr" "'hyq' is the name of a model"
  expect_exit 1 "$RBDGRAD" register-scene leap --server "$SERVER" --model hyq --lock lf_knee=0
  expect_in "$WORK/stderr" "INVALID_ARGUMENT"
  expect_in "$WORK/stderr" "scene 'leap': locked joint 'lf_knee': model 'hyq' has no such joint"
  expect_exit 1 "$RBDGRAD" register-scene leap --server "$SERVER" --model ur5
  expect_in "$WORK/stderr" "NOT_FOUND"
  stop_daemon
}

# `rbdgrad health` and the connection options against a daemon with TLS and tokens (certificates
# made here, by tests/support/make_test_certs.sh)
case_daemon_health_tls_token() {
  bash "$SOURCE_DIR/tests/support/make_test_certs.sh" "$WORK/certs"
  printf 'mpc %s\n' "tok-cli-4e1d" >"$WORK/tokens"
  printf 'tok-cli-4e1d\n' >"$WORK/token"
  printf 'tok-wrong\n' >"$WORK/wrong-token"
  cat >"$WORK/secure.yaml" <<YAML
tls:
  cert_file: $WORK/certs/server.pem
  key_file: $WORK/certs/server.key
auth:
  tokens_file: $WORK/tokens
log_level: warn
YAML
  start_daemon --config "$WORK/secure.yaml"
  local tls=(--tls-ca "$WORK/certs/ca.pem")
  # health needs no token; SERVING exits 0
  expect_exit 0 "$RBDGRAD" "${tls[@]}" --server "$SERVER" health
  expect_in "$WORK/stdout" "SERVING"
  expect_exit 0 "$RBDGRAD" health --server "$SERVER" --tls-ca="$WORK/certs/ca.pem"
  # an unknown service: the call fails (NOT_FOUND), exit 1
  expect_exit 1 "$RBDGRAD" "${tls[@]}" --server "$SERVER" health --service no.such.Service
  expect_in "$WORK/stderr" "rbdgrad health: NOT_FOUND"
  # the other commands need the token, before or after the command
  expect_exit 0 "$RBDGRAD" "${tls[@]}" --token-file "$WORK/token" --server "$SERVER" models
  expect_in "$WORK/stdout" "iiwa14"
  expect_exit 0 "$RBDGRAD" compute --server "$SERVER" --n 4 "${tls[@]}" --token-file "$WORK/token"
  expect_in "$WORK/stdout" "4 of 4 states computed"
  expect_exit 1 "$RBDGRAD" "${tls[@]}" --server "$SERVER" models
  expect_in "$WORK/stderr" "rbdgrad models: UNAUTHENTICATED: missing bearer token"
  expect_exit 1 "$RBDGRAD" "${tls[@]}" --token-file "$WORK/wrong-token" --server "$SERVER" info
  expect_in "$WORK/stderr" "UNAUTHENTICATED: invalid bearer token"
  # plaintext, or a CA the server's certificate does not chain to: no connection
  expect_exit 1 "$RBDGRAD" --server "$SERVER" health
  expect_in "$WORK/stderr" "UNAVAILABLE"
  expect_exit 1 "$RBDGRAD" --tls-ca "$WORK/certs/other_ca.pem" --server "$SERVER" health
  expect_in "$WORK/stderr" "UNAVAILABLE"
  # usage: unreadable files, a certificate without its key
  expect_exit 2 "$RBDGRAD" --token-file "$WORK/none" --server "$SERVER" models
  expect_in "$WORK/stderr" "--token-file: cannot read '$WORK/none'"
  expect_exit 2 "$RBDGRAD" --tls-ca "$WORK/none.pem" --server "$SERVER" health
  expect_in "$WORK/stderr" "tls.ca_file: cannot read '$WORK/none.pem'"
  expect_exit 2 "$RBDGRAD" --tls-cert "$WORK/certs/client.pem" --server "$SERVER" health
  expect_in "$WORK/stderr" "--tls-cert and --tls-key go together"
  expect_exit 2 "$RBDGRAD" --tls-ca
  expect_in "$WORK/stderr" "option '--tls-ca' needs a value"
  expect_exit 0 "$RBDGRAD" health --help
  expect_in "$WORK/stdout" "exit status: 0 SERVING"
  expect_exit 0 "$RBDGRAD" --help
  expect_in "$WORK/stdout" "--token-file FILE"
  stop_daemon
  # no daemon at all: exit 1
  expect_exit 1 "$RBDGRAD" health --server 127.0.0.1:1
  expect_in "$WORK/stderr" "rbdgrad health: UNAVAILABLE"
  # a plaintext daemon on a non-loopback address needs listen.insecure: the start-up check says so
  expect_exit 1 "$RBDGRADD" --once --listen 0.0.0.0:0 --unix-socket ""
  cat "$WORK/stdout" "$WORK/stderr" >"$WORK/log"  # (the daemon logs to stdout)
  expect_in "$WORK/log" "is not a loopback address and TLS is off"
  expect_in "$WORK/log" "listen.insecure: true"
}

# the Pinocchio reference through the daemon, like eval; f64 results equal eval's exactly
#   daemon_compute_reference ROBOT PRECISION OUTPUT_TYPE TOL [compare_results.py options]
case_daemon_compute_reference() {
  local robot=$1 precision=$2 output_type=$3 tol=$4; shift 4
  start_daemon --model "$robot"
  # the name the daemon serves the robot under: its only model
  expect_exit 0 "$RBDGRAD" models --server "$SERVER"
  local served; served=$(awk 'NR == 2 { print $1 }' "$WORK/stdout")
  expect_exit 0 "$RBDGRAD" compute --server "$SERVER" --model "$served" --in "$REFERENCE_DIR/$robot.jsonl" \
    --out "$WORK/out.jsonl" --precision "$precision" --output-type "$output_type"
  expect_in "$WORK/stdout" "32 of 32 states computed"
  "$PYTHON" "$HERE/compare_results.py" "$WORK/out.jsonl" "$REFERENCE_DIR/$robot.jsonl" --tol "$tol" \
    --precision "$precision" --outputs qdd,M,Minv,dqdd_dq,dqdd_dqd,tau_id,dtau_dq,dtau_dqd "$@"
  if [[ $precision == f64 && $output_type == f64 ]]; then
    expect_exit 0 "$RBDGRAD" eval --model "$robot" --in "$REFERENCE_DIR/$robot.jsonl" --out "$WORK/eval.jsonl"
    cmp -s <(tail -n +2 "$WORK/out.jsonl") <(tail -n +2 "$WORK/eval.jsonl") \
      || fail "compute's f64 results differ from eval's (in-process core)"
  fi
  stop_daemon
}

# a bad state is rejected before sending, a state the server refuses (Q16.16 overflow) gets the
# server's error, and every other state is still computed: the same states fail as with eval, the
# others have eval's values; exit 1
case_daemon_compute_bad_states() {
  make_states iiwa14 6 '
states[1]["qd"][2] = float("nan")
states[4]["qd"] = [900.0] * 7          # Q16.16 overflows' "$WORK/in.jsonl"
  expect_exit 1 "$RBDGRAD" eval --in "$WORK/in.jsonl" --out "$WORK/eval.jsonl" --precision fixed --outputs M,qdd
  start_daemon
  # the daemon computes the overflowing state again in f64 (fixed_point_fallback: cpu)
  "$RBDGRAD" eval --in "$WORK/in.jsonl" --out "$WORK/eval64.jsonl" --outputs M,qdd || true
  expect_exit 1 "$RBDGRAD" compute --server "$SERVER" --in "$WORK/in.jsonl" --out "$WORK/out.jsonl" --precision fixed \
    --outputs M,qdd
  expect_in "$WORK/stdout" "states failed"
  expect_in "$WORK/stdout" "left the fixed-point range and w"
  expect_in "$WORK/stdout" "computed again on cpu in f64"
  "$PYTHON" - "$WORK/out.jsonl" "$WORK/eval.jsonl" "$WORK/eval64.jsonl" <<'PY'
import json, sys
(header, *states), (_, *evals), (_, *evals64) = ([json.loads(l) for l in open(p)] for p in sys.argv[1:4])
by_index = {s["index"]: s for s in states}
f64 = {e["index"]: e for e in evals64}
assert sorted(by_index) == list(range(6)), sorted(by_index)
assert header["precision"] == "fixed", header
assert by_index[1] == {"index": 1, "error": "state 1: field 'qd' element 2 is not finite (nan)"}, by_index[1]
# the states Q16.16 cannot hold (state 4 at least) come back computed in f64; the rest in Q16.16
overflowed = {e["index"] for e in evals if "overflow" in e.get("error", "")}
assert 4 in overflowed, overflowed
failed = {s["index"] for s in states if "error" in s}
assert failed == {1}, failed
for e in evals:
    if e["index"] in overflowed:
        assert by_index[e["index"]] == f64[e["index"]], (by_index[e["index"]], f64[e["index"]])
    elif "error" not in e:
        assert by_index[e["index"]] == e, (by_index[e["index"]], e)
print("OK")
PY
  stop_daemon
}

name=${1:?usage: cli_test.sh CASE [ARGS...]}; shift
"case_$name" "$@"
echo "PASS: $name $*"
