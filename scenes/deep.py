#!/usr/bin/env python3
"""Writes scenes/deep.nff: a field of trees out to 800 units, for the paper's
section 2.3 (cuts in the object tree), where depth, not object count, decides.

A few objects stand near the camera (a mirror ball, a glass ball, a post); a
grid of trees (a cone and a sphere each, jittered) runs from 12 to 800 units
away on a ground of 25-unit square tiles (one object each, so that the far
ones can be cut). Deterministic (fixed seed):

    python3 scenes/deep.py > scenes/deep.nff
"""
import random

rng = random.Random(1994)
out = []
w = out.append
w("# deep.nff: a field of trees to 800 units (written by scenes/deep.py)")
w("v")
w("from 0 -6 6")
w("at 0 80 0")
w("up 0 0 1")
w("angle 65")
w("hither 0.01")
w("resolution 640 360")
w("b 0.55 0.7 0.95")
w("l 40 -30 60 1 1 1")
w("l -30 10 25 0.6 0.6 0.55")
# Ground: square tiles, so that the far ones can be cut with the trees on them.
w("f 0.45 0.5 0.3 0.9 0 1 0 1")
tile = 25
for ty in range(-25, 1000, tile):
    for tx in range(-900, 900, tile):
        w("p 4")
        w(f"{tx} {ty} 0")
        w(f"{tx + tile} {ty} 0")
        w(f"{tx + tile} {ty + tile} 0")
        w(f"{tx} {ty + tile} 0")
# Near objects.
w("f 0.9 0.9 0.95 0.3 0.7 40 0 1")
w("s -1.2 2.5 0.7 0.7")
w("f 0.95 0.95 1 0.05 0.1 60 0.85 1.5")
w("s 1.3 3.5 0.6 0.6")
w("f 0.8 0.3 0.2 0.9 0.1 10 0 1")
w("c")
w("0.2 6 0 0.15")
w("0.2 6 2.2 0.15")
# The field: trees on a jittered grid.
trunk = "f 0.4 0.28 0.15 0.9 0 1 0 1"
crowns = [
    "f 0.15 0.5 0.15 0.9 0 1 0 1",
    "f 0.25 0.6 0.1 0.9 0 1 0 1",
    "f 0.1 0.4 0.2 0.9 0.05 5 0 1",
]
for gy in range(12, 800, 9):
    half = 40 + gy // 3
    for gx in range(-half, half + 1, 9):
        x = gx + rng.uniform(-3, 3)
        y = gy + rng.uniform(-3, 3)
        h = rng.uniform(2.0, 5.0)
        r = rng.uniform(0.9, 1.8)
        w(trunk)
        w("c")
        w(f"{x:.3f} {y:.3f} 0 {0.12 * r:.3f}")
        w(f"{x:.3f} {y:.3f} {h:.3f} {0.08 * r:.3f}")
        w(rng.choice(crowns))
        w(f"s {x:.3f} {y:.3f} {h + 0.6 * r:.3f} {r:.3f}")
print("\n".join(out))
