"""twinray: stereo and multi-view ray tracing, with exact ground truth.

A scene is loaded once; a job plans a render of it (camera, rig, method)
from ``twinray render``'s flags; its render returns every view as numpy
arrays with the depth, the disparity to the neighbouring view, the
occlusion and out-of-frame masks, and the second layer of mirrors and glass.

>>> import twinray
>>> scene = twinray.Scene.load("scenes/example.nff")
>>> job = twinray.Job(scene, size=(960, 540), stereo=True, interaxial=0.2, samples=4)
>>> result = job.render()
>>> result.images.shape, result.disparity.shape
((2, 540, 960, 3), (2, 540, 960))

The arrays' exact definitions are in docs/python.md. ``twinray.dataset``
generates stereo data sets; ``twinray.ray`` spreads renders of the
``twinray`` binary over a Ray cluster (the ``twinray-ray`` command).
"""

from __future__ import annotations

from ._native import Scene, __version__
from ._native import display as _display
from ._native import write_image as _write_image
from ._job import Job, Result

__all__ = ["Scene", "Job", "Result", "write_image", "__version__"]


def write_image(path, image, spec=None) -> None:
    """Writes one view ``(H, W, 3)`` (linear float32) to ``path`` as the CLI
    writes it: .png and .jpg 8-bit with the display transform of ``spec``
    (a job's spec dict; default: sRGB, no exposure or tone curve), .exr and
    .pfm as floats. The file is written under a temporary name and renamed:
    it is whole or absent."""
    import numpy as np

    _write_image(str(path), np.ascontiguousarray(image, dtype=np.float32), spec or {})
