#!/usr/bin/env python3
"""CPU time of a `--samples 1` render, several binaries side by side, for a loaded machine.

usage (from the project's root):
    bench/render-cpu-one.py ROUNDS SIZE THREADS SCENE BIN...

Runs `BIN render SCENE -o o.pfm --size SIZExSIZE --samples 1 --threads THREADS
--quiet --stats` for each BIN in turn (A B C A B C ...), ROUNDS times, under
`perf stat -e task-clock`, and the same at 8x8 pixels (loading, building,
start-up). Prints the medians of --stats' render_s, eye_pass_cpu_s and
shading_pass_cpu_s (wall-based: the load inflates them), of the process's CPU
time, of the 8x8 baseline, and of their difference per round: the CPU time of
the render at SIZE, which other processes' load does not inflate as much.
"""
import json, subprocess, sys, os, statistics, tempfile
rounds, size, threads, scene = int(sys.argv[1]), sys.argv[2], sys.argv[3], sys.argv[4]
bins = sys.argv[5:]
res = {b: {"render": [], "cpu": [], "ins": [], "eye": [], "shade": []} for b in bins}
td = tempfile.mkdtemp(prefix="17p-b")
def cpu_of(b, sz):
    ps = os.path.join(td, "p0.txt")
    subprocess.run(["perf", "stat", "-x,", "-o", ps, "-e", "task-clock", b, "render", scene, "-o", os.path.join(td, "o0.pfm"),
                    "--size", f"{sz}x{sz}", "--samples", "1", "--threads", threads, "--quiet"], check=True)
    for line in open(ps):
        f = line.split(",")
        if len(f) > 2 and f[2].startswith("task-clock"): return float(f[0]) / 1000
for b in bins: res[b]["base"] = []
for r in range(rounds):
    for b in bins:
        res[b]["base"].append(cpu_of(b, 8))
        st = os.path.join(td, "s.json"); ps = os.path.join(td, "p.txt")
        subprocess.run(["perf", "stat", "-x,", "-o", ps, "-e", "task-clock", b, "render", scene,
                        "-o", os.path.join(td, "o.pfm"), "--size", f"{size}x{size}", "--samples", "1",
                        "--threads", threads, "--quiet", "--stats", st], check=True)
        t = json.load(open(st))["time"]
        res[b]["render"].append(t["render_s"]); res[b]["eye"].append(t["eye_pass_cpu_s"]); res[b]["shade"].append(t["shading_pass_cpu_s"])
        for line in open(ps):
            f = line.split(",")
            if len(f) > 2 and f[2].startswith("instructions"): res[b]["ins"].append(float(f[0]))
            if len(f) > 2 and f[2].startswith("task-clock"): res[b]["cpu"].append(float(f[0]) / 1000)
print(f"{os.path.basename(scene)} {size}² {threads}t, {rounds} rounds, medians")
print("%-22s %9s %9s %9s %9s %9s %13s" % ("binary", "render_ms", "eye_ms", "shade_ms", "cpu_ms", "base_ms", "cpu-base_ms"))
for b in bins:
    m = lambda k: statistics.median(res[b][k])
    d = statistics.median([c - x for c, x in zip(res[b]["cpu"], res[b]["base"])])
    print("%-22s %9.1f %9.1f %9.1f %9.1f %9.1f %13.1f" % (os.path.basename(b), m("render")*1e3, m("eye")*1e3, m("shade")*1e3, m("cpu")*1e3, m("base")*1e3, d*1e3))
