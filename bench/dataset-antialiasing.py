#!/usr/bin/env python3
"""The data set generator's anti-aliasing against a 64-sample reference: for
each of the generator's first --scenes scenes (960x540 stereo pairs, seed 1),
the PSNR of the 8-bit views on every pixel and on the edges (pixels where the
reference differs from a neighbour by more than 8/255), and the CPU seconds
of the render alone on one thread, per sampling given as render flags.

    pip install ./python && python3 bench/dataset-antialiasing.py --scenes 8 \\
        samples=4 adaptive=0.125,max_samples=4 adaptive=0.25,max_samples=4
"""

import argparse
import tempfile
import time
from pathlib import Path

import numpy as np

import twinray
from twinray import dataset as ds


def job_flags(index: int, opts: ds.Options, folder: Path):
    """Sample `index`'s scene and rig, as the generator makes them."""
    rng = np.random.default_rng(ds.sample_seed(1, index))
    spec = ds.make_scene(rng, folder, opts)
    scene = twinray.Scene.load(folder / "scene.obj", light=list(spec.lights), background=spec.background)
    w, h = opts.size
    common = dict(size=(w, h), from_=(0, 0, 0), at=(0, 0, -1), up=(0, 1, 0), fov=opts.fov, threads=1)
    focal = twinray.Job(scene, **common).rig["focal_px"]
    b = ds.draw_interaxial(rng, spec, focal, opts)
    budget = f"-{min(int(np.ceil(opts.disparity[1])) + 1, w - 1)}px,1px"
    return scene, dict(stereo=True, interaxial=round(b, 6), convergence="inf", depth_budget=budget, **common)


def views(scene, flags, sampling):
    """The 8-bit views and the render's CPU seconds."""
    job = twinray.Job(scene, **flags, **sampling)
    cpu = time.process_time()
    r = job.render(ground_truth=False)
    return r.display(), time.process_time() - cpu


def psnr(a, b, mask=None):
    d = (a.astype(np.float64) - b.astype(np.float64)) / 255.0
    mse = np.mean(np.square(d[mask] if mask is not None else d))
    return 10 * np.log10(1.0 / mse)


def edges(ref):
    r = ref.astype(np.int16)
    e = np.zeros(r.shape[:-1], bool)
    dx = np.abs(r[..., 1:, :] - r[..., :-1, :]).max(-1) > 8
    dy = np.abs(r[..., 1:, :, :] - r[..., :-1, :, :]).max(-1) > 8
    e[..., 1:] |= dx
    e[..., :-1] |= dx
    e[..., 1:, :] |= dy
    e[..., :-1, :] |= dy
    return e


def sampling_of(text: str):
    out = {}
    for kv in text.split(","):
        k, v = kv.split("=")
        out[k] = float(v) if k == "adaptive" else int(v)
    return out


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--scenes", type=int, default=8)
    p.add_argument("samplings", nargs="+", help="render flags, e.g. samples=4 or adaptive=0.125,max_samples=4")
    a = p.parse_args()
    opts = ds.Options()
    results = {s: [] for s in a.samplings}
    with tempfile.TemporaryDirectory() as tmp:
        for i in range(a.scenes):
            scene, flags = job_flags(i, opts, Path(tmp) / str(i))
            ref, _ = views(scene, flags, dict(samples=64))
            mask = edges(ref)
            for s in a.samplings:
                img, cpu = views(scene, flags, sampling_of(s))
                results[s].append((psnr(img, ref), psnr(img, ref, mask), cpu))
                print(f"scene {i}, {s}: {results[s][-1][0]:.2f} dB, edges {results[s][-1][1]:.2f} dB "
                      f"({mask.mean() * 100:.1f} % of pixels), {cpu:.2f} CPU s", flush=True)
    for s, r in results.items():
        m = np.mean(r, axis=0)
        print(f"{s}: PSNR {m[0]:.2f} dB, edges {m[1]:.2f} dB, render {m[2]:.2f} CPU s a pair")


if __name__ == "__main__":
    main()
