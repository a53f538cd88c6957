#!/usr/bin/python3
"""Run time against error from accuracy_bench's CSV: one panel per robot, one point per backend and
precision (time per state at batch size N, median relative error of dqdd/dq and dqdd/dqd against
Pinocchio, the larger of the two), with the Pareto front marked (no other point is both faster and
more accurate). Needs Debian's python3-matplotlib: run it with /usr/bin/python3.

usage: plot_accuracy.py RESULTS.csv N OUT.png
"""
import csv
import math
import sys

import matplotlib

matplotlib.use("Agg")  # files only, no display
import matplotlib.pyplot as plt  # noqa: E402


def points_of(rows, n):
    """{robot: [(label, us_per_state, error)]} at batch size n; rows without an error are skipped."""
    robots = {}
    for r in rows:
        if int(r["n"]) != n or not r["us_per_state"]:
            continue
        errors = [float(r[k]) for k in ("ref_dq_median", "ref_dqd_median") if r[k]]
        if not errors:
            continue
        label = r["backend"].replace("fpga kernel", "kernel") + " " + r["precision"]
        if r["timing"] != "measured":
            label += "*"
        robots.setdefault(r["robot"], []).append((label, float(r["us_per_state"]), max(errors)))
    return robots


def pareto(points):
    """The points no other point beats in both time and error, by increasing time."""
    front, best = [], math.inf
    for p in sorted(points, key=lambda p: (p[1], p[2])):
        if p[2] < best:
            front.append(p)
            best = p[2]
    return front


def main():
    if len(sys.argv) != 4:
        sys.exit(__doc__)
    with open(sys.argv[1], newline="") as f:
        rows = list(csv.DictReader(f))
    n = int(sys.argv[2])
    robots = points_of(rows, n)
    if not robots:
        sys.exit(f"plot_accuracy.py: no rows with N = {n} in {sys.argv[1]}")
    cols = min(2, len(robots))
    rows_n = (len(robots) + cols - 1) // cols
    fig, axes = plt.subplots(rows_n, cols, figsize=(6.0 * cols, 4.6 * rows_n), squeeze=False)
    for ax in axes.flat[len(robots):]:
        ax.set_visible(False)
    for ax, (robot, points) in zip(axes.flat, robots.items()):
        front = pareto(points)
        for label, us, err in points:
            on_front = (label, us, err) in front
            ax.scatter(us, max(err, 1e-17), s=36, zorder=3, color="tab:red" if on_front else "tab:blue")
            ax.annotate(label, (us, max(err, 1e-17)), fontsize=6.5, xytext=(4, 3), textcoords="offset points")
        ax.plot([p[1] for p in front], [max(p[2], 1e-17) for p in front], color="tab:red", lw=1, ls="--",
                label="Pareto front")
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_title(f"{robot}, N = {n}")
        ax.set_xlabel("time per state (µs)")
        ax.set_ylabel("median relative error vs Pinocchio")
        ax.grid(True, which="both", lw=0.3)
        ax.legend(fontsize=7, loc="lower right")
    fig.text(0.01, 0.005, "* time from the FPGA plugin's cycle model (kernel: other formats of the same pipeline, "
             "Q16.16's cycle count); fpga = the kernel's C simulation through the plugin", fontsize=7)
    fig.tight_layout(rect=(0, 0.03, 1, 1))
    fig.savefig(sys.argv[3], dpi=80)


if __name__ == "__main__":
    main()
