"""Frames and tiles of twinray renders across machines, on Ray.

Each Ray task runs the ``twinray`` binary on a share of the work (a chunk of
frames with ``--only``, or one tile with ``--tiles N --tile K``); twinray
writes every file atomically under its final name, so a task that dies leaves
nothing partial, and a retried or re-run task skips what is done.
"""

from .driver import RenderFailed, run_frames, run_tiles

__all__ = ["RenderFailed", "run_frames", "run_tiles"]
