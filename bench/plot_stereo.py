#!/usr/bin/env python3
"""Plots the time ratios of `twinray bench-stereo --csv`: the pair over its views rendered alone (two mono renders).

usage: python3 bench/plot_stereo.py docs/stereo-bench.csv docs/images/stereo-ratio.png
"""
import csv
import sys
from collections import defaultdict

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402


def main(src, dst):
    rows = list(csv.DictReader(open(src)))
    interaxials = sorted({float(r["interaxial"]) for r in rows})
    fig, axes = plt.subplots(1, len(interaxials), figsize=(4 * len(interaxials), 3.6), sharey=True)
    if len(interaxials) == 1:
        axes = [axes]
    for ax, b in zip(axes, interaxials):
        series = defaultdict(list)
        for r in rows:
            if float(r["interaxial"]) == b:
                series[r["scene"]].append((int(r["size"]), float(r["ratio"])))
        for scene, pts in sorted(series.items()):
            pts.sort()
            ax.plot([p[0] for p in pts], [p[1] for p in pts], marker="o", label=scene)
        ax.axhspan(0.74, 0.96, color="0.85", label="paper: 0.74-0.96")
        ax.axhline(0.60, color="red", linestyle="--", linewidth=1, label="target 0.60")
        ax.axhline(1.0, color="black", linewidth=0.5)
        ax.set_xscale("log", base=2)
        ax.set_xticks([128, 256, 512, 1024])
        ax.set_xticklabels(["128²", "256²", "512²", "1024²"])
        ax.set_title(f"interaxial {b:g}")
        ax.set_xlabel("image size")
    axes[0].set_ylabel("pair / two mono renders")
    axes[-1].legend(fontsize=7, loc="upper right")
    fig.tight_layout()
    fig.savefig(dst, dpi=110)


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2])
