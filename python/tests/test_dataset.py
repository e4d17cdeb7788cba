"""The data set generator: samples read back by a PFM reader with their
labels in the asked disparity range, the same seed giving the same bytes,
and a run killed midway resuming to the same bytes."""

from __future__ import annotations

import dataclasses
import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from twinray import dataset
from twinray.dataset import Options, generate, read_pfm, write_pfm

SMALL = Options(size=(64, 40), samples=1, objects=(3, 6), mirror_rate=0.2, glass_rate=0.2)
# The generator's own anti-aliasing: adaptive sampling.
ADAPTIVE = dataclasses.replace(SMALL, samples=None)


def tree(root: Path) -> dict:
    """Every file under `root` by relative path, with its bytes."""
    return {str(p.relative_to(root)): p.read_bytes() for p in sorted(root.rglob("*")) if p.is_file()}


def test_pfm_round_trip(tmp_path):
    grey = np.arange(12, dtype=np.float32).reshape(3, 4) - 5.5
    colour = np.random.default_rng(1).random((2, 5, 3), dtype=np.float32)
    write_pfm(tmp_path / "g.pfm", grey)
    write_pfm(tmp_path / "c.pfm", colour)
    assert (tmp_path / "g.pfm").read_bytes().startswith(b"Pf\n4 3\n-1.0\n")
    assert np.array_equal(read_pfm(tmp_path / "g.pfm"), grey)
    assert np.array_equal(read_pfm(tmp_path / "c.pfm"), colour)


def test_twenty_samples_read_back_with_their_labels(tmp_path):
    manifest = json.loads(generate(tmp_path, 20, seed=7, opts=SMALL).read_text())
    assert [s["index"] for s in manifest["samples"]] == list(range(20))
    lo, hi = SMALL.disparity
    mirrors = 0
    for s in manifest["samples"]:
        name = f"{s['index']:07d}"
        for side in ("left", "right"):
            d = read_pfm(tmp_path / "disparity" / side / f"{name}.pfm")
            z = read_pfm(tmp_path / "depth" / side / f"{name}.pfm")
            assert d.shape == (40, 64) and d.dtype == np.float32
            assert np.isfinite(d).all() and np.isfinite(z).all()
            # Every visible point within the asked range, and d = f·b/z.
            assert d.min() >= lo - 1e-3 and d.max() <= hi + 1e-3
            np.testing.assert_allclose(d, s["focal_px"] * s["interaxial"] / z, rtol=1e-4)
            layer2 = read_pfm(tmp_path / "disparity_layer2" / side / f"{name}.pfm")
            mirrors += int(np.isfinite(layer2).sum())
            assert (tmp_path / "frames_cleanpass" / side / f"{name}.png").read_bytes()[:4] == b"\x89PNG"
        # The manifest's spec renders the sample again.
        assert s["spec"]["scene"] == f"scenes/{name}/scene.obj"
        assert float(s["spec"]["rig"]["interaxial"]) == pytest.approx(s["interaxial"])
    assert mirrors > 0


def test_the_same_seed_gives_the_same_bytes(tmp_path):
    generate(tmp_path / "a", 3, seed=11, opts=ADAPTIVE)
    # one sample at a time on two render threads, as --threads 2 makes them
    generate(tmp_path / "b", 3, seed=11, opts=dataclasses.replace(ADAPTIVE, threads=2))
    generate(tmp_path / "c", 3, seed=12, opts=ADAPTIVE)
    a, b, c = (tree(tmp_path / x) for x in "abc")
    assert a == b
    frames = [k for k in a if k.startswith("frames_cleanpass/")]
    assert len(frames) == 6 and all(a[k] != c[k] for k in frames)


def test_without_samples_the_views_are_sampled_adaptively(tmp_path):
    assert Options().samples is None
    out = tmp_path / "default"
    assert dataset.main(["--out", str(out), "--pairs", "1", "--size", "48x32", "-q"]) == 0
    manifest = json.loads((out / "manifest.json").read_text())
    options = manifest["options"]
    assert (options["samples"], options["adaptive"], options["max_samples"]) == (None, 0.125, 4)
    sampling = manifest["samples"][0]["spec"]["sampling"]
    assert (sampling["samples"], sampling["adaptive"], sampling["max_samples"]) == (None, 0.125, 4)
    # --samples N is the user's: flat sampling, in the spec too.
    flat = tmp_path / "flat"
    assert dataset.main(["--out", str(flat), "--pairs", "1", "--size", "48x32", "--samples", "2", "-q"]) == 0
    sampling = json.loads((flat / "manifest.json").read_text())["samples"][0]["spec"]["sampling"]
    assert sampling["samples"] == 2 and sampling["max_samples"] is None
    a = (out / "frames_cleanpass" / "left" / "0000000.png").read_bytes()
    assert a != (flat / "frames_cleanpass" / "left" / "0000000.png").read_bytes()


def test_a_killed_run_resumes_to_the_same_bytes(tmp_path):
    args = ["--pairs", "6", "--seed", "3", "--size", "64x40", "--samples", "1", "-q"]
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(sys.path))
    run = [sys.executable, "-m", "twinray.dataset", "--out", str(tmp_path / "killed"), *args]
    proc = subprocess.Popen(run, env=env)
    meta = tmp_path / "killed" / "meta"
    deadline = time.monotonic() + 120
    while not (meta.is_dir() and len(list(meta.iterdir())) >= 2):
        assert proc.poll() is None and time.monotonic() < deadline, "no sample written"
        time.sleep(0.02)
    proc.send_signal(signal.SIGKILL)
    proc.wait()
    done_before = len(list(meta.iterdir()))
    assert done_before < 6 and not (tmp_path / "killed" / "manifest.json").exists()
    subprocess.run(run, env=env, check=True)
    whole = [sys.executable, "-m", "twinray.dataset", "--out", str(tmp_path / "whole"), *args]
    subprocess.run(whole, env=env, check=True)
    assert tree(tmp_path / "killed") == tree(tmp_path / "whole")


def test_models_under_assets_are_placed_among_the_shapes(tmp_path):
    models = tmp_path / "models"
    models.mkdir()
    corners = [(0, 0, 0), (1, 0, 0), (0, 1, 0), (0, 0, 1)]
    faces = [(0, 2, 1), (0, 1, 3), (0, 3, 2), (1, 2, 3)]
    stl = ["solid tetra"]
    for f in faces:
        stl += ["facet normal 0 0 0", "outer loop"]
        stl += ["vertex %g %g %g" % corners[i] for i in f]
        stl += ["endloop", "endfacet"]
    (models / "tetra.stl").write_text("\n".join(stl + ["endsolid tetra"]) + "\n")
    opts = Options(size=(48, 32), samples=1, objects=(3, 4), assets=str(models), asset_rate=1.0)
    manifest = json.loads(generate(tmp_path / "out", 2, seed=1, opts=opts).read_text())
    for s in manifest["samples"]:
        assert s["assets"] and set(s["assets"]) == {"tetra.stl"}
        obj = (tmp_path / "out" / s["spec"]["scene"]).read_text()
        # Every object a tetrahedron of four triangles; the wall one quad.
        assert obj.count("\nf ") == 4 * len(s["assets"]) + 1
