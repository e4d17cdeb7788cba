#!/usr/bin/env python3
"""Speed against quality of the approximations, one panel per scene, from
`twinray bench-stereo --approx ... --csv` (bench/approx.sh).

x: time / two mono renders (the views rendered alone); y: PSNR of the worst view against the exact
images (exact images drawn at the top edge). One point per size and interaxial.

usage: python3 bench/plot_approx.py docs/approx-bench.csv docs/images/approx-speed-quality.png
"""
import csv
import math
import sys
from collections import defaultdict

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

TOP = 70.0  # where exact images (infinite PSNR) are drawn
STYLE = {
    "none": ("o", "black"),
    "cut": ("v", "tab:green"),
    "merge": ("s", "tab:orange"),
    "reproject": ("D", "tab:blue"),
    "paper": ("x", "tab:red"),
    "fast": ("*", "tab:purple"),
    "all": ("P", "tab:brown"),
}


def main(src, dst):
    rows = list(csv.DictReader(open(src)))
    scenes = sorted({r["scene"] for r in rows})
    cols = 4
    lines = math.ceil(len(scenes) / cols)
    fig, axes = plt.subplots(lines, cols, figsize=(4 * cols, 3.4 * lines), sharex=True, sharey=True)
    axes = [a for row in (axes if lines > 1 else [axes]) for a in row]
    for ax, scene in zip(axes, scenes):
        points = defaultdict(list)
        for r in rows:
            if r["scene"] == scene:
                psnr = float(r["psnr_db"])
                points[r["approx"]].append((float(r["ratio"]), min(psnr, TOP)))
        for name, pts in points.items():
            marker, color = STYLE.get(name, ("+", "gray"))
            ax.scatter([p[0] for p in pts], [p[1] for p in pts], marker=marker, color=color, label=name, s=22)
        ax.axhline(40, color="0.6", lw=0.8, ls="--")
        ax.set_title(scene)
        ax.grid(alpha=0.3)
    for ax in axes[len(scenes):]:
        ax.axis("off")
    for ax in axes[::cols]:
        ax.set_ylabel(f"PSNR, worst view (dB; exact at {TOP:.0f})")
    for ax in axes[-cols:]:
        ax.set_xlabel("time / two mono renders")
    axes[0].legend(fontsize=7, loc="lower left")
    fig.tight_layout()
    fig.savefig(dst, dpi=90)


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2])
