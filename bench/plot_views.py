#!/usr/bin/env python3
"""Plots the cost of N views against one mono view from `bench/views.sh`'s CSV:
one curve per scene, exact (solid), --fast (dashed), and any other mode of an
older run (dash-dot: shared shading, epipolar rows).

usage: python3 bench/plot_views.py docs/views-bench.csv docs/images/views-cost.png
"""
import csv
import sys
from collections import defaultdict

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402


def main(src, dst):
    rows = [r for r in csv.DictReader(open(src)) if r["mode"] != "mono"]
    series = defaultdict(list)
    for r in rows:
        series[(r["scene"], r["mode"])].append((int(r["views"]), float(r["per_mono"])))
    fig, (ax, ax2) = plt.subplots(1, 2, figsize=(10, 4))
    colors = {}
    for (scene, mode), pts in sorted(series.items()):
        pts.sort()
        color = colors.setdefault(scene, f"C{len(colors)}")
        style = {"exact": "-", "fast": "--"}.get(mode, "-.")
        xs = [p[0] for p in pts]
        ax.plot(xs, [p[1] for p in pts], style, marker="o", ms=3, color=color,
                label=f"{scene} {mode}")
        ax2.plot(xs, [p[1] / p[0] for p in pts], style, marker="o", ms=3, color=color)
    n = sorted({int(r["views"]) for r in rows})
    ax.plot(n, n, ":", color="0.5", label="N independent views")
    ax.set_xscale("log", base=2)
    ax.set_yscale("log", base=2)
    ax.set_xlabel("views N")
    ax.set_ylabel("CPU time / one mono view")
    ax.set_title("N views")
    ax.legend(fontsize=6, ncol=2)
    ax2.set_xscale("log", base=2)
    ax2.axhline(1.0, color="0.5", ls=":")
    ax2.set_xlabel("views N")
    ax2.set_ylabel("time per view / one mono view")
    ax2.set_title("per view (- exact, -- fast, -. other)", fontsize=10)
    size = rows[0]["size"] if rows else ""
    fig.suptitle(f"Cost of N views, {size} per view, --samples 1 (bench/views.sh)")
    fig.tight_layout()
    fig.savefig(dst, dpi=110)


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2])
