#!/usr/bin/python3
"""Draws stability_sweep's CSV: relative error against the swept quantity, log-log, one panel per
sweep, one line per precision (solid = median, dashed = worst; both gravity settings pooled).

    /usr/bin/python3 bench/stability/plot_stability.py stability.csv stability.png [ROBOT]

ROBOT (e.g. iiwa14) draws that robot's rows where the sweep has them; by default, and for the
sweeps run on random models only (joints, cond), all robots pooled.

Needs matplotlib (Debian: python3-matplotlib, hence /usr/bin/python3).
"""
import csv
import math
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

SWEEPS = [
    ("velocity", "max joint speed (rad/s)"),
    ("mass_ratio", "tip/root link mass and inertia ratio"),
    ("inertia_ratio", "tip/root link rotational inertia ratio"),
    ("joint_limit", "distance from a joint limit (fraction of range)"),
    ("singularity", "perturbation of q = 0 on iiwa14 (rad)"),
    ("joints", "joints (random chains and trees)"),
    ("cond", "cond(M) (upper end of a decade)"),
]
COLORS = {"f64": "tab:blue", "f32": "tab:orange", "fixed": "tab:green"}


def number(text):
    try:
        value = float(text)
    except ValueError:
        return math.nan
    return value


def error(row, stat):
    """The larger of the dqdd/dq and dqdd/dqd errors, ignoring one that was not measured."""
    values = [number(row[f"{stat}_err_dqdd_dq"]), number(row[f"{stat}_err_dqdd_dqd"])]
    values = [v for v in values if not math.isnan(v)]
    return max(values) if values else math.nan


def nan_low(v):
    return -math.inf if math.isnan(v) else v


def main(csv_path, png_path, robot="all"):
    with open(csv_path, newline="") as f:
        table = list(csv.DictReader(f))
    # per sweep: the robot's rows if it has any, else the pooled ones
    rows = []
    for sweep, _ in SWEEPS:
        own = [r for r in table if r["sweep"] == sweep and r["robot"] == robot]
        rows += own or [r for r in table if r["sweep"] == sweep and r["robot"] == "all"]
    sweeps = [(s, label) for s, label in SWEEPS if any(r["sweep"] == s for r in rows)]
    cols = 2
    fig, axes = plt.subplots((len(sweeps) + cols - 1) // cols, cols, figsize=(11, 3.2 * ((len(sweeps) + 1) // cols)),
                             squeeze=False)
    for ax, (sweep, label) in zip(axes.flat, sweeps):
        xs_all = []
        for precision, color in COLORS.items():
            mine = [r for r in rows if r["sweep"] == sweep and r["precision"] == precision]
            xs = sorted({number(r["x"]) for r in mine})
            xs_all += xs
            for stat, style in (("median", "-"), ("worst", "--")):
                # a robot has a row per gravity setting: the larger error of the two
                ys = [max((error(r, stat) for r in mine if number(r["x"]) == x), key=nan_low) for x in xs]
                ax.plot(xs, ys, style, color=color, marker="o" if stat == "median" else None, markersize=3,
                        label=f"{precision} {stat}")
        positive = [x for x in xs_all if x > 0]
        if positive and min(xs_all) <= 0:  # "at the limit" / "at q = 0" is x = 0
            ax.set_xscale("symlog", linthresh=min(positive))
        else:
            ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel(label)
        ax.set_ylabel("relative error")
        robots = {r["robot"] for r in rows if r["sweep"] == sweep}
        ax.set_title(f"{sweep} ({', '.join(sorted(robots))})")
        ax.grid(True, which="major", alpha=0.3)
    for ax in list(axes.flat)[len(sweeps):]:
        ax.axis("off")
    axes.flat[0].legend(fontsize=7, ncol=3)
    fig.tight_layout()
    fig.savefig(png_path, dpi=80)


if __name__ == "__main__":
    if len(sys.argv) not in (3, 4):
        sys.exit("usage: plot_stability.py STABILITY_CSV OUTPUT_PNG [ROBOT]")
    main(*sys.argv[1:])
