"""Stereo data sets in the manner of FlyingThings3D, with exact labels.

    python -m twinray.dataset --out DIR --pairs N --seed S

Each sample is a random scene: procedural shapes (boxes, spheres,
cylinders) and any models under ``--assets`` (glTF, OBJ, STL, PLY), with
procedural textures (stripes, checkers, smooth noise, rings) in front of a
textured back wall, under random point lights, with
mirrors and glass at a set rate, anti-aliased by adaptive sampling (or
``--samples N`` flat samples per pixel). The stereo rig (parallel cameras, as
SceneFlow's) is drawn so that every visible disparity lies within
``--disparity MIN,MAX`` pixels. Written per sample:

* the SceneFlow layout (``--format sceneflow``, the default):
  ``frames_cleanpass/{left,right}/NNNNNNN.png``,
  ``disparity/{left,right}/NNNNNNN.pfm`` (SceneFlow's sign and PFM:
  one channel, rows bottom to top), and beside them ``depth/``,
  ``occlusion/`` and ``out_of_frame/`` (PNG masks, 255 = set) and
  ``disparity_layer2/`` (PFM, NaN where no mirror or glass);
* or ``--format npy``: ``npy/NNNNNNN/{images,depth,disparity,occluded,
  out_of_frame,layer2_disparity}.npy`` (float views, linear);
* the scene (``scenes/NNNNNNN/scene.obj`` with its .mtl and textures) and
  ``meta/NNNNNNN.json``: its seed and job spec, so that
  ``twinray render --job`` renders it again; at the end ``manifest.json``
  lists every sample in order.

The same seed gives the same bytes (the scene, the rig and the renders
depend on the sample's seed alone, and the renderer's images do not
depend on thread counts). A sample is done when its ``meta`` file exists,
written last; a run that is stopped resumes where it stopped. With
``--address`` the samples are rendered as Ray tasks across a cluster
(a shared file system for ``--out``), through the package's Ray driver.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import os
import sys
import time
from concurrent.futures import ThreadPoolExecutor, as_completed
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Dict, List, Optional, Sequence, Tuple

import numpy as np

#: The data set's format version, in every manifest.
FORMAT_VERSION = 2

#: The anti-aliasing without ``--samples``: the renderer's adaptive
#: sampling (the pixel corners, then a cell split in four where its corners
#: differ by more than ADAPTIVE_THRESHOLD), down to ADAPTIVE_CELLS cells per
#: pixel. Against 64 samples per pixel it comes closer than 4 flat samples
#: per pixel on every scene measured, on the whole image and on the edges,
#: in under half the CPU time (docs/python.md has the measurements).
ADAPTIVE_CELLS = 4
ADAPTIVE_THRESHOLD = 0.125


@dataclass
class Options:
    """What every sample of a run shares (in the manifest)."""

    size: Tuple[int, int] = (960, 540)
    #: Flat samples per pixel; None: adaptive sampling with `adaptive` and
    #: `max_samples` (the render flags').
    samples: Optional[int] = None
    adaptive: float = ADAPTIVE_THRESHOLD
    max_samples: int = ADAPTIVE_CELLS
    disparity: Tuple[float, float] = (2.0, 160.0)
    objects: Tuple[int, int] = (6, 14)
    mirror_rate: float = 0.1
    glass_rate: float = 0.1
    format: str = "sceneflow"
    threads: Optional[int] = None
    fov: float = 50.0
    #: A folder of models (glTF, OBJ, STL, PLY) placed among the shapes.
    assets: Optional[str] = None
    asset_rate: float = 0.3


# ---------------------------------------------------------------------------
# PFM


def write_pfm(path: Path, data: np.ndarray) -> None:
    """Writes a float32 image as PFM (``Pf`` for (H, W), ``PF`` for
    (H, W, 3)), rows bottom to top, little-endian, atomically."""
    data = np.asarray(data, dtype="<f4")
    kind = "PF" if data.ndim == 3 else "Pf"
    h, w = data.shape[:2]
    header = f"{kind}\n{w} {h}\n-1.0\n".encode("ascii")
    _atomic_write(path, header + np.ascontiguousarray(data[::-1]).tobytes())


def read_pfm(path) -> np.ndarray:
    """Reads a PFM file (``PF`` colour or ``Pf`` grey, either byte order)
    as float32, row 0 at the top."""
    with open(path, "rb") as f:
        kind = f.readline().strip()
        if kind not in (b"PF", b"Pf"):
            raise ValueError(f"{path}: not a PFM file")
        dims = f.readline().split()
        while len(dims) < 2:
            dims += f.readline().split()
        w, h = int(dims[0]), int(dims[1])
        scale = float(f.readline())
        channels = 3 if kind == b"PF" else 1
        dtype = "<f4" if scale < 0 else ">f4"
        data = np.frombuffer(f.read(w * h * channels * 4), dtype=dtype)
    if data.size != w * h * channels:
        raise ValueError(f"{path}: truncated PFM")
    shape = (h, w, 3) if channels == 3 else (h, w)
    return data.reshape(shape)[::-1].astype(np.float32)


def _atomic_write(path: Path, data: bytes) -> None:
    """Writes `data` under a temporary name beside `path`, then renames it:
    a file under its final name is whole."""
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    with open(tmp, "wb") as f:
        f.write(data)
    os.replace(tmp, path)


# ---------------------------------------------------------------------------
# Scenes


def sample_seed(seed: int, index: int) -> int:
    """The seed of sample `index` of a run seeded `seed`: independent of the
    other samples, so that any one is made alone."""
    return int(np.random.SeedSequence([seed, index]).generate_state(1, np.uint64)[0] >> 1)


def texture(rng: np.random.Generator, size: int = 128) -> np.ndarray:
    """A procedural texture (H, W, 3), linear: stripes, a checker, smooth
    noise or rings, in two or three random colours."""
    y, x = np.mgrid[0:size, 0:size] / size
    colours = rng.uniform(0.05, 0.95, size=(3, 3))
    kind = rng.integers(4)
    if kind == 0:
        angle = rng.uniform(0, np.pi)
        f = rng.integers(2, 9)
        t = 0.5 + 0.5 * np.sin(2 * np.pi * f * (x * np.cos(angle) + y * np.sin(angle)))
    elif kind == 1:
        n = rng.integers(2, 9)
        t = ((np.floor(x * n) + np.floor(y * n)) % 2).astype(float)
    elif kind == 2:
        grid = rng.uniform(0, 1, size=(6, 6))
        gy, gx = y * 5, x * 5
        i, j = gy.astype(int), gx.astype(int)
        fy, fx = gy - i, gx - j
        t = (grid[i, j] * (1 - fx) * (1 - fy) + grid[i, j + 1] * fx * (1 - fy)
             + grid[i + 1, j] * (1 - fx) * fy + grid[i + 1, j + 1] * fx * fy)
    else:
        cx, cy = rng.uniform(0, 1, 2)
        t = 0.5 + 0.5 * np.cos(2 * np.pi * rng.integers(3, 10) * np.hypot(x - cx, y - cy))
    third = 0.5 + 0.5 * np.sin(2 * np.pi * 3 * (x + 0.5 * y))
    img = (colours[0] * t[..., None] + colours[1] * (1 - t[..., None])) * (0.8 + 0.2 * third[..., None])
    return img.astype(np.float32)


class Mesh:
    """Triangles with texture coordinates, grouped by material, as OBJ text."""

    def __init__(self) -> None:
        self.v: List[str] = []
        self.vt: List[str] = []
        self.faces: List[str] = []

    def add(self, points: np.ndarray, uvs: np.ndarray, quads: Sequence[Tuple[int, ...]], material: str) -> None:
        base = len(self.v)
        self.v += [f"v {p[0]:.6f} {p[1]:.6f} {p[2]:.6f}" for p in points]
        self.vt += [f"vt {u[0]:.6f} {u[1]:.6f}" for u in uvs]
        self.faces.append(f"usemtl {material}")
        for q in quads:
            self.faces.append("f " + " ".join(f"{base + i + 1}/{base + i + 1}" for i in q))

    def text(self, mtl: str) -> str:
        return "\n".join([f"mtllib {mtl}", *self.v, *self.vt, *self.faces]) + "\n"


def _rotation(rng: np.random.Generator) -> np.ndarray:
    q = rng.normal(size=4)
    q /= np.linalg.norm(q)
    a, b, c, d = q
    return np.array([
        [a*a + b*b - c*c - d*d, 2*(b*c - a*d), 2*(b*d + a*c)],
        [2*(b*c + a*d), a*a - b*b + c*c - d*d, 2*(c*d - a*b)],
        [2*(b*d - a*c), 2*(c*d + a*b), a*a - b*b - c*c + d*d],
    ])


def _grid(u: np.ndarray, v: np.ndarray, point) -> Tuple[np.ndarray, np.ndarray, List[Tuple[int, ...]]]:
    """A (len(u) × len(v)) grid of points `point(u, v)`, its quads."""
    uu, vv = np.meshgrid(u, v, indexing="ij")
    pts = point(uu, vv).reshape(-1, 3)
    uvs = np.stack([(uu - u[0]) / (u[-1] - u[0]), (vv - v[0]) / (v[-1] - v[0])], -1).reshape(-1, 2)
    n = len(v)
    quads = [(i * n + j, (i + 1) * n + j, (i + 1) * n + j + 1, i * n + j + 1)
             for i in range(len(u) - 1) for j in range(len(v) - 1)]
    return pts, uvs, quads


def shape(rng: np.random.Generator) -> Tuple[np.ndarray, np.ndarray, List[Tuple[int, ...]]]:
    """A unit-sized procedural shape at the origin: a box, a sphere or a cylinder."""
    kind = rng.integers(3)
    if kind == 0:
        sx, sy, sz = rng.uniform(0.4, 1.0, 3)
        corners = np.array([[x, y, z] for x in (-sx, sx) for y in (-sy, sy) for z in (-sz, sz)])
        faces = [(0, 1, 3, 2), (4, 6, 7, 5), (0, 4, 5, 1), (2, 3, 7, 6), (0, 2, 6, 4), (1, 5, 7, 3)]
        pts = np.concatenate([corners[list(f)] for f in faces])
        uvs = np.tile([[0, 0], [1, 0], [1, 1], [0, 1]], (6, 1))
        quads = [(4 * i, 4 * i + 1, 4 * i + 2, 4 * i + 3) for i in range(6)]
        return pts, uvs, quads
    if kind == 1:
        def sphere(u, v):
            return np.stack([np.sin(v) * np.cos(u), np.cos(v), np.sin(v) * np.sin(u)], -1)

        return _grid(np.linspace(0, 2 * np.pi, 25), np.linspace(1e-3, np.pi - 1e-3, 13), sphere)
    r, hgt = rng.uniform(0.3, 0.8), rng.uniform(0.6, 1.0)

    def cylinder(u, v):
        return np.stack([r * np.cos(u), v, r * np.sin(u)], -1)

    return _grid(np.linspace(0, 2 * np.pi, 25), np.linspace(-hgt, hgt, 2), cylinder)


#: The model files `--assets` takes.
ASSET_TYPES = (".gltf", ".glb", ".obj", ".stl", ".ply")

_asset_triangles: Dict[str, np.ndarray] = {}


def asset_files(folder: Optional[str]) -> List[Path]:
    """The models under `folder`, in a fixed order (their draw depends on it)."""
    if not folder:
        return []
    return sorted(p for p in Path(folder).rglob("*") if p.suffix.lower() in ASSET_TYPES and p.is_file())


def asset_shape(path: Path, rng: np.random.Generator):
    """A model's triangles centred and scaled to a unit radius, with texture
    coordinates projected on two of its axes (its own materials are left
    for a procedural texture, as FlyingThings3D textures its models)."""
    import twinray

    key = str(path)
    if key not in _asset_triangles:
        _asset_triangles[key] = twinray.Scene.load(path).triangles()
    tris = _asset_triangles[key].astype(np.float64)
    if len(tris) == 0:
        return None
    lo, hi = tris.reshape(-1, 3).min(0), tris.reshape(-1, 3).max(0)
    pts = (tris.reshape(-1, 3) - (lo + hi) / 2) / max(float((hi - lo).max()) / 2, 1e-9)
    axes = rng.permutation(3)[:2]
    uvs = (pts[:, axes] + 1) / 2
    faces = [(3 * i, 3 * i + 1, 3 * i + 2) for i in range(len(tris))]
    return pts, uvs, faces


@dataclass
class SceneSpec:
    """What a sample's scene is, beside its files: the depths it spans and
    its lights, for the rig and `Scene.load`."""

    near: float
    far: float
    lights: List[Tuple[Tuple[float, float, float], Tuple[float, float, float]]] = field(default_factory=list)
    background: Tuple[float, float, float] = (0.0, 0.0, 0.0)
    assets: List[str] = field(default_factory=list)


def make_scene(rng: np.random.Generator, folder: Path, opts: Options) -> SceneSpec:
    """Writes a random scene to `folder` (scene.obj, scene.mtl, textures)
    for a camera at the origin looking down −z; returns its depth span."""
    import twinray

    folder.mkdir(parents=True, exist_ok=True)
    w, h = opts.size
    tan_y = np.tan(np.radians(opts.fov) / 2)
    tan_x = tan_y * w / h
    mesh, mtl = Mesh(), []
    wall_z = float(rng.uniform(14, 24))
    # The back wall fills the frame, with room for the views' offsets.
    ww, wh = wall_z * tan_x * 1.6 + 4, wall_z * tan_y * 1.6 + 4
    wall = np.array([[-ww, -wh, -wall_z], [ww, -wh, -wall_z], [ww, wh, -wall_z], [-ww, wh, -wall_z]])
    mesh.add(wall, np.array([[0, 0], [4, 0], [4, 4], [0, 4]]), [(0, 1, 2, 3)], "wall")
    textures = {"wall": texture(rng)}
    mtl.append("newmtl wall\nKd 1 1 1\nKs 0 0 0\nillum 1\nmap_Kd wall.png\n")
    near = wall_z
    models = asset_files(opts.assets)
    used: List[str] = []
    count = int(rng.integers(opts.objects[0], opts.objects[1] + 1))
    for k in range(count):
        z = float(rng.uniform(3.5, wall_z - 2))
        x = float(rng.uniform(-0.9, 0.9)) * z * tan_x
        y = float(rng.uniform(-0.9, 0.9)) * z * tan_y
        scale = float(rng.uniform(0.3, 0.9)) * (1 + z / 10)
        made = None
        if models and rng.uniform() < opts.asset_rate:
            model = models[int(rng.integers(len(models)))]
            made = asset_shape(model, rng)
            if made is not None:
                used.append(str(model.relative_to(opts.assets)))
        pts, uvs, quads = made if made is not None else shape(rng)
        pts = pts @ _rotation(rng).T * scale + [x, y, -z]
        near = min(near, float(-pts[:, 2].max()))
        name = f"m{k}"
        draw = rng.uniform()
        if draw < opts.mirror_rate:
            mtl.append(f"newmtl {name}\nKd 0.05 0.05 0.05\nKs 0.95 0.95 0.95\nNs 1000\nillum 3\n")
        elif draw < opts.mirror_rate + opts.glass_rate:
            mtl.append(f"newmtl {name}\nKd 0.05 0.05 0.05\nKs 0.3 0.3 0.3\nNs 1000\nd 0.1\nNi 1.5\nillum 7\n")
        else:
            ks = rng.uniform(0, 0.3)
            ns = rng.uniform(100, 900)
            mtl.append(f"newmtl {name}\nKd 1 1 1\nKs {ks:.3f} {ks:.3f} {ks:.3f}\nNs {ns:.1f}\nillum 2\nmap_Kd {name}.png\n")
            textures[name] = texture(rng)
        mesh.add(pts, uvs, quads, name)
    for name, tex in textures.items():
        twinray.write_image(folder / f"{name}.png", tex)
    (folder / "scene.mtl").write_text("".join(mtl))
    (folder / "scene.obj").write_text(mesh.text("scene.mtl"))
    lights = []
    for _ in range(int(rng.integers(1, 4))):
        pos = (float(rng.uniform(-8, 8)), float(rng.uniform(2, 10)), float(rng.uniform(-4, 4)))
        col = tuple(float(c) for c in rng.uniform(0.5, 1.0, 3) * rng.uniform(0.6, 1.0))
        lights.append((pos, col))
    return SceneSpec(near=max(near, 0.5), far=wall_z, lights=lights,
                     background=tuple(float(c) for c in rng.uniform(0, 0.3, 3)), assets=used)


def draw_interaxial(rng: np.random.Generator, scene: SceneSpec, focal_px: float, opts: Options) -> float:
    """An interaxial for which every depth in the scene's span has a
    disparity f·b/z within the user's range: b in [MIN·far/f, MAX·near/f]
    (the lower end alone if the span is too deep for the range)."""
    lo = opts.disparity[0] * scene.far / focal_px
    hi = opts.disparity[1] * scene.near / focal_px
    return float(rng.uniform(lo, hi)) if hi > lo else lo


# ---------------------------------------------------------------------------
# Samples


def sample_name(index: int) -> str:
    return f"{index:07d}"


def make_sample(out: Path, seed: int, index: int, opts: Options) -> Dict:
    """Makes sample `index` of the run seeded `seed` under `out`, unless its
    meta file says it is done; returns its manifest entry."""
    import twinray

    name = sample_name(index)
    meta = out / "meta" / f"{name}.json"
    if meta.exists():
        return json.loads(meta.read_text())
    s = sample_seed(seed, index)
    rng = np.random.default_rng(s)
    folder = out / "scenes" / name
    scene_spec = make_scene(rng, folder, opts)
    light = [(p, c) for p, c in scene_spec.lights]
    scene = twinray.Scene.load(folder / "scene.obj", light=light, background=scene_spec.background)
    w, h = opts.size
    sampling = (dict(samples=opts.samples) if opts.samples
                else dict(adaptive=opts.adaptive, max_samples=opts.max_samples))
    common = dict(size=(w, h), from_=(0, 0, 0), at=(0, 0, -1), up=(0, 1, 0), fov=opts.fov,
                  threads=opts.threads, **sampling)
    focal_px = twinray.Job(scene, **common).rig["focal_px"]
    b = draw_interaxial(rng, scene_spec, focal_px, opts)
    # Parallel cameras put everything in front of the screen (twinray's
    # negative disparities): the budget is the user's range (less than the
    # width, as budgets are), so that only a pair beyond it is warned about.
    budget = f"-{min(int(np.ceil(opts.disparity[1])) + 1, w - 1)}px,1px"
    job = twinray.Job(scene, stereo=True, interaxial=round(b, 6), convergence="inf",
                      depth_budget=budget, **common)
    r = job.render()
    files = write_sample(out, name, r, opts)
    spec = job.spec
    spec["scene"] = f"scenes/{name}/scene.obj"
    spec["output"]["path"] = f"scenes/{name}/render.png"
    spec["trace"]["threads"] = None
    entry = {
        "index": index,
        "seed": s,
        "interaxial": round(b, 6),
        "focal_px": r.rig["focal_px"],
        "assets": scene_spec.assets,
        "files": files,
        "spec": spec,
    }
    _atomic_write(meta, json.dumps(entry, indent=1, sort_keys=True).encode())
    return entry


def write_sample(out: Path, name: str, r, opts: Options) -> List[str]:
    """Writes one rendered sample in the chosen format; returns its files,
    relative to `out`."""
    import twinray

    files: List[str] = []

    def put(rel: str) -> Path:
        files.append(rel)
        p = out / rel
        p.parent.mkdir(parents=True, exist_ok=True)
        return p

    if opts.format == "npy":
        for key in ("images", "depth", "disparity", "occluded", "out_of_frame", "layer2_disparity"):
            p = put(f"npy/{name}/{key}.npy")
            import io

            buf = io.BytesIO()
            np.save(buf, getattr(r, key), allow_pickle=False)
            _atomic_write(p, buf.getvalue())
        return files
    for view, side in enumerate(("left", "right")):
        twinray.write_image(put(f"frames_cleanpass/{side}/{name}.png"), r.images[view], r.spec)
        write_pfm(put(f"disparity/{side}/{name}.pfm"), r.disparity[view])
        write_pfm(put(f"depth/{side}/{name}.pfm"), r.depth[view])
        write_pfm(put(f"disparity_layer2/{side}/{name}.pfm"), r.layer2_disparity[view])
        for key in ("occluded", "out_of_frame"):
            mask = np.repeat(getattr(r, key)[view][..., None].astype(np.float32), 3, axis=-1)
            twinray.write_image(put(f"{'occlusion' if key == 'occluded' else key}/{side}/{name}.png"),
                                mask, {"output": {"linear": True}})
    return files


def write_manifest(out: Path, seed: int, entries: List[Dict], opts: Options) -> Path:
    """`manifest.json`: the run's options and every sample, in order."""
    manifest = {
        "format_version": FORMAT_VERSION,
        "seed": seed,
        "options": {k: v for k, v in asdict(opts).items() if k not in ("threads", "assets")},
        "samples": sorted(entries, key=lambda e: e["index"]),
    }
    path = out / "manifest.json"
    _atomic_write(path, json.dumps(manifest, indent=1, sort_keys=True).encode())
    return path


#: The folders a run writes (and cleans of a stopped run's temporary files).
FOLDERS = ("frames_cleanpass", "disparity", "depth", "disparity_layer2", "occlusion",
           "out_of_frame", "npy", "scenes", "meta")


def remove_temporaries(out: Path) -> None:
    """Removes the temporary files a stopped run left (``.NAME.PID.tmp``
    here, ``.twinray-*.tmp`` from the library): a file under its final name
    is whole, the others are not kept."""
    for folder in FOLDERS:
        for p in (out / folder).rglob(".*.tmp"):
            p.unlink(missing_ok=True)


def generate(out, pairs: int, seed: int, opts: Optional[Options] = None, progress: bool = False) -> Path:
    """Makes samples 0..pairs-1 in this process (those not done yet) and
    the manifest; returns the manifest's path."""
    from tqdm import tqdm

    out, opts = Path(out), opts or Options()
    remove_temporaries(out)
    # A render keeps the cores busy only part of the time (the scene, the
    # depth pass and the files are one thread's work), so without --threads
    # each core makes its own samples, one render thread each (the render
    # releases the GIL; a sample's bytes do not depend on its threads).
    workers = 1 if opts.threads else max(1, min(os.cpu_count() or 1, pairs))
    each = opts if workers == 1 else dataclasses.replace(opts, threads=1)
    pool = ThreadPoolExecutor(workers)
    try:
        futures = [pool.submit(make_sample, out, seed, i, each) for i in range(pairs)]
        entries = [f.result() for f in tqdm(as_completed(futures), total=pairs, unit="pair", disable=not progress)]
    finally:
        # Ctrl-C or an error: the samples not started are dropped, the ones
        # under way finish (a rerun resumes after them).
        pool.shutdown(cancel_futures=True)
    return write_manifest(out, seed, entries, opts)


def generate_on_ray(out, pairs: int, seed: int, opts: Optional[Options] = None, progress: bool = False,
                    cpus_per_task: float = 1, max_retries: int = 2, chunk: int = 4) -> Path:
    """`generate` with chunks of samples as Ray tasks (retried where a
    worker dies; a retry skips the samples done), with a progress bar.
    Ray must be initialised."""
    import ray
    from tqdm import tqdm

    out, opts = Path(out).resolve(), opts or Options()
    remove_temporaries(out)

    @ray.remote
    def share(first: int, last: int) -> List[Dict]:
        o = dataclasses.replace(opts, threads=opts.threads or max(1, int(cpus_per_task)))
        return [make_sample(out, seed, i, o) for i in range(first, last)]

    pending = {}
    for first in range(0, pairs, chunk):
        last = min(pairs, first + chunk)
        ref = share.options(num_cpus=cpus_per_task, max_retries=max_retries).remote(first, last)
        pending[ref] = (first, last)
    entries: List[Dict] = []
    failures: List[str] = []
    with tqdm(total=pairs, unit="pair", disable=not progress, file=sys.stderr) as bar:
        while pending:
            done, _ = ray.wait(list(pending), num_returns=1)
            for ref in done:
                first, last = pending.pop(ref)
                try:
                    entries += ray.get(ref)
                except Exception as err:  # a share that failed every attempt
                    failures.append(f"pairs {first}..{last - 1}: {str(err).strip().splitlines()[-1:]}")
                bar.update(last - first)
    if failures:
        raise RuntimeError(f"{len(failures)} share(s) failed {max_retries + 1} times: " + "; ".join(failures))
    return write_manifest(out, seed, entries, opts)


def _pair(text: str, kind=float) -> Tuple:
    a, b = text.replace("x", ",").split(",")
    return kind(a), kind(b)


def parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="python -m twinray.dataset", description=__doc__.split("\n\n")[0])
    p.add_argument("--out", required=True, help="output folder (made if missing; a run there resumes)")
    p.add_argument("--pairs", type=int, required=True, help="number of stereo pairs")
    p.add_argument("--seed", type=int, default=0, help="the run's seed (default 0)")
    p.add_argument("--size", type=lambda t: _pair(t, int), default=(960, 540), metavar="WxH")
    p.add_argument("--samples", type=int,
                   help="N flat anti-aliasing samples per pixel (default: adaptive: the pixel corners, "
                        f"then cells split where they differ by {ADAPTIVE_THRESHOLD}, down to {ADAPTIVE_CELLS} a pixel)")
    p.add_argument("--disparity", type=_pair, default=(2.0, 160.0), metavar="MIN,MAX",
                   help="disparity range of every pair, in pixels (default 2,160)")
    p.add_argument("--mirror-rate", type=float, default=0.1, help="share of objects that are mirrors")
    p.add_argument("--glass-rate", type=float, default=0.1, help="share of objects that are glass")
    p.add_argument("--format", choices=["sceneflow", "npy"], default="sceneflow")
    p.add_argument("--assets", help="a folder of glTF, OBJ, STL or PLY models placed among the shapes")
    p.add_argument("--asset-rate", type=float, default=0.3,
                   help="share of objects drawn from --assets (default 0.3)")
    p.add_argument("--threads", type=int, help="render threads per sample, one sample at a time (default: one sample per core, one thread each)")
    p.add_argument("--address", help="Ray cluster ('auto': the one this machine joined)")
    p.add_argument("--cpus-per-task", type=float, default=1, help="CPUs a Ray task reserves")
    p.add_argument("-q", "--quiet", action="store_true", help="no progress bar")
    return p


def main(argv: Optional[List[str]] = None) -> int:
    a = parser().parse_args(argv)
    if a.pairs < 0 or (a.samples is not None and a.samples < 1) or not 0 <= a.mirror_rate + a.glass_rate <= 1:
        print("twinray.dataset: --pairs >= 0, --samples >= 1, and the rates add up to at most 1",
              file=sys.stderr)
        return 2
    if not 0 < a.disparity[0] < a.disparity[1]:
        print("twinray.dataset: --disparity MIN,MAX with 0 < MIN < MAX", file=sys.stderr)
        return 2
    opts = Options(size=a.size, samples=a.samples, disparity=a.disparity, mirror_rate=a.mirror_rate,
                   glass_rate=a.glass_rate, format=a.format, threads=a.threads,
                   assets=a.assets and str(Path(a.assets).resolve()), asset_rate=a.asset_rate)
    if a.assets and not asset_files(opts.assets):
        print(f"twinray.dataset: no .gltf, .glb, .obj, .stl or .ply file under {a.assets}", file=sys.stderr)
        return 2
    start = time.monotonic()
    try:
        if a.address:
            import ray

            ray.init(address=a.address, log_to_driver=False)
            path = generate_on_ray(a.out, a.pairs, a.seed, opts, progress=not a.quiet,
                                   cpus_per_task=a.cpus_per_task)
        else:
            path = generate(a.out, a.pairs, a.seed, opts, progress=not a.quiet)
    except KeyboardInterrupt:
        print("twinray.dataset: stopped; run the same command again to resume", file=sys.stderr)
        return 130
    seconds = time.monotonic() - start
    print(f"twinray.dataset: {a.pairs} pair(s) in {path.parent} ({seconds:.1f} s); manifest {path}",
          file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
