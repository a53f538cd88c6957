#!/usr/bin/env python3
"""Sums Nsight Compute's per-source-line page (ncu -i REPORT --page source --csv --print-source
cuda,sass) by source line: each line's share of the warp stall samples, its warp instructions
and shared-memory wavefronts (and their ideal) per state, the whole kernel's totals first, then
the lines that hold the most of the chosen counter. `--by pass` sums the SASS instead, in address
order, cut after each barrier (BAR.SYNC): a block kernel's synced passes, each with the source
lines that hold most of its instructions (a loop around a barrier shows as one segment, its
barrier executed once an iteration). gpu-checks.sh runs it on the profile step's report;
docs/benchmarks/cuda.md reads its output. Stdlib only.

The totals are the SASS rows' (each instruction once, as the details page counts): the page lists
an instruction under every source line it is attributed to, inlined code under more than one, so
the source lines' sums count some twice.

    ncu_source_summary.py SOURCE_CSV [--states N] [--top K] [--by stall|instructions|wavefronts|excess|pass]
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


COUNTERS = (STALL, INSTRUCTIONS, WAVEFRONTS, IDEAL)


def read_page(path):
    """The source lines, one record each: (file, line, source, counters); and the SASS
    instructions by address: {address: (text, counters, the first "file:line" listing it)}."""
    records, sass, header, file_name, line = [], {}, None, "?", "?"
    with open(path, encoding="utf-8", newline="") as f:
        for row in csv.reader(f):
            if not row:
                continue
            if row[0] == "File Path":
                file_name = row[1].rsplit("/", 1)[-1]
            elif row[0] == "Line No":
                header = row
            elif header is None or row[0] == "Function Name":
                continue
            elif row[0].isdigit():
                values = dict(zip(header[4:], row[4:]))
                counters = {k: number(values.get(k, "")) for k in COUNTERS}
                line = f"{file_name}:{row[0]}"
                records.append((file_name, int(row[0]), row[1].strip(), counters))
            elif not row[0] and len(row) > 3 and row[2].startswith("0x"):
                values = dict(zip(header[4:], row[4:]))
                address = int(row[2], 16)
                if address not in sass:
                    sass[address] = (row[3].strip(), {k: number(values.get(k, "")) for k in COUNTERS}, line)
    if header is None:
        raise SystemExit(f"{path}: no 'Line No' header: not ncu's source page as CSV")
    return records, sass


def print_passes(sass, per, stalls, top):
    """The SASS in address order, a segment per barrier: its share of the stall samples, its
    warp instructions and wavefronts per state, its barrier's executions per state, and the
    source lines with most of its instructions."""
    segments, current = [], []
    for address in sorted(sass):
        current.append(sass[address])
        if current[-1][0].startswith("BAR.SYNC"):
            segments.append(current)
            current = []
    if current:
        segments.append(current)
    for k, segment in enumerate(segments):
        sums = {c: sum(x[1][c] for x in segment) for c in COUNTERS}
        by_line = {}
        for text, counters, line in segment:
            by_line[line] = by_line.get(line, 0.0) + counters[INSTRUCTIONS]
        lines = sorted(by_line.items(), key=lambda item: item[1], reverse=True)[:top]
        barrier = segment[-1][1][INSTRUCTIONS] / per if segment[-1][0].startswith("BAR.SYNC") else 0.0
        print(f"pass {k:2d}  stall {100 * sums[STALL] / stalls:5.1f}%  instructions {sums[INSTRUCTIONS] / per:7.0f}  "
              f"wavefronts {sums[WAVEFRONTS] / per:6.0f} (ideal {sums[IDEAL] / per:6.0f})  barrier x{barrier:4.1f}  "
              + ", ".join(f"{line} {count / per:.0f}" for line, count in lines))


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("source_csv")
    parser.add_argument("--states", type=float, default=1.0, help="divide the counts by this (the launch's states)")
    parser.add_argument("--top", type=int, default=30)
    parser.add_argument("--by", choices=["stall", "instructions", "wavefronts", "excess", "pass"], default="stall")
    args = parser.parse_args()
    records, sass = read_page(args.source_csv)
    # the SASS rows' totals where the page has them (each instruction once), else the lines'
    rows = [counters for _, counters, _ in sass.values()] or [r[3] for r in records]
    total = {k: sum(c[k] for c in rows) for k in COUNTERS}
    per = args.states
    print(f"{len(records)} source lines, {len(sass)} SASS instructions; per state: {total[INSTRUCTIONS] / per:.0f} "
          f"warp instructions, {total[WAVEFRONTS] / per:.0f} shared-memory wavefronts (ideal {total[IDEAL] / per:.0f}); "
          f"{total[STALL]:.0f} stall samples")
    stalls = total[STALL] or 1.0
    if args.by == "pass":
        if not sass:
            raise SystemExit(f"{args.source_csv}: no SASS rows (print the page with --print-source cuda,sass)")
        print_passes(sass, per, stalls, 3)
        return 0
    key = {
        "stall": lambda r: r[3][STALL],
        "instructions": lambda r: r[3][INSTRUCTIONS],
        "wavefronts": lambda r: r[3][WAVEFRONTS],
        "excess": lambda r: r[3][WAVEFRONTS] - r[3][IDEAL],
    }[args.by]
    for file_name, line, source, c in sorted(records, key=key, reverse=True)[: args.top]:
        print(f"{file_name}:{line}  stall {100 * c[STALL] / stalls:5.1f}%  instructions {c[INSTRUCTIONS] / per:8.0f}  "
              f"wavefronts {c[WAVEFRONTS] / per:7.0f} (ideal {c[IDEAL] / per:7.0f})  {source[:80]}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
