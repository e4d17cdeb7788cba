#!/usr/bin/env python3
"""Whole renders of the SPD scenes by CPU time, two or more binaries alternating.

usage (from the project's root):
    bench/render-cpu.py mono ROUNDS BIN BIN ...

mono:   each BIN renders ../shared/scenes/spd/NAME.nff at 512x512, --samples 1,
        one thread (the renders of ../shared/bench/vs-povray.sh, on one core);
        prints the medians and the last binary's time over the first's.
(A pair or N views against their views rendered alone: bench/views-cost.sh.)

The clock is the CPU time of the child (user + system, getrusage), not wall time,
so that a machine loaded by other work inflates it less. Scenes: $SCENES, default
all seven (balls gears mount rings teapot tetra tree); an entry ending in .nff is
a path (a scene of your own, e.g. an SPD scene without its lights:
`grep -v '^l ' ../shared/scenes/spd/tetra.nff > /tmp/tetra-unlit.nff`). A BIN
may carry flags for its renders after commas
(`target/release/twinray,--fast`: the same binary with other flags,
side by side with it plain). $SIZE
overrides the mono size (512). Within a round every binary runs once,
in turn. Mono also prints each binary's fastest run (`min`), the figure least
moved by other work.
"""
import os
import resource
import statistics
import subprocess
import sys
import tempfile

mode, rounds, bins = sys.argv[1], int(sys.argv[2]), sys.argv[3:]
if mode != "mono" or len(bins) < 1:
    sys.exit(__doc__)
scenes = os.environ.get("SCENES", "balls gears mount rings teapot tetra tree").split()
here = os.path.dirname(os.path.abspath(__file__))
spd = os.path.join(here, "..", "..", "shared", "scenes", "spd", "%s.nff")
out = os.path.join(tempfile.mkdtemp(), "out.png")


def cpu(cmd):
    a = resource.getrusage(resource.RUSAGE_CHILDREN)
    subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    b = resource.getrusage(resource.RUSAGE_CHILDREN)
    return (b.ru_utime - a.ru_utime) + (b.ru_stime - a.ru_stime)


size = os.environ.get("SIZE", "512")


def path(scene):
    return scene if scene.endswith(".nff") else spd % scene


def command(b, scene):
    # "BIN,FLAG,FLAG...": the flags go to that binary's renders.
    b, *flags = b.split(",")
    return [b, "render", path(scene), "-o", out, "--size", "%sx%s" % (size, size),
            "--samples", "1", "--threads", "1", "--quiet"] + flags


for s in scenes:
    t = {b: [] for b in bins}
    for _ in range(rounds):
        for b in bins:
            t[b].append(cpu(command(b, s)))
    med = {k: statistics.median(v) for k, v in t.items()}
    row = " ".join("%s %.3f s (min %.3f)" % (b, med[b], min(t[b])) for b in bins)
    print("%-8s %s  last/first %.3f" % (s, row, med[bins[-1]] / med[bins[0]]), flush=True)
