"""The Python face of a job and of its render."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Callable, Dict, List, Optional, Tuple

import numpy as np

from . import _native


@dataclass
class Result:
    """A render: every view, and its ground truth (docs/python.md).

    Arrays are indexed ``[view, row, column]``, views left to right, row 0
    at the top; the ground truth is taken at each pixel's centre.

    * ``images``: float32 ``(views, H, W, 3)``, linear RGB, the values of
      the CLI's .pfm and .exr files; ``display()`` gives the 8-bit pixels
      of its .png files.
    * ``depth``: float32 ``(views, H, W)``, the camera depth (along the view
      direction) of the surface seen, in scene units; ``inf`` where none.
    * ``disparity``: float32 ``(views, H, W)``, pixels to the neighbouring
      view with SceneFlow's sign: a point at column ``x`` of a view is at
      ``x - d`` in the view to its right; the last view's neighbour is the
      one to its left, where the point is at ``x + d``. ``f*b/z`` for
      parallel cameras, less ``f*b/C`` with convergence at ``C``.
    * ``occluded``: bool ``(views, H, W)``: the neighbour's ray to the point
      meets another surface first.
    * ``out_of_frame``: bool ``(views, H, W)``: the point falls outside the
      neighbour's image.
    * ``layer2_depth``, ``layer2_disparity``: float32 ``(views, H, W)``:
      where the surface is a mirror or glass, the depth and disparity of
      what it shows (from the path length through it); NaN elsewhere.
    * ``rig``: the views' offsets and shifts, interaxial, convergence,
      focal length in pixels, camera.
    * ``spec``: the job's spec dict (``--print-job``), to render it again.

    The ground-truth arrays are ``None`` when ``render(ground_truth=False)``.
    """

    images: np.ndarray
    rig: Dict[str, Any]
    spec: Dict[str, Any]
    seconds: float
    depth: Optional[np.ndarray] = None
    disparity: Optional[np.ndarray] = None
    occluded: Optional[np.ndarray] = None
    out_of_frame: Optional[np.ndarray] = None
    layer2_depth: Optional[np.ndarray] = None
    layer2_disparity: Optional[np.ndarray] = None
    messages: List[Tuple[str, str]] = field(default_factory=list)

    @property
    def views(self) -> int:
        """Number of views."""
        return int(self.images.shape[0])

    def display(self) -> np.ndarray:
        """The views as uint8 ``(views, H, W, 3)``: the pixels of the CLI's
        8-bit files (the spec's exposure and tone curve, then sRGB unless
        ``linear``)."""
        return _native.display(np.ascontiguousarray(self.images), self.spec)


class Job:
    """A render of a loaded scene, checked and planned.

    ``Job(scene, **flags)`` takes ``twinray render``'s flags with
    underscores: ``size=(960, 540)``, ``stereo=True``, ``views=8``,
    ``interaxial=0.2``, ``convergence="inf"``, ``samples=4``,
    ``fast=True``, ``from_=(x, y, z)``, ``at=(x, y, z)``, ``fov=40``,
    ``threads=2``, ... A flag without a value takes ``True``; ``None`` and
    ``False`` leave a flag out. ``Job(scene, spec=d)`` takes a whole spec
    dict, as ``twinray render --print-job`` prints it and ``job.spec``
    returns (its scene is ``scene``).

    The scene is not read again: any number of jobs (other rigs, cameras,
    sizes) share it and its hierarchy. A bad flag or value raises
    ``ValueError`` with the command line's message.
    """

    def __init__(self, scene: _native.Scene, spec: Optional[Dict[str, Any]] = None, **flags: Any):
        self._job = _native.Job(scene, spec, **flags)

    @property
    def spec(self) -> Dict[str, Any]:
        """The job as a spec dict (``--print-job``'s JSON)."""
        return self._job.spec

    @property
    def rig(self) -> Dict[str, Any]:
        """The planned rig: ``views`` (each ``offset`` along the camera's
        right axis and whole-pixel ``shift``), ``interaxial``,
        ``convergence``, ``effective_convergence``, ``focal_px``, ``width``,
        ``height``, ``camera``."""
        return self._job.rig

    @property
    def views(self) -> int:
        """Number of views."""
        return self._job.views

    @property
    def size(self) -> Tuple[int, int]:
        """(width, height) of each view."""
        return self._job.size

    @property
    def messages(self) -> List[Tuple[str, str]]:
        """What checking and planning said: (level, text) pairs."""
        return self._job.messages

    def render(
        self,
        progress: Optional[Callable[[int, int], Any]] = None,
        ground_truth: bool = True,
    ) -> Result:
        """Renders every view; with ``ground_truth`` (the default) also the
        depth, disparity, occlusion, out-of-frame and second-layer arrays.

        The GIL is released while rendering. ``progress(done, total)`` is
        called on this thread about ten times a second, and once at the
        end with ``done == total``. Ctrl-C, or an exception raised by ``progress``,
        stops the render within a row of samples and is raised here.
        """
        out = self._job.render(progress, ground_truth)
        return Result(spec=self.spec, messages=self.messages, **out)

    def __repr__(self) -> str:
        return repr(self._job)
