"""The Python API: shapes and dtypes, one scene planned with two rigs, the
arrays against the CLI's PFM files, disparity against geometry, occlusion
against warping, the mirror's second layer, progress and cancelling."""

from __future__ import annotations

import os
import subprocess
import threading
import time
import _thread
from pathlib import Path

import numpy as np
import pytest

import twinray
from twinray.dataset import read_pfm

REPO = Path(__file__).resolve().parents[2]
EXAMPLE = REPO / "scenes" / "example.nff"


def nff(path: Path, body: str, size=(96, 64), fov=40.0) -> Path:
    """A scene looking down -z from the origin, with `body` after the camera."""
    w, h = size
    path.write_text(
        "b 0.1 0.1 0.1\nv\nfrom 0 0 0\nat 0 0 -1\nup 0 1 0\n"
        f"angle {fov}\nhither 0.01\nresolution {w} {h}\nl 0 5 5\n{body}"
    )
    return path


def quad(z: float, half: float) -> str:
    """A square facing +z at depth `z`, `half` wide each way."""
    return (
        f"p 4\n{-half} {-half} {z}\n{half} {-half} {z}\n{half} {half} {z}\n{-half} {half} {z}\n"
    )


def scene_flow(rig, view: int, z: float) -> float:
    """SceneFlow's disparity of depth z from view `view` to its neighbour."""
    views = rig["views"]
    n = 1 if view + 1 < len(views) else -1
    a, b = views[view], views[view + n]
    # The point's column in b minus its column in a (the library's pair disparity).
    moved = a["shift"] - b["shift"] - rig["focal_px"] * (b["offset"] - a["offset"]) / z
    return -moved if b["offset"] > a["offset"] else moved


@pytest.fixture(scope="module")
def example():
    return twinray.Scene.load(EXAMPLE)


def test_shapes_and_dtypes_and_one_scene_with_two_rigs(example):
    pair = twinray.Job(example, size=(64, 48), stereo=True, interaxial=0.2, samples=4)
    r = pair.render()
    assert r.images.shape == (2, 48, 64, 3) and r.images.dtype == np.float32
    for name in ("depth", "disparity", "layer2_depth", "layer2_disparity"):
        a = getattr(r, name)
        assert a.shape == (2, 48, 64) and a.dtype == np.float32, name
    for name in ("occluded", "out_of_frame"):
        a = getattr(r, name)
        assert a.shape == (2, 48, 64) and a.dtype == np.bool_, name
    assert r.rig["interaxial"] == pytest.approx(0.2)
    assert len(r.rig["views"]) == 2
    assert r.display().shape == (2, 48, 64, 3) and r.display().dtype == np.uint8

    # The same loaded scene, planned again with four views further apart.
    quad_rig = twinray.Job(example, size=(64, 48), views=4, interaxial=0.5, convergence="inf")
    r4 = quad_rig.render(ground_truth=False)
    assert r4.images.shape == (4, 48, 64, 3) and r4.disparity is None
    assert [v["shift"] for v in r4.rig["views"]] == [0, 0, 0, 0]
    # The spec round-trips: the same job from its dict renders the same views.
    again = twinray.Job(example, spec=quad_rig.spec).render(ground_truth=False)
    assert np.array_equal(again.images, r4.images)


def test_bad_flags_are_value_errors(example):
    with pytest.raises(ValueError, match="samples"):
        twinray.Job(example, samples="many")
    with pytest.raises(ValueError):
        twinray.Job(example, no_such_flag=1)
    with pytest.raises(ValueError, match="Scene.load"):
        twinray.Job(example, ground=True)
    with pytest.raises(OSError, match="such.nff"):
        twinray.Scene.load(REPO / "no" / "such.nff")


def cli_binary() -> str:
    path = os.environ.get("TWINRAY_BIN") or str(REPO / "target" / "release" / "twinray")
    if not Path(path).exists():
        pytest.skip("no twinray binary (set TWINRAY_BIN)")
    return path


def test_images_equal_the_clis_pfm_files(example, tmp_path):
    flags = dict(size=(48, 32), stereo=True, interaxial=0.3, samples=4)
    r = twinray.Job(example, **flags).render(ground_truth=False)
    out = tmp_path / "pair.pfm"
    subprocess.run(
        [cli_binary(), "render", str(EXAMPLE), "-o", str(out), "-q", "--size", "48x32",
         "--stereo", "--interaxial", "0.3", "--samples", "4"],
        check=True,
    )
    for view, name in enumerate(["pair_L.pfm", "pair_R.pfm"]):
        assert np.array_equal(read_pfm(tmp_path / name), r.images[view]), name


@pytest.mark.parametrize("convergence", ["inf", "4"])
@pytest.mark.parametrize("interaxial", [0.1, 0.35])
def test_a_fronto_parallel_plane_has_disparity_f_b_over_z(tmp_path, convergence, interaxial):
    z = 6.0
    scene = twinray.Scene.load(nff(tmp_path / "plane.nff", "f 0.8 0.8 0.8 1 0 1 0 1\n" + quad(-z, 50)))
    for views in (2, 3):
        r = twinray.Job(scene, views=views, interaxial=interaxial, convergence=convergence,
                        samples=1).render()
        rig = r.rig
        assert np.all(np.isfinite(r.depth))
        np.testing.assert_allclose(r.depth, z, rtol=2e-6)
        for v in range(views):
            expected = scene_flow(rig, v, z)
            assert np.max(np.abs(r.disparity[v] - expected)) < 1e-4
        if convergence == "inf":
            f, b = rig["focal_px"], interaxial
            np.testing.assert_allclose(r.disparity, f * b / z, atol=1e-4)
        else:
            assert any(v["shift"] != 0 for v in rig["views"])
        # Nothing hides the plane; the columns beyond the neighbour's edge are out of frame.
        assert not r.occluded.any()
        d = abs(scene_flow(rig, 0, z))
        cols = int(np.ceil(d - 0.5)) if d > 0.5 else 0
        assert r.out_of_frame[0].sum() == cols * r.images.shape[1]


def texture_scene(tmp_path: Path) -> Path:
    """A textured diffuse floor and a textured box in front of a textured wall
    (OBJ with map_Kd), lit by one light: Lambert only."""
    tex = np.zeros((64, 64, 3), np.float32)
    yy, xx = np.mgrid[0:64, 0:64] / 64.0
    tex[..., 0] = 0.5 + 0.4 * np.sin(2 * np.pi * 2 * xx)
    tex[..., 1] = 0.5 + 0.4 * np.sin(2 * np.pi * 3 * yy)
    tex[..., 2] = 0.5 + 0.4 * np.cos(2 * np.pi * (xx + yy))
    twinray.write_image(tmp_path / "wall.png", tex, {"output": {"linear": True}})
    twinray.write_image(tmp_path / "box.png", 1.0 - tex, {"output": {"linear": True}})
    (tmp_path / "s.mtl").write_text(
        "newmtl wall\nKd 1 1 1\nKs 0 0 0\nillum 1\nmap_Kd wall.png\n"
        "newmtl box\nKd 1 1 1\nKs 0 0 0\nillum 1\nmap_Kd box.png\n"
    )
    v, vt, f = [], [], []

    def face(corners, mtl):
        f.append(f"usemtl {mtl}")
        base = len(v)
        for c, t in zip(corners, [(0, 0), (1, 0), (1, 1), (0, 1)]):
            v.append("v %g %g %g" % c)
            vt.append("vt %g %g" % t)
        f.append("f " + " ".join(f"{base + i + 1}/{base + i + 1}" for i in range(4)))

    face([(-6, -4, -10), (6, -4, -10), (6, 4, -10), (-6, 4, -10)], "wall")
    # The box's front and its two sides, 5 units away.
    face([(-1, -1, -5), (1, -1, -5), (1, 1, -5), (-1, 1, -5)], "box")
    face([(-1, -1, -7), (-1, -1, -5), (-1, 1, -5), (-1, 1, -7)], "box")
    face([(1, -1, -5), (1, -1, -7), (1, 1, -7), (1, 1, -5)], "box")
    (tmp_path / "s.obj").write_text("mtllib s.mtl\n" + "\n".join(v + vt + f) + "\n")
    return tmp_path / "s.obj"


def bilinear(img: np.ndarray, x: np.ndarray, y: np.ndarray) -> np.ndarray:
    x0 = np.clip(np.floor(x).astype(int), 0, img.shape[1] - 2)
    fx = np.clip(x - x0, 0, 1)[..., None]
    return img[y, x0] * (1 - fx) + img[y, x0 + 1] * fx


def psnr(a: np.ndarray, b: np.ndarray) -> float:
    mse = float(np.mean((a - b) ** 2))
    return 10 * np.log10(1.0 / mse)


def test_warping_the_right_view_by_the_left_disparity_gives_the_left_view(tmp_path):
    scene = twinray.Scene.load(texture_scene(tmp_path), light=[((0, 3, 2),)])
    r = twinray.Job(scene, size=(160, 120), from_=(0, 0, 0), at=(0, 0, -1), up=(0, 1, 0),
                    fov=50, stereo=True, interaxial=0.4, convergence="inf", samples=1).render()
    left, right = r.images
    h, w = r.depth.shape[1:]
    ys, xs = np.mgrid[0:h, 0:w]
    src = xs - r.disparity[0]
    warped = bilinear(right, src, ys)
    good = ~r.occluded[0] & ~r.out_of_frame[0] & (src >= 0) & (src <= w - 1)
    hidden = r.occluded[0] & ~r.out_of_frame[0]
    assert good.mean() > 0.7 and hidden.sum() > 100
    assert psnr(warped[good], left[good]) >= 35
    # Where the mask says hidden, the right view shows the box, not the wall.
    assert psnr(warped[hidden], left[hidden]) < 20


def test_a_flat_mirror_gives_the_disparity_of_the_virtual_image(tmp_path):
    # A mirror 4 units in front of the camera, a wall 3 units behind it: the
    # wall's image in the mirror lies 4 + 4 + 3 = 11 units away.
    body = ("f 0.9 0.9 0.9 0 1 1 0 1\n" + quad(-4, 40)
            + "f 0.8 0.3 0.2 1 0 1 0 1\np 4\n-40 -40 3\n-40 40 3\n40 40 3\n40 -40 3\n")
    scene = twinray.Scene.load(nff(tmp_path / "mirror.nff", body))
    r = twinray.Job(scene, stereo=True, interaxial=0.25, convergence="inf", samples=1).render()
    np.testing.assert_allclose(r.depth, 4.0, rtol=2e-6)
    f = r.rig["focal_px"]
    np.testing.assert_allclose(r.layer2_depth, 11.0, rtol=1e-4)
    np.testing.assert_allclose(r.layer2_disparity, f * 0.25 / 11.0, atol=1e-4)
    np.testing.assert_allclose(r.disparity, f * 0.25 / 4.0, atol=1e-4)
    # A diffuse surface has no second layer.
    diffuse = twinray.Scene.load(nff(tmp_path / "wall.nff", "f 1 1 1 1 0 1 0 1\n" + quad(-4, 40)))
    d = twinray.Job(diffuse, stereo=True, interaxial=0.25, samples=1).render()
    assert np.isnan(d.layer2_depth).all() and np.isnan(d.layer2_disparity).all()


def test_progress_is_reported_and_ctrl_c_stops_the_render(example):
    job = twinray.Job(example, size=(320, 240), stereo=True, interaxial=0.2, samples=16)
    seen = []
    job.render(progress=lambda done, total: seen.append((done, total)), ground_truth=False)
    assert seen and seen[-1][0] == seen[-1][1] > 0

    # An exception from the callback stops the render and is raised.
    class Stop(Exception):
        pass

    def stop(done, total):
        raise Stop()

    with pytest.raises(Stop):
        job.render(progress=stop)

    # SIGINT, as Ctrl-C sends it, while the GIL is released: the render (a
    # minute of work) stops within a row of samples, not at its end.
    big = twinray.Job(example, size=(1280, 960), stereo=True, samples=64)
    timer = threading.Timer(0.2, _thread.interrupt_main)
    start = time.monotonic()
    timer.start()
    with pytest.raises(KeyboardInterrupt):
        big.render()
    timer.cancel()
    assert time.monotonic() - start < 10
