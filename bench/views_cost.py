#!/usr/bin/env python3
"""What N views cost against N mono renders: run by bench/views-cost.sh.

For each scene and each number of views N, a round renders:
  * mono: each of the N views alone, as N mono renders of the same binary
    with the same flags but the method's (a mono render takes no --fast or
    --reproject: they need two views or more) (the view's own camera: the scene's `from` and `at`
    moved by the view's offset along the camera's right axis, as the oracle
    test moves the eye; the rig converges at infinity, so no view has an
    image shift and view K of the rig is exactly that camera);
  * every MODE (exact: the default method; fast: --fast; reproject:
    --reproject) rendering the N views in one process.
Every render writes PNG (what a user writes), at --samples 1 unless FLAGS
say otherwise. The time is the CPU time (user + sys) of the whole process at
--threads 1, the best of ROUNDS rounds (for the mono renders, the best
round's sum of the N); beside it the wall time of the same commands on all
cores (WALL=0: not measured), best of the rounds too.

Images: each exact view against its mono render (a check that the baseline
renders the same views: "identical" or the worst PSNR), and each approximate
mode's views against the exact views: the worst view's PSNR of the 8-bit
sRGB images and its share of pixels off by more than 16/255 in any channel,
against the budget of docs/stereo.md (PSNR >= 40 dB, <= 0.5 %).

usage (from the project root, after cargo build --release):
    bench/views-cost.sh [SCENE.nff ...]
environment (defaults):
    TWINRAY=target/release/twinray  SIZE=420x560  INTERAXIAL=0.02
    VIEWS=1,2,4,8,16,48,96  MODES="exact fast"  ROUNDS=3  WALL=1
    FLAGS=""  (more flags for every render, e.g. "--max-depth 3")
    CSV=docs/views-cost.csv  PLOT=docs/images/views-cost.png (empty: none)
    SCENES: balls mount tetra tree of ../shared/scenes/spd
"""
import csv
import glob
import math
import os
import resource
import shutil
import subprocess
import sys
import tempfile
import time

import numpy as np
from PIL import Image

MODE_FLAGS = {"exact": [], "fast": ["--fast"], "reproject": ["--reproject"]}
BUDGET_PSNR_DB = 40.0
BUDGET_SHARE_OFF = 0.005
OFF = 16


def env(name, default):
    v = os.environ.get(name)
    return default if v is None else v


def run(cmd):
    """(CPU seconds of the child, wall seconds)."""
    a = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    p = subprocess.run(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    wall = time.perf_counter() - t0
    b = resource.getrusage(resource.RUSAGE_CHILDREN)
    if p.returncode != 0:
        sys.exit("failed: %s\n%s" % (" ".join(cmd), p.stderr))
    return (b.ru_utime - a.ru_utime) + (b.ru_stime - a.ru_stime), wall


def nff_viewpoint(path):
    """The NFF file's from, at and up (float32 vectors)."""
    vp = {}
    with open(path) as f:
        for line in f:
            w = line.split()
            if len(w) == 4 and w[0] in ("from", "at", "up"):
                vp[w[0]] = np.array([float(x) for x in w[1:]], dtype=np.float32)
            if len(vp) == 3:
                break
    if len(vp) != 3:
        sys.exit("%s: no NFF viewpoint (from, at, up)" % path)
    return vp


def unit(v):
    # As rig/camera.rs: scaled by the largest component before normalising.
    v = (v / np.max(np.abs(v))).astype(np.float32)
    return (v / np.float32(np.sqrt(np.dot(v, v)))).astype(np.float32)


def view_cameras(vp, n, b):
    """Each view's (from, at): the rig's offsets (rig/mod.rs, in f32)."""
    forward = unit(vp["at"] - vp["from"])
    right = unit(np.cross(forward, unit(vp["up"])).astype(np.float32))
    cams = []
    for i in range(n):
        off = (np.float32(i) - (np.float32(n) - np.float32(1)) * np.float32(0.5)) * np.float32(b)
        d = (right * off).astype(np.float32)
        cams.append(((vp["from"] + d).astype(np.float32), (vp["at"] + d).astype(np.float32)))
    return cams


def vec(v):
    return ",".join(repr(float(x)) for x in v)


def view_files(stem, n):
    """The files of an N-view render to STEM.png, in view order."""
    if n == 1:
        return [stem + ".png"]
    if n == 2:
        return [stem + "_L.png", stem + "_R.png"]
    files = glob.glob(stem + "_*.png")
    files.sort(key=lambda f: int(f[len(stem) + 1:-4]))
    if len(files) != n:
        sys.exit("%s: %d views written, %d expected" % (stem, len(files), n))
    return files


def load(path):
    return np.asarray(Image.open(path).convert("RGB"), dtype=np.int16)


def difference(a, b):
    """(PSNR dB of the 8-bit images, share of pixels off by > 16/255)."""
    d = a - b
    mse = float(np.mean((d.astype(np.float64) / 255.0) ** 2))
    psnr = math.inf if mse == 0 else 10 * math.log10(1 / mse)
    off = float(np.mean(np.any(np.abs(d) > OFF, axis=2)))
    return psnr, off


def worst(pairs):
    ds = [difference(load(a), load(b)) for a, b in pairs]
    return min(d[0] for d in ds), max(d[1] for d in ds)


def main():
    here = os.path.dirname(os.path.abspath(__file__))
    spd = os.path.join(here, "..", "..", "shared", "scenes", "spd")
    scenes = sys.argv[1:] or [os.path.join(spd, s + ".nff") for s in "balls mount tetra tree".split()]
    binary = env("TWINRAY", "target/release/twinray")
    size = env("SIZE", "420x560")
    b = float(env("INTERAXIAL", "0.02"))
    counts = [int(x) for x in env("VIEWS", "1,2,4,8,16,48,96").split(",")]
    modes = env("MODES", "exact fast").split()
    rounds = int(env("ROUNDS", "3"))
    wall_too = env("WALL", "1") != "0"
    flags = env("FLAGS", "").split()
    if "--samples" not in flags and "--spd" not in flags and "--adaptive" not in flags:
        flags += ["--samples", "1"]
    out_csv = env("CSV", "docs/views-cost.csv")
    plot = env("PLOT", "docs/images/views-cost.png")
    for m in modes:
        if m not in MODE_FLAGS:
            sys.exit("MODES: %s is not one of %s" % (m, " ".join(MODE_FLAGS)))
    if not os.access(binary, os.X_OK):
        sys.exit("%s: build first (cargo build --release --bin twinray)" % binary)
    tmp = tempfile.mkdtemp()
    common = ["--size", size, "-q"] + flags
    rows = []
    commit = subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True,
                            text=True).stdout.strip()
    print("# %s, %s per view, interaxial %s, flags %s, commit %s, %d rounds, %s"
          % (binary, size, b, " ".join(flags), commit, rounds, time.strftime("%Y-%m-%d %H:%M")))
    print("%-7s %3s %-9s %9s %9s %7s %9s %9s %7s  %s" % (
        "scene", "N", "mode", "cpu_s", "mono_cpu", "ratio", "wall_s", "mono_wall", "ratio",
        "images"))
    try:
        for scene in scenes:
            name = os.path.splitext(os.path.basename(scene))[0]
            vp = nff_viewpoint(scene)
            for n in counts:
                cams = view_cameras(vp, n, b)
                rig = [] if n == 1 else ["--views", str(n), "--interaxial", repr(b),
                                        "--convergence", "inf"]
                best = {}
                # A mono render takes no method of several views (--fast
                # refuses one view): at N = 1 only the exact render runs.
                run_modes = [m for m in modes if n > 1 or m == "exact"]
                for _ in range(rounds):
                    for threads in (["1"] + (["all"] if wall_too else [])):
                        th = ["--threads", "1"] if threads == "1" else []
                        shutil.rmtree(os.path.join(tmp, "m"), ignore_errors=True)
                        os.makedirs(os.path.join(tmp, "m"))
                        # The N mono renders, one process each.
                        cpu = wall = 0.0
                        for k, (f, a) in enumerate(cams):
                            c, w = run([binary, "render", scene, "-o",
                                        os.path.join(tmp, "m", "v%d.png" % k), "--from", vec(f),
                                        "--at", vec(a)] + common + th)
                            cpu, wall = cpu + c, wall + w
                        t = cpu if threads == "1" else wall
                        best[("mono", threads)] = min(best.get(("mono", threads), math.inf), t)
                        for m in run_modes:
                            stem = os.path.join(tmp, m)
                            for f in glob.glob(stem + "*.png"):
                                os.remove(f)
                            c, w = run([binary, "render", scene, "-o", stem + ".png"] + rig
                                       + MODE_FLAGS[m] + common + th)
                            t = c if threads == "1" else w
                            best[(m, threads)] = min(best.get((m, threads), math.inf), t)
                monos = [os.path.join(tmp, "m", "v%d.png" % k) for k in range(n)]
                exact = view_files(os.path.join(tmp, "exact"), n) if "exact" in modes else None
                for m in run_modes:
                    files = view_files(os.path.join(tmp, m), n)
                    if m == "exact":
                        psnr, off = worst(zip(files, monos))
                        note = "views = mono renders" if psnr == math.inf else \
                            "against the mono renders: worst %.1f dB" % psnr
                    elif exact:
                        psnr, off = worst(zip(files, exact))
                        ok = psnr >= BUDGET_PSNR_DB and off <= BUDGET_SHARE_OFF
                        note = "worst view %s dB, %.3f %% > 16/255 (%s)" % (
                            "inf" if psnr == math.inf else "%.1f" % psnr, 100 * off,
                            "within the budget" if ok else "OVER THE BUDGET")
                    else:
                        psnr, off, note = math.nan, math.nan, ""
                    cpu, mono_cpu = best[(m, "1")], best[("mono", "1")]
                    wall = best.get((m, "all"), math.nan)
                    mono_wall = best.get(("mono", "all"), math.nan)
                    row = dict(scene=name, size=size, views=n, mode=m, cpu_s=cpu,
                               mono_cpu_s=mono_cpu, ratio_cpu=cpu / mono_cpu, wall_s=wall,
                               mono_wall_s=mono_wall, ratio_wall=wall / mono_wall,
                               per_mono_view=cpu / (mono_cpu / n), psnr_db=psnr,
                               share_off=off, commit=commit)
                    rows.append(row)
                    print("%-7s %3d %-9s %9.3f %9.3f %7.3f %9.3f %9.3f %7.3f  %s" % (
                        name, n, m, cpu, mono_cpu, cpu / mono_cpu, wall, mono_wall,
                        wall / mono_wall, note), flush=True)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    if out_csv:
        with open(out_csv, "w", newline="") as f:
            w = csv.DictWriter(f, fieldnames=list(rows[0]))
            w.writeheader()
            for r in rows:
                w.writerow({k: ("%.6g" % v if isinstance(v, float) else v) for k, v in r.items()})
    if plot:
        try:
            import matplotlib  # noqa: F401
        except ImportError:
            print("(matplotlib not installed: no plot; pip install matplotlib)", file=sys.stderr)
            return
        subprocess.run([sys.executable, os.path.join(here, "plot_views_cost.py"), out_csv, plot],
                       check=True)


if __name__ == "__main__":
    main()
