#!/usr/bin/env python3
"""Writes leaves.obj, leaves.mtl and leaf.png into a folder: seven quads
textured with a leaf whose alpha cuts its outline and two holes (MTL `map_d`:
a MASK cut-out, docs/shading.md), to show cut-outs in eye and shadow rays.
Needs Pillow.

    python3 docs/images/leaves.py /tmp/leaves
    twinray render /tmp/leaves/leaves.obj -o docs/images/leaves.png --size 480x360 \\
        --ground --background 0.55,0.7,0.9
"""
import math, os, random, sys

from PIL import Image

def leaf(path, size=256):
    img = Image.new("RGBA", (size, size))
    px = img.load()
    for y in range(size):
        for x in range(size):
            u, v = (x + 0.5) / size * 2 - 1, (y + 0.5) / size * 2 - 1
            width = 0.55 * (1 - v * v) ** 0.6 + 1e-6
            inside = (u / width) ** 2 + 0.9 * v * v < 1 and abs(v) < 0.97
            hole = (u - 0.2) ** 2 + (v + 0.3) ** 2 < 0.02 or (u + 0.15) ** 2 + (v - 0.25) ** 2 < 0.015
            vein = abs(u) < 0.02
            green = 200 if vein else int(120 + 60 * v)
            px[x, y] = (40, green, 30, 255 if inside and not hole else 0)
    img.save(path)

def main(out):
    os.makedirs(out, exist_ok=True)
    leaf(os.path.join(out, "leaf.png"))
    with open(os.path.join(out, "leaves.mtl"), "w") as f:
        f.write("newmtl leaf\nKd 1 1 1\nKs 0.1 0.1 0.1\nNs 50\nillum 2\n"
                "map_Kd leaf.png\nmap_d leaf.png\n")
    lines = ["mtllib leaves.mtl", "usemtl leaf"]
    random.seed(3)
    for k in range(7):
        cx, cy, cz = random.uniform(-1.5, 1.5), random.uniform(0.5, 2.0), random.uniform(-1.5, 1.5)
        yaw, tilt = random.uniform(0, 6.28), random.uniform(-0.6, 0.6)
        for u, v in [(-1, -1), (1, -1), (1, 1), (-1, 1)]:
            x, y = u * 0.7, v * 0.7
            y2, z2 = y * math.cos(tilt), y * math.sin(tilt)
            X = x * math.cos(yaw) + z2 * math.sin(yaw)
            Z = -x * math.sin(yaw) + z2 * math.cos(yaw)
            lines.append(f"v {cx + X:.4f} {cy + y2:.4f} {cz + Z:.4f}")
        lines += ["vt 0 0", "vt 1 0", "vt 1 1", "vt 0 1"]
        b = 4 * k
        lines.append(f"f {b+1}/{b+1} {b+2}/{b+2} {b+3}/{b+3} {b+4}/{b+4}")
    with open(os.path.join(out, "leaves.obj"), "w") as f:
        f.write("\n".join(lines) + "\n")

if __name__ == "__main__":
    main(sys.argv[1])
