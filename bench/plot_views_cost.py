#!/usr/bin/env python3
"""Plots bench/views-cost.sh's CSV: N views against N mono renders.

Left: the CPU time of N views over that of the N views rendered alone (1 is
no saving). Right: the same time in mono views (N is no saving). One colour
per scene; exact solid, --fast dashed, --reproject dotted.

usage: python3 bench/plot_views_cost.py docs/views-cost.csv docs/images/views-cost.png
"""
import csv
import sys
from collections import defaultdict

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402


def main(src, dst):
    series = defaultdict(list)
    for r in csv.DictReader(open(src)):
        series[(r["scene"], r["mode"])].append(
            (int(r["views"]), float(r["ratio_cpu"]), float(r["per_mono_view"])))
    fig, (ax, ax2) = plt.subplots(1, 2, figsize=(10, 4))
    colors = {}
    styles = {"exact": "-", "fast": "--", "reproject": ":"}
    for (scene, mode), pts in sorted(series.items()):
        pts.sort()
        color = colors.setdefault(scene, "C%d" % len(colors))
        label = "%s %s" % (scene, mode)
        xs = [p[0] for p in pts]
        kw = dict(marker="o", ms=3, color=color, linestyle=styles.get(mode, "-."), label=label)
        ax.plot(xs, [p[1] for p in pts], **kw)
        ax2.plot(xs, [p[2] for p in pts], **kw)
    top = max((x for pts in series.values() for x, _, _ in pts), default=1)
    ax.axhline(1.0, color="grey", lw=0.8)
    ax2.plot([1, top], [1, top], color="grey", lw=0.8, label="N mono renders")
    for a in (ax, ax2):
        a.set_xscale("log", base=2)
        a.set_xlabel("views N")
        a.grid(True, which="both", alpha=0.3)
    ax.set_ylabel("CPU time ÷ N mono renders")
    ax.set_ylim(bottom=0)
    ax2.set_yscale("log", base=2)
    ax2.set_ylabel("CPU time in mono views")
    ax2.legend(fontsize=7, ncol=2)
    fig.suptitle("N views against N mono renders (one thread, whole process)")
    fig.tight_layout()
    fig.savefig(dst, dpi=110)


if __name__ == "__main__":
    main(*sys.argv[1:3])
