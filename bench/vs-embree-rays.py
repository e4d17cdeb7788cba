#!/usr/bin/env python3
"""Single rays of three kinds, twinray against Intel Embree 4 on the same rays.

usage (from the project's root):
    bench/vs-embree-rays.py [--size N] [--rounds R] SCENE.nff ...

../shared/bench/vs-embree.py compares eye rays, which twinray traces eight to a
packet. This compares the rays a renderer traces one at a time: the program
`cargo bench -p twinray-bench --bench ray_kinds` makes a scene's eye rays (N²,
the file's viewpoint), the mirror reflections at their hits and the shadow
segments from their hits toward the first light, traces each kind alone on
twinray's eight-wide tree (the renderer's single-ray descent) and writes the
rays out; Embree (through the embreex binding, as in vs-embree.py) intersects
the same rays one by one (rtcIntersect1; rtcOccluded1 with the segment's
length for shadows) over the same triangles. One thread, CPU time of each
side's tracing thread, R rounds, each at least a quarter second of tracing;
prints the medians in Mrays/s, the ratio twinray / Embree (above 1: twinray
faster), and the share of rays on which the two disagree about hit or miss.
Polygon scenes only (Embree here has no spheres or cones).
"""
import argparse
import importlib.util
import os
import re
import subprocess
import sys
import tempfile
import time

import numpy as np

here = os.path.dirname(os.path.abspath(__file__))
# The NFF reader and the Embree binding of ../shared/bench/vs-embree.py.
spec = importlib.util.spec_from_file_location(
    "vs_embree", os.path.join(here, "..", "..", "shared", "bench", "vs-embree.py"))
vs_embree = importlib.util.module_from_spec(spec)
spec.loader.exec_module(vs_embree)
rtcs, TriangleMesh = vs_embree.rtcs, vs_embree.TriangleMesh


def embree_rate(scene, rays, kind):
    """Mrays/s of one round (at least 0.25 s of this thread's CPU), and hits."""
    o, d, far = rays[:, 0:3].copy(), rays[:, 3:6].copy(), rays[:, 6].copy()
    spent, passes, hits = 0.0, 0, 0
    while spent < 0.25:
        t0 = time.thread_time()
        if kind == "shadow":
            found = scene.run(o, d, dists=far, query="OCCLUDED")
        else:
            found = scene.run(o, d)
        spent += time.thread_time() - t0
        passes += 1
        hits = int((found >= 0).sum())
    return passes * len(rays) / spent / 1e6, hits


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--size", type=int, default=512)
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("scenes", nargs="+")
    a = ap.parse_args()
    with tempfile.TemporaryDirectory() as td:
        out = subprocess.run(
            ["cargo", "bench", "-q", "-p", "twinray-bench", "--bench", "ray_kinds", "--",
             "--size", str(a.size), "--rounds", str(a.rounds), "--out", td] + [os.path.abspath(s) for s in a.scenes],
            check=True, capture_output=True, text=True).stdout
        ours = {}
        for line in out.splitlines():
            w = line.split()
            if len(w) >= 7 and re.fullmatch(r"\d+", w[2]):
                rates = sorted(float(x) for x in w[6:])
                ours[(w[0], w[1])] = (int(w[2]), int(w[3]), rates[len(rates) // 2])
        print("%-10s %-9s %8s %12s %12s %7s %9s" % (
            "scene", "kind", "rays", "twinray_Mr/s", "embree_Mr/s", "ratio", "hit_diff"))
        for path in a.scenes:
            name = os.path.basename(path).rsplit(".", 1)[0]
            try:
                _, tris, _ = vs_embree.parse_nff(path)
            except SystemExit as e:  # spheres or cones: no Embree figure
                print("%-10s skipped: %s" % (name, e))
                continue
            scene = rtcs.EmbreeScene()
            TriangleMesh(scene, tris)
            for kind in ("eye", "reflected", "shadow"):
                if (name, kind) not in ours:
                    continue
                n, our_hits, our_rate = ours[(name, kind)]
                rays = np.fromfile(os.path.join(td, "%s.%s.f32" % (name, kind)),
                                   dtype="<f4").reshape(-1, 7)
                scene.run(rays[:64, 0:3].copy(), rays[:64, 3:6].copy())  # commit first
                rounds = [embree_rate(scene, rays, kind) for _ in range(a.rounds)]
                rate = sorted(r for r, _ in rounds)[len(rounds) // 2]
                hits = rounds[-1][1]
                print("%-10s %-9s %8d %12.2f %12.2f %7.2f %8.4f%%" % (
                    name, kind, n, our_rate, rate, our_rate / rate,
                    100.0 * abs(our_hits - hits) / max(n, 1)))
            sys.stdout.flush()


if __name__ == "__main__":
    main()
