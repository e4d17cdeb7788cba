#!/usr/bin/env python3
"""Markdown tables from `twinray bench-stereo --approx ... --csv` (bench/approx.sh).

usage: python3 bench/approx_tables.py CSV summary      one row per scene: every configuration's
                                                        ratio, worst-view PSNR and largest difference
       python3 bench/approx_tables.py CSV paper CONFIG  the shape of the paper's tables 2.3/2.4:
                                                        scene x size, one column per interaxial
"""
import csv
import statistics
import sys


def psnr(v):
    p = float(v)
    return "exact" if p == float("inf") else f"{p:.1f}"


def summary(rows):
    configs = [c for c in ["none", "cut", "merge", "reproject", "paper", "all", "fast"] if any(r["approx"] == c for r in rows)]
    print("| scene | " + " | ".join(configs) + " |")
    print("|---|" + "---:|" * len(configs))
    ratios = {c: [] for c in configs}
    for scene in dict.fromkeys(r["scene"] for r in rows):
        cells = []
        for c in configs:
            r = next(r for r in rows if r["scene"] == scene and r["approx"] == c)
            ratios[c].append(float(r["ratio"]))
            cells.append(f"{float(r['ratio']):.2f} · {psnr(r['psnr_db'])} · {float(r['max_abs']):.2f}")
        print(f"| {scene} | " + " | ".join(cells) + " |")
    print("| **median ratio** | " + " | ".join(f"**{statistics.median(ratios[c]):.2f}**" for c in configs) + " |")


def paper(rows, config):
    rows = [r for r in rows if r["approx"] == config]
    ias = sorted({float(r["interaxial"]) for r in rows})
    print("| scene | size | " + " | ".join(f"b = {b:g}" for b in ias) + " |")
    print("|---|---:|" + "---:|" * len(ias))
    for scene in dict.fromkeys(r["scene"] for r in rows):
        for size in sorted({int(r["size"]) for r in rows if r["scene"] == scene}):
            cells = []
            for b in ias:
                r = next((r for r in rows if r["scene"] == scene and int(r["size"]) == size and float(r["interaxial"]) == b), None)
                cells.append("" if r is None else f"{float(r['ratio']):.2f} ({psnr(r['psnr_db'])})")
            print(f"| {scene} | {size}² | " + " | ".join(cells) + " |")


if __name__ == "__main__":
    data = list(csv.DictReader(open(sys.argv[1])))
    if sys.argv[2] == "summary":
        summary(data)
    else:
        paper(data, sys.argv[3])
