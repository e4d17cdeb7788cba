#!/usr/bin/env python3
"""Writes a generated diffuse NFF scene (no highlight, mirror or glass): 400
spheres of random colours and sizes on a floor, four lights, for the
benchmarks of what reprojection saves on diffuse scenes (bench/views-cost.sh
MODES="exact reproject").

usage: python3 bench/diffuse_scene.py OUT.nff
"""
import random
import sys


def main(out):
    g = random.Random(44)
    lines = [
        "v",
        "from 0 -14 6",
        "at 0 0 0.5",
        "up 0 0 1",
        "angle 40",
        "hither 0.01",
        "resolution 512 512",
        "b 0.1 0.12 0.15",
    ]
    for x, y, z in [(-8, -10, 12), (9, -6, 10), (0, 8, 14), (-4, -16, 4)]:
        lines.append("l %g %g %g" % (x, y, z))
    lines.append("f 0.7 0.7 0.65 0.9 0 0 0 1")
    lines.append("p 4 -30 -30 0 30 -30 0 30 30 0 -30 30 0")
    for _ in range(400):
        r = g.uniform(0.15, 0.6)
        lines.append("f %.3f %.3f %.3f 0.8 0 0 0 1" % (g.random(), g.random(), g.random()))
        lines.append("s %.3f %.3f %.3f %.3f" % (g.uniform(-9, 9), g.uniform(-6, 14), r, r))
    with open(out, "w") as f:
        f.write("\n".join(lines) + "\n")


if __name__ == "__main__":
    if len(sys.argv) != 2:
        sys.exit(__doc__)
    main(sys.argv[1])
