#!/usr/bin/env python3
"""Whole renders, mono and stereo, several builds side by side: best CPU time and identical output.

usage (from the project's root):
    bench/render-sides.py ROUNDS NAME=BIN[,ENV=VALUE...] ... [-- SCENE ...]

Each NAME renders each SCENE (default: the eleven SPD scenes in
../shared/scenes/spd) at $SIZE x $SIZE (default 512), --samples 1, one
thread, once mono and once --stereo, ROUNDS times, the builds in turn within
a round so that the machine's load falls on all of them alike. An entry's
ENV=VALUE items are set in that render's environment (the same binary with a
variable set is another NAME). The clock is the child's CPU time (user +
system, getrusage), which other processes' load inflates less than wall time.

Prints per scene and mode each NAME's best and median CPU seconds, the last
NAME's best over the first's, and whether every NAME's image (the mono file,
both eyes of the pair) is byte for byte the first's.
"""
import hashlib
import os
import resource
import statistics
import subprocess
import sys
import tempfile

SPD = "balls gears jacks lattice mount rings shells sombrero teapot tetra tree".split()


def parse(argv):
    if len(argv) < 2:
        sys.exit(__doc__)
    rounds, rest = int(argv[0]), argv[1:]
    scenes = []
    if "--" in rest:
        at = rest.index("--")
        rest, scenes = rest[:at], rest[at + 1:]
    here = os.path.dirname(os.path.abspath(__file__))
    spd = os.path.join(here, "..", "..", "shared", "scenes", "spd")
    scenes = scenes or [os.path.join(spd, s + ".nff") for s in SPD]
    builds = []
    for entry in rest:
        name, _, spec = entry.partition("=")
        binary, *env = spec.split(",")
        builds.append((name, binary, dict(e.split("=", 1) for e in env)))
    if not builds:
        sys.exit(__doc__)
    return rounds, builds, scenes


def render(binary, env, scene, stereo, out):
    """CPU seconds of one render, and the digests of what it wrote."""
    size = os.environ.get("SIZE", "512")
    cmd = [binary, "render", scene, "-o", out, "--size", f"{size}x{size}",
           "--samples", "1", "--threads", "1", "--quiet"]
    if stereo:
        cmd.append("--stereo")
    files = sorted(f for f in os.listdir(os.path.dirname(out)))
    for f in files:
        os.remove(os.path.join(os.path.dirname(out), f))
    a = resource.getrusage(resource.RUSAGE_CHILDREN)
    subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                   env={**os.environ, **env})
    b = resource.getrusage(resource.RUSAGE_CHILDREN)
    digests = []
    for f in sorted(os.listdir(os.path.dirname(out))):
        with open(os.path.join(os.path.dirname(out), f), "rb") as fh:
            digests.append(hashlib.sha256(fh.read()).hexdigest())
    return (b.ru_utime - a.ru_utime) + (b.ru_stime - a.ru_stime), digests


def main():
    rounds, builds, scenes = parse(sys.argv[1:])
    out = os.path.join(tempfile.mkdtemp(), "out.png")
    names = [b[0] for b in builds]
    print("%-9s %-6s " % ("scene", "mode") + " ".join("%16s" % n for n in names)
          + "  last/first  same image", flush=True)
    for scene in scenes:
        for stereo in (False, True):
            times = {n: [] for n in names}
            digests = {}
            for _ in range(rounds):
                for name, binary, env in builds:
                    t, d = render(binary, env, scene, stereo, out)
                    times[name].append(t)
                    digests.setdefault(name, d)
            best = {n: min(v) for n, v in times.items()}
            row = " ".join("%7.3f (%6.3f)" % (best[n], statistics.median(times[n]))
                           for n in names)
            same = all(digests[n] == digests[names[0]] for n in names)
            label = os.path.splitext(os.path.basename(scene))[0]
            print("%-9s %-6s %s  %10.3f  %s" % (label, "stereo" if stereo else "mono", row,
                                                best[names[-1]] / best[names[0]],
                                                "yes" if same else "NO"), flush=True)


main()
