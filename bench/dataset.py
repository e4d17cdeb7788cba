#!/usr/bin/env python3
"""Pairs per second of the data set generator at its defaults (960x540,
adaptive sampling, ground truth, PNG and PFM files), in one process on every
core: the best of --runs runs of --pairs pairs each, with the process's CPU
time beside the wall time.

    pip install ./python && python3 bench/dataset.py [--pairs 10] [--runs 3] [--samples N]

On a quiet 2-core AMD EPYC VM, `--pairs 16 --runs 3`: 2.04-2.10 pairs/s,
0.88 s of CPU a pair (docs/python.md).
"""

import argparse
import os
import resource
import shutil
import tempfile
import time

from twinray.dataset import Options, generate


def cpu_seconds() -> float:
    r = resource.getrusage(resource.RUSAGE_SELF)
    return r.ru_utime + r.ru_stime


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--pairs", type=int, default=10)
    p.add_argument("--runs", type=int, default=3)
    p.add_argument("--seed", type=int, default=1)
    p.add_argument("--samples", type=int, help="flat samples per pixel (default: the generator's adaptive sampling)")
    p.add_argument("--size", default="960x540")
    a = p.parse_args()
    w, h = (int(v) for v in a.size.split("x"))
    opts = Options(size=(w, h), samples=a.samples)
    best = None
    for run in range(a.runs):
        out = tempfile.mkdtemp(prefix="twinray-dataset-bench-")
        try:
            wall, cpu = time.perf_counter(), cpu_seconds()
            generate(out, a.pairs, a.seed, opts)
            wall, cpu = time.perf_counter() - wall, cpu_seconds() - cpu
        finally:
            shutil.rmtree(out, ignore_errors=True)
        print(f"run {run + 1}: {a.pairs} pairs in {wall:.2f} s wall ({a.pairs / wall:.2f} pairs/s), "
              f"{cpu:.2f} s CPU ({cpu / a.pairs:.3f} s per pair)")
        if best is None or wall < best[0]:
            best = (wall, cpu)
    wall, cpu = best
    sampling = f"--samples {a.samples}" if a.samples else "adaptive sampling"
    print(f"best: {a.pairs / wall:.2f} pairs/s at {w}x{h}, {sampling}, ground truth, "
          f"{os.cpu_count()} cores; {cpu / a.pairs:.3f} CPU s per pair")


if __name__ == "__main__":
    main()
