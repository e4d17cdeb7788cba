#!/usr/bin/env bash
# Load + build time and memory of a 1M-triangle mesh, as .glb, .gltf (external
# .bin), .obj, binary .stl and binary .ply, side by side in one run
# (alternating, REPS rounds), so that another job on the machine slows all of
# them alike.
#
#   bench/mesh-load.sh [REPS]      (default 5; needs a release build and python3)
#   FORMATS="stl ply" bench/mesh-load.sh 5     (only some formats)
#
# Prints per run: load_s and build_s from --stats, memory per triangle
# (shapes, corner attributes, materials and hierarchy: the stats' memory_bytes
# over the triangle count) and the process's peak RSS (GNU time); then the
# median of each format's load_s and build_s over the rounds.
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
twinray=${TWINRAY:-$root/target/release/twinray}
reps=${1:-5}
formats=${FORMATS:-glb gltf obj stl ply}
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
for ext in $formats; do
    python3 "$root/bench/make_terrain_gltf.py" "$work/terrain.$ext" >/dev/null
done
echo "machine: $(nproc) cores, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | xargs); load average $(cut -d' ' -f1-3 /proc/loadavg)"
printf '%-6s %4s %8s %8s %8s %12s %10s\n' format run load_s build_s total_s bytes/tri peak_MB
for r in $(seq 1 "$reps"); do
    for ext in $formats; do
        /usr/bin/time -f '%M' -o "$work/rss" "$twinray" render "$work/terrain.$ext" \
            -o "$work/out.png" --size 8x8 -q --stats "$work/stats.json" 2>/dev/null
        python3 - "$work/stats.json" "$work/rss" "$ext" "$r" <<'PY'
import json, sys
d = json.load(open(sys.argv[1]))
t, s = d["time"], d["scene"]
rss = int(open(sys.argv[2]).read().split()[-1]) / 1024
print(f'{sys.argv[3]:<6} {sys.argv[4]:>4} {t["load_s"]:8.3f} {t["build_s"]:8.3f} '
      f'{t["load_s"] + t["build_s"]:8.3f} {s["memory_bytes"] / s["primitives"]:12.1f} {rss:10.1f}')
PY
    done
done | tee "$work/runs"
python3 - "$work/runs" <<'PY'
import statistics, sys
rows = [l.split() for l in open(sys.argv[1]) if l.split() and l.split()[0] != "format"]
print(f"median over {len({r[1] for r in rows})} rounds:")
print(f"{'format':<6} {'load_s':>8} {'build_s':>8} {'total_s':>8}")
for ext in dict.fromkeys(r[0] for r in rows):
    mine = [r for r in rows if r[0] == ext]
    med = [statistics.median(float(r[k]) for r in mine) for k in (2, 3, 4)]
    print(f"{ext:<6} {med[0]:8.3f} {med[1]:8.3f} {med[2]:8.3f}")
PY
echo "load average after: $(cut -d' ' -f1-3 /proc/loadavg)"
