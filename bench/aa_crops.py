#!/usr/bin/env python3
"""The figure of docs/benchmarks.md#anti-aliasing: one crop of an edge-rich
region, rendered with each sampling, enlarged 4x (nearest pixel), side by side.

    bench/aa_crops.py SCENE.nff OUT.png [--size 512] [--crop X,Y,W,H]

Left to right: --samples 1, --samples 4, --samples 16, --adaptive (default),
and a 256-sample reference. Needs only the Python standard library: the
renders are read as PFM and the figure written as PNG with zlib, sRGB-encoded
as twinray's own 8-bit outputs are.
"""

import argparse
import os
import struct
import subprocess
import tempfile
import zlib

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
BIN = os.path.join(ROOT, "target", "release", "twinray")
CONFIGS = [["--samples", "1"], ["--samples", "4"], ["--samples", "16"], [],
           ["--samples", "256", "--seed", "1"]]


def read_pfm(path):
    with open(path, "rb") as f:
        kind = f.readline().strip()
        w, h = map(int, f.readline().split())
        scale = float(f.readline())
        data = f.read()
    assert kind == b"PF", kind
    fmt = ("<" if scale < 0 else ">") + "f" * (w * h * 3)
    v = struct.unpack(fmt, data[: w * h * 12])
    # PFM rows run bottom to top.
    return w, h, [[v[(r * w + x) * 3:(r * w + x) * 3 + 3] for x in range(w)]
                  for r in range(h - 1, -1, -1)]


def write_png(path, width, height, rows):
    raw = b"".join(b"\x00" + bytes(row) for row in rows)
    def chunk(tag, data):
        return (struct.pack(">I", len(data)) + tag + data
                + struct.pack(">I", zlib.crc32(tag + data) & 0xFFFFFFFF))
    png = (b"\x89PNG\r\n\x1a\n"
           + chunk(b"IHDR", struct.pack(">IIBBBBB", width, height, 8, 2, 0, 0, 0))
           + chunk(b"IDAT", zlib.compress(raw, 9)) + chunk(b"IEND", b""))
    with open(path, "wb") as f:
        f.write(png)


def srgb(v):
    """The sRGB curve, as twinray encodes its 8-bit outputs by default."""
    v = max(0.0, min(1.0, v))
    return 12.92 * v if v <= 0.0031308 else 1.055 * v ** (1 / 2.4) - 0.055


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("scene")
    p.add_argument("out")
    p.add_argument("--size", type=int, default=512)
    p.add_argument("--crop", default="200,180,48,48")
    p.add_argument("--zoom", type=int, default=4)
    args = p.parse_args()
    cx, cy, cw, ch = map(int, args.crop.split(","))
    z, gap = args.zoom, 4
    crops = []
    with tempfile.TemporaryDirectory() as tmp:
        for i, flags in enumerate(CONFIGS):
            out = os.path.join(tmp, f"{i}.pfm")
            subprocess.run([BIN, "render", args.scene, "-o", out, "--size",
                            f"{args.size}x{args.size}", "-q"] + flags, check=True,
                           stderr=subprocess.DEVNULL)
            _, _, img = read_pfm(out)
            crops.append([row[cx:cx + cw] for row in img[cy:cy + ch]])
    width = len(crops) * cw * z + (len(crops) - 1) * gap
    rows = []
    for y in range(ch * z):
        row = []
        for k, crop in enumerate(crops):
            for x in range(cw * z):
                c = crop[y // z][x // z]
                row += [round(srgb(v) * 255) for v in c]
            if k + 1 < len(crops):
                row += [255] * (3 * gap)
        rows.append(row)
    write_png(args.out, width, ch * z, rows)


if __name__ == "__main__":
    main()
