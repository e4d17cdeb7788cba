#!/usr/bin/env python3
"""How model files without lights look: mean luminance of the model's pixels
and the share of them that are near black, per binary, on the meshes of the
up-axis set (scripts/upright.txt, fetched by scripts/fetch-real-models.sh)
and any extra model files given.

usage (from the project's root, after scripts/fetch-real-models.sh):
    bench/model-look.py OUT_DIR BIN [BIN ...] [-- MODEL ...]

Each BIN renders each model at 160x120 with --samples 1 and the automatic up
axis, and once more with --background 1,0,1 to find the model's pixels (those
that are not exactly magenta: the geometry and camera are the same). Pixels
are 8-bit sRGB, decoded to linear; luminance is Rec. 709's; near black is a
luminance below 0.01 (sRGB 25 of 255). The renders are kept in OUT_DIR for
looking at. Needs python3 with Pillow.
"""
import os
import statistics
import subprocess
import sys

from PIL import Image

args = sys.argv[1:]
if len(args) < 2:
    sys.exit(__doc__)
out, rest = args[0], args[1:]
bins, extra = (rest[: rest.index("--")], rest[rest.index("--") + 1 :]) if "--" in rest else (rest, [])
root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
models = []
for line in open(os.path.join(root, "scripts", "upright.txt")):
    if line.strip() and not line.startswith("#"):
        package, path, _ = line.split()
        models.append(os.path.join(root, "models", "upright", package, path))
models += extra
os.makedirs(out, exist_ok=True)


def linear(c):
    c /= 255.0
    return c / 12.92 if c <= 0.04045 else ((c + 0.055) / 1.055) ** 2.4


LUT = [linear(float(i)) for i in range(256)]


def render(b, model, png, flags):
    cmd = [b, "render", model, "-o", png, "--size", "160x120", "--samples", "1", "-q"] + flags
    subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    return Image.open(png).convert("RGB")


summary = {b: ([], []) for b in bins}
for model in models:
    name = os.path.basename(model)
    row = []
    for k, b in enumerate(bins):
        look = render(b, model, os.path.join(out, "%s.%d.png" % (name, k)), [])
        mask = render(b, model, os.path.join(out, "mask.png"), ["--background", "1,0,1"])
        px, mk = look.tobytes(), mask.tobytes()
        ys = [
            0.2126 * LUT[px[i]] + 0.7152 * LUT[px[i + 1]] + 0.0722 * LUT[px[i + 2]]
            for i in range(0, len(px), 3)
            if mk[i : i + 3] != b"\xff\x00\xff"
        ]
        mean = statistics.mean(ys) if ys else 0.0
        dark = sum(y < 0.01 for y in ys) / len(ys) if ys else 0.0
        summary[b][0].append(mean)
        summary[b][1].append(dark)
        row.append("mean %.3f dark %5.1f%%" % (mean, 100 * dark))
    print("%-28s %s" % (name[:28], "  |  ".join(row)), flush=True)
for b, (means, darks) in summary.items():
    print("%s: luminance median %.3f (lowest %.3f); near-black share median %.1f%%, largest %.1f%%; models with over 20%% near black: %d of %d"
          % (b, statistics.median(means), min(means), 100 * statistics.median(darks), 100 * max(darks),
             sum(d > 0.2 for d in darks), len(darks)))
