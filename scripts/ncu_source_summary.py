#!/usr/bin/env python3
"""Sums Nsight Compute's per-source-line page (ncu -i REPORT --page source --csv --print-source
cuda,sass) by source line: each line's share of the warp stall samples, its warp instructions
and shared-memory wavefronts (and their ideal) per state, the whole kernel's totals first, then
the lines that hold the most of the chosen counter. gpu-checks.sh runs it on the profile step's
report; docs/benchmarks/cuda.md reads its output. Stdlib only.

    ncu_source_summary.py SOURCE_CSV [--states N] [--top K] [--by stall|instructions|wavefronts|excess]
"""
import argparse
import csv
import sys

STALL = "Warp Stall Sampling (All Samples)"
INSTRUCTIONS = "Instructions Executed"
WAVEFRONTS = "L1 Wavefronts Shared"
IDEAL = "L1 Wavefronts Shared Ideal"


def number(text):
    try:
        return float(text.replace(",", ""))
    except (AttributeError, ValueError):
        return 0.0  # "-" or empty: no value for this line


def read_lines(path):
    """One record per CUDA source line: (file, line, source, counters); SASS rows are skipped."""
    records, header, file_name = [], None, "?"
    with open(path, encoding="utf-8", newline="") as f:
        for row in csv.reader(f):
            if not row:
                continue
            if row[0] == "File Path":
                file_name = row[1].rsplit("/", 1)[-1]
            elif row[0] == "Line No":
                header = row
            elif row[0] and row[0] != "Function Name" and header is not None and row[0].isdigit():
                values = dict(zip(header[4:], row[4:]))
                counters = {k: number(values.get(k, "")) for k in (STALL, INSTRUCTIONS, WAVEFRONTS, IDEAL)}
                records.append((file_name, int(row[0]), row[1].strip(), counters))
    if header is None:
        raise SystemExit(f"{path}: no 'Line No' header: not ncu's source page as CSV")
    return records


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("source_csv")
    parser.add_argument("--states", type=float, default=1.0, help="divide the counts by this (the launch's states)")
    parser.add_argument("--top", type=int, default=30)
    parser.add_argument("--by", choices=["stall", "instructions", "wavefronts", "excess"], default="stall")
    args = parser.parse_args()
    records = read_lines(args.source_csv)
    total = {k: sum(r[3][k] for r in records) for k in (STALL, INSTRUCTIONS, WAVEFRONTS, IDEAL)}
    per = args.states
    print(f"{len(records)} source lines; per state: {total[INSTRUCTIONS] / per:.0f} warp instructions, "
          f"{total[WAVEFRONTS] / per:.0f} shared-memory wavefronts (ideal {total[IDEAL] / per:.0f}); "
          f"{total[STALL]:.0f} stall samples")
    key = {
        "stall": lambda r: r[3][STALL],
        "instructions": lambda r: r[3][INSTRUCTIONS],
        "wavefronts": lambda r: r[3][WAVEFRONTS],
        "excess": lambda r: r[3][WAVEFRONTS] - r[3][IDEAL],
    }[args.by]
    stalls = total[STALL] or 1.0
    for file_name, line, source, c in sorted(records, key=key, reverse=True)[: args.top]:
        print(f"{file_name}:{line}  stall {100 * c[STALL] / stalls:5.1f}%  instructions {c[INSTRUCTIONS] / per:8.0f}  "
              f"wavefronts {c[WAVEFRONTS] / per:7.0f} (ideal {c[IDEAL] / per:7.0f})  {source[:80]}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
