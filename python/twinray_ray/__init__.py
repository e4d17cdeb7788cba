"""Frames and tiles of twinray renders across machines, on Ray.

Each Ray task runs the ``twinray`` binary on a share of the work (a chunk of
frames with ``--only``, or one tile with ``--tiles N --tile K``); twinray
writes every file atomically under its final name, so a task that dies leaves
nothing partial. A record beside the outputs says which job made them, so a
re-run (or a retried task) renders only what that job has not done.
"""

from .binary import BinaryNotFound, find_twinray
from .driver import Interrupted, RenderFailed, run_frames, run_tiles

__all__ = ["BinaryNotFound", "Interrupted", "RenderFailed", "find_twinray", "run_frames", "run_tiles"]
