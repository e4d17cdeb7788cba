#!/usr/bin/env python3
"""Anti-aliasing against a many-samples reference (issue: Sampler and Film).

For each scene: a reference at --reference samples per pixel (box filter, its own seed: uncorrelated with the configurations),
then --samples 1, 4, 16 and --adaptive at each threshold; prints, per
configuration, the eye samples per pixel, the PSNR against the reference and
the render time, as a Markdown table, and writes the rows as CSV.

    bench/antialias.py [--size 512] [--reference 256] [--thresholds 0.0625,0.03125]
                       [--csv docs/antialias-bench.csv] [--refs DIR] [SCENE.nff ...]

Default scenes: ../shared/scenes/spd/*.nff (the SPD set) beside the repository.
The mono renders are enough for the quality: the sample positions are the same
in every view (locked), and the stereo cost is bench-stereo's business.
"""

import argparse
import csv
import json
import os
import re
import subprocess
import sys
import tempfile
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
BIN = os.path.join(ROOT, "target", "release", "twinray")
SPD = ["balls", "gears", "mount", "rings", "teapot", "tetra", "tree"]


def render(scene, out, size, flags, stats):
    cmd = [BIN, "render", scene, "-o", out, "--size", f"{size}x{size}", "-q",
           "--stats", stats] + flags
    t = time.perf_counter()
    subprocess.run(cmd, check=True, stderr=subprocess.DEVNULL)
    seconds = time.perf_counter() - t
    with open(stats) as f:
        facts = json.load(f)["sampling"]
    return seconds, facts


def psnr(a, b):
    out = subprocess.run([BIN, "compare", a, b], check=True, capture_output=True,
                         text=True).stdout
    m = re.search(r"psnr_db (\S+)", out)
    return float(m.group(1)) if m else float("nan")


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("scenes", nargs="*")
    p.add_argument("--size", type=int, default=512)
    p.add_argument("--reference", type=int, default=256)
    p.add_argument("--samples", default="1,4,16")
    p.add_argument("--thresholds", default="0.0625,0.03125")
    p.add_argument("--csv")
    p.add_argument("--refs", help="keep the references in this directory and reuse them")
    args = p.parse_args()
    scenes = args.scenes or [os.path.join(ROOT, "..", "shared", "scenes", "spd", f"{s}.nff")
                             for s in SPD]
    configs = [(f"--samples {n}", ["--samples", n]) for n in args.samples.split(",")]
    configs += [(f"--adaptive {t}", ["--adaptive", t]) for t in args.thresholds.split(",")]
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for scene in scenes:
            name = os.path.splitext(os.path.basename(scene))[0]
            refs = args.refs or tmp
            os.makedirs(refs, exist_ok=True)
            ref = os.path.join(refs, f"{name}-{args.size}-ref{args.reference}.exr")
            st = os.path.join(tmp, "stats.json")
            if not os.path.exists(ref):
                ref_s, _ = render(scene, ref, args.size,
                                  ["--samples", str(args.reference), "--seed", "1"], st)
                print(f"{name}: reference {args.reference} samples in {ref_s:.1f} s",
                      file=sys.stderr)
            for label, flags in configs:
                img = os.path.join(tmp, f"{name}.exr")
                seconds, facts = render(scene, img, args.size, flags, st)
                rows.append({
                    "scene": name,
                    "config": label,
                    "samples_per_pixel": facts["eye_samples_per_pixel_mean"],
                    "refined_pixels": facts["refined_pixels"],
                    "psnr_db": psnr(ref, img),
                    "seconds": seconds,
                })
                r = rows[-1]
                print(f"  {label:20} {r['samples_per_pixel']:6.2f} spp  "
                      f"{r['psnr_db']:6.2f} dB  {seconds:6.2f} s", file=sys.stderr)
    print(f"| scene | sampling | eye samples / pixel | PSNR vs {args.reference} spp (dB) | time (s) |")
    print("|---|---|---:|---:|---:|")
    for r in rows:
        print(f"| {r['scene']} | `{r['config']}` | {r['samples_per_pixel']:.2f} | "
              f"{r['psnr_db']:.2f} | {r['seconds']:.2f} |")
    if args.csv:
        with open(args.csv, "w", newline="") as f:
            w = csv.DictWriter(f, fieldnames=list(rows[0].keys()))
            w.writeheader()
            w.writerows(rows)


if __name__ == "__main__":
    main()
