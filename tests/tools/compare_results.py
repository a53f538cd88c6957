#!/usr/bin/env python3
"""Tests for tools/cli (rbdgrad eval): compares a results file with a Pinocchio reference file.

Every state of the reference must have a result line with no error and every output the results
header lists; each output is compared by relative Frobenius error ||x - ref|| / ||ref||.
Exits 0 when the worst error of every output is within --tol (and the median within --median-tol
when given), 1 otherwise, printing the per-output median/worst errors either way. Stdlib only.
"""
import argparse
import json
import math
import statistics
import sys


def read_jsonl(path):
    with open(path, encoding="utf-8") as f:
        lines = [json.loads(line) for line in f if line.strip()]
    if not lines:
        raise SystemExit(f"{path}: empty file")
    return lines[0], lines[1:]


def relative_error(x, ref):
    diff = math.sqrt(sum((a - b) ** 2 for a, b in zip(x, ref)))
    norm = math.sqrt(sum(b * b for b in ref))
    return diff / norm if norm > 0 else diff


def main():
    p = argparse.ArgumentParser(description=__doc__)
    p.add_argument("results")
    p.add_argument("reference")
    p.add_argument("--tol", type=float, required=True, help="bound on the worst relative error")
    p.add_argument("--median-tol", type=float, help="bound on the median relative error")
    p.add_argument("--precision", help="the precision the results header must state")
    p.add_argument("--outputs", help="comma-separated outputs the header must list, exactly")
    a = p.parse_args()

    header, results = read_jsonl(a.results)
    ref_header, refs = read_jsonl(a.reference)
    problems = []
    outputs = header.get("outputs", [])
    if not outputs:
        problems.append("results header lists no outputs")
    if a.outputs is not None and outputs != a.outputs.split(","):
        problems.append(f"header outputs {outputs}, expected {a.outputs.split(',')}")
    if a.precision is not None and header.get("precision") != a.precision:
        problems.append(f"header precision {header.get('precision')!r}, expected {a.precision!r}")
    if header.get("nv") != ref_header.get("nv"):
        problems.append(f"header nv {header.get('nv')}, reference nv {ref_header.get('nv')}")
    if header.get("joint_names") != ref_header.get("joint_names"):
        problems.append("joint_names differ from the reference")
    if len(results) != len(refs):
        problems.append(f"{len(results)} result lines for {len(refs)} reference states")

    errors = {name: [] for name in outputs}
    by_index = {r.get("index"): r for r in results}
    for ref in refs:
        r = by_index.get(ref["index"])
        if r is None:
            problems.append(f"state {ref['index']}: no result")
            continue
        if "error" in r:
            problems.append(f"state {ref['index']}: error {r['error']!r}")
            continue
        if r.get("kind", "") != ref.get("kind", ""):
            problems.append(f"state {ref['index']}: kind {r.get('kind')!r}, expected {ref.get('kind')!r}")
        extra = set(r) - set(outputs) - {"index", "kind"}
        if extra:
            problems.append(f"state {ref['index']}: unexpected fields {sorted(extra)}")
        for name in outputs:
            x = r.get(name)
            if x is None or len(x) != len(ref[name]):
                problems.append(f"state {ref['index']}: output {name!r} missing or of the wrong size")
                continue
            errors[name].append(relative_error(x, ref[name]))

    for name, errs in errors.items():
        if not errs:
            continue
        med, worst = statistics.median(errs), max(errs)
        print(f"{name:9s} median {med:.2e} worst {worst:.2e} over {len(errs)} states")
        if worst > a.tol:
            problems.append(f"{name}: worst relative error {worst:.3e} > {a.tol:.1e}")
        if a.median_tol is not None and med > a.median_tol:
            problems.append(f"{name}: median relative error {med:.3e} > {a.median_tol:.1e}")

    for msg in problems[:30]:
        print("FAIL:", msg)
    if problems:
        print(f"FAIL: {len(problems)} problem(s)")
        return 1
    print("OK")
    return 0


if __name__ == "__main__":
    sys.exit(main())
