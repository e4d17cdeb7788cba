#!/usr/bin/env python3
"""Counts, of the GLB models of npm `@webxr-input-profiles/assets` (82 VR
controller models exported from Blender, MIT licence), how many render as a
flat silhouette with twinray's defaults: the model's pixels of (nearly) one
colour, as an emissive-textured model gave when the texture was ignored, or
a model seen as a black shape.

    scripts/count-flat-silhouettes.py [DIR]   (default DIR: models/webxr)

Fetches the package with `npm pack` into DIR if it is not there, renders
every GLB with `twinray render FILE -o X.pfm --size 96x72` (the defaults
otherwise: framing, headlight, adaptive sampling), and measures the model's
pixels (those that differ from the black background) in sRGB-encoded luma,
as the 8-bit output would show them: a model is flat when their standard
deviation is below 0.02 (2 % of the range) or when it covers no pixel.
Writes one line per model and the count. Needs npm, Python 3 (standard
library only) and a twinray binary ($TWINRAY, default target/release/twinray).
"""
import glob
import os
import struct
import subprocess
import sys
import tempfile

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
TWINRAY = os.environ.get("TWINRAY", os.path.join(ROOT, "target", "release", "twinray"))
PACKAGE = "@webxr-input-profiles/assets@1.0.20"
FLAT_STD = 0.02


def fetch(out):
    if glob.glob(os.path.join(out, "package", "dist", "profiles", "*", "*.glb")):
        return
    os.makedirs(out, exist_ok=True)
    tgz = subprocess.run(["npm", "pack", "--silent", PACKAGE], cwd=out, check=True,
                         capture_output=True, text=True).stdout.strip().splitlines()[-1]
    subprocess.run(["tar", "xzf", tgz], cwd=out, check=True)
    os.remove(os.path.join(out, tgz))


def read_pfm(path):
    with open(path, "rb") as f:
        data = f.read()
    header, rest = data.split(b"\n", 1)
    dims, rest = rest.split(b"\n", 1)
    scale, pixels = rest.split(b"\n", 1)
    w, h = map(int, dims.split())
    little = float(scale) < 0
    n = 3 if header == b"PF" else 1
    values = struct.unpack(("<" if little else ">") + "f" * (w * h * n), pixels[:w * h * n * 4])
    return [values[i * n:(i + 1) * n] if n == 3 else (values[i],) * 3 for i in range(w * h)]


def srgb(v):
    v = max(0.0, min(1.0, v))
    return 12.92 * v if v <= 0.0031308 else 1.055 * v ** (1 / 2.4) - 0.055


def measure(glb, tmp):
    out = os.path.join(tmp, "m.pfm")
    run = subprocess.run([TWINRAY, "render", glb, "-o", out, "--size", "96x72", "-q"],
                         capture_output=True, text=True)
    if run.returncode != 0:
        return None, run.stderr.strip().splitlines()[-1]
    lumas = [0.2126 * srgb(r) + 0.7152 * srgb(g) + 0.0722 * srgb(b)
             for r, g, b in read_pfm(out) if max(r, g, b) > 0.0]
    if not lumas:
        return 0.0, "no pixels"
    mean = sum(lumas) / len(lumas)
    std = (sum((x - mean) ** 2 for x in lumas) / len(lumas)) ** 0.5
    return std, f"{len(lumas)} px, mean {mean:.3f}"


def main():
    out = os.path.abspath(sys.argv[1] if len(sys.argv) > 1 else os.path.join(ROOT, "models", "webxr"))
    fetch(out)
    glbs = sorted(glob.glob(os.path.join(out, "package", "dist", "profiles", "*", "*.glb")))
    flat, failed = [], []
    with tempfile.TemporaryDirectory() as tmp:
        for glb in glbs:
            name = os.path.relpath(glb, os.path.join(out, "package", "dist", "profiles"))
            std, note = measure(glb, tmp)
            if std is None:
                failed.append(name)
                print(f"FAIL  {name}: {note}")
                continue
            is_flat = std < FLAT_STD
            if is_flat:
                flat.append(name)
            print(f"{'flat' if is_flat else 'ok  '}  {name}: luma std {std:.3f} ({note})")
    print(f"{len(glbs)} GLBs: {len(flat)} flat silhouettes, {len(failed)} failed to render")


if __name__ == "__main__":
    main()
