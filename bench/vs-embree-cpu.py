#!/usr/bin/env python3
"""Eye-ray throughput against Embree 4, by CPU time, for a loaded machine.

usage (from the project's root):
    bench/vs-embree-cpu.py [--size N] [--rounds R] [--twinray BIN ...] SCENE.nff ...

The same rays and scenes as ../shared/bench/vs-embree.py (whose functions it
imports): one eye ray per pixel centre, nearest hit only, twinray rendering a
matte copy of the scene with no lights, one thread. The difference is the clock:
that script times wall seconds, which other processes' load inflates by 2-10x
on a shared machine. Here Embree's `scene.run` is timed by this thread's CPU
time (time.thread_time) and twinray's by the CPU time of its process (user +
system, from the kernel's accounting of the child), less that of the same
command at 8x8 pixels (parsing, building, start-up), so that what remains is
the eye rays and the pixels they make. (twinray's `--stats` eye-pass time is
wall time summed over threads, which the load inflates.) Each `--twinray`
binary (default target/release/twinray)
is run in turn with Embree between them, `--rounds` times (default 5); prints
the medians and, per binary, the ratio twinray / Embree (above 1: twinray is
faster). With two binaries, their ratio to each other too.
"""
import argparse, importlib.util, json, os, resource, subprocess, tempfile, time

here = os.path.dirname(os.path.abspath(__file__))
spec = importlib.util.spec_from_file_location(
    "vs_embree", os.path.join(here, "..", "..", "shared", "bench", "vs-embree.py"))
vs = importlib.util.module_from_spec(spec)
spec.loader.exec_module(vs)


def twinray_cpu(binary, nff, size, td):
    """CPU seconds of one render at size x size, and its eye-ray hits."""
    st = os.path.join(td, "s.json")
    r0 = resource.getrusage(resource.RUSAGE_CHILDREN)
    subprocess.run([binary, "render", nff, "-o", os.path.join(td, "o.pfm"), "--size",
                    "%dx%d" % (size, size), "--samples", "1", "--threads", "1", "--quiet",
                    "--stats", st], check=True)
    r1 = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (r1.ru_utime - r0.ru_utime) + (r1.ru_stime - r0.ru_stime)
    return cpu, json.load(open(st))["rays"]["eye_hit"]


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--size", type=int, default=512)
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--twinray", action="append")
    ap.add_argument("scenes", nargs="+")
    a = ap.parse_args()
    bins = a.twinray or ["target/release/twinray"]
    print("load average %s" % open("/proc/loadavg").read().split()[:3])
    print("%-10s %-28s %12s %12s %7s %9s" % ("scene", "twinray", "twinray_Mr/s", "embree_Mr/s",
                                             "ratio", "hit_diff"))
    for path in a.scenes:
        name = os.path.basename(path).rsplit(".", 1)[0]
        view, tris, matte = vs.parse_nff(path)
        o, d = vs.eye_rays(view, a.size, a.size)
        scene = vs.rtcs.EmbreeScene()
        vs.TriangleMesh(scene, tris)
        scene.run(o[:1024], d[:1024])  # commit the scene before timing
        n = a.size * a.size
        et, tt, hits = [], {b: [] for b in bins}, {}
        with tempfile.TemporaryDirectory() as td:
            nff = os.path.join(td, "matte.nff")
            open(nff, "w").write(matte)
            for _ in range(a.rounds):
                for b in bins:
                    t0 = time.thread_time()
                    ehits = scene.run(o, d)
                    et.append(time.thread_time() - t0)
                    s, h = twinray_cpu(b, nff, a.size, td)
                    fixed, _ = twinray_cpu(b, nff, 8, td)
                    tt[b].append(max(s - fixed, 1e-6))
                    hits[b] = h
        em = n / vs.median(et) / 1e6
        for b in bins:
            tm = n / vs.median(tt[b]) / 1e6
            ehit = int((ehits >= 0).sum())
            print("%-10s %-28s %12.2f %12.2f %7.2f %8.4f%%" % (
                name, b[-28:], tm, em, tm / em, 100.0 * abs(hits[b] - ehit) / n))
        if len(bins) == 2:
            r = vs.median(tt[bins[0]]) / vs.median(tt[bins[1]])
            print("%-10s second / first (CPU time ratio inverted: above 1, the second is faster): %.2f"
                  % (name, r))


if __name__ == "__main__":
    main()
