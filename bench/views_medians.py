#!/usr/bin/env python3
"""Medians over the rounds of `ROUNDS=k bench/views.sh`'s CSV: per scene, N and
mode, the CPU seconds, the cost per mono view (each round's ratio to that
round's mono), each mode's ratio to the exact mode in the same round, and
the shadow rays traced (and proved, --shadow-fans) per view.

usage: python3 bench/views_medians.py CSV
"""
import csv
import statistics
import sys
from collections import defaultdict


def main(src):
    rows = list(csv.DictReader(open(src)))
    mono = {(r["scene"], r["round"]): float(r["cpu_s"]) for r in rows if r["mode"] == "mono"}
    cpu = {(r["scene"], r["views"], r["mode"], r["round"]): r for r in rows if r["mode"] != "mono"}
    keys = defaultdict(list)
    for (scene, n, mode, rnd), r in cpu.items():
        keys[(scene, int(n), mode)].append((rnd, r))
    print("| scene | N | mode | CPU s | × mono | ÷ exact | shadow rays / view | proved / view | fans free / asked |")
    print("|---|---|---|---|---|---|---|---|---|")
    for (scene, n, mode), rs in sorted(keys.items()):
        med = lambda xs: statistics.median(xs) if xs else float("nan")
        s = med([float(r["cpu_s"]) for _, r in rs])
        per_mono = med([float(r["cpu_s"]) / mono[(scene, rnd)] for rnd, r in rs])
        ratio = med([
            float(r["cpu_s"]) / float(cpu[(scene, str(n), "exact", rnd)]["cpu_s"])
            for rnd, r in rs if (scene, str(n), "exact", rnd) in cpu
        ])
        r0 = rs[0][1]
        shadow = int(r0["shadow_rays"]) / n
        proved = int(r0["shadow_rays_proved"] or 0) / n
        fans = f"{r0['fan_free']} / {r0['fan_queries']}"
        print(f"| {scene} | {n} | {mode} | {s:.2f} | {per_mono:.2f} | {ratio:.2f} | {shadow:.0f} | {proved:.0f} | {fans} |")


if __name__ == "__main__":
    main(sys.argv[1])
