#!/usr/bin/env bash
# Render time against object count: the SPD sphereflakes and tetrahedra at three
# sizes of database, same view and resolution. A hierarchy makes the time grow
# with the logarithm of the count.
#
# usage (from the project root):  bench/scaling.sh [SIZE]     (needs ../shared)
set -euo pipefail
size=${1:-512}
tr=${TWINRAY:-target/release/twinray}
spd=${SPD:-../shared/scenes/spd}
[[ -x $tr ]] || { echo "build first: cargo build --release" >&2; exit 2; }
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
printf '| scene | primitives | load (s) | build (s) | render (s) | nodes visited per eye ray |\n|---|---:|---:|---:|---:|---:|\n'
for n in balls_s2 balls balls_s5 tetra tetra_s8; do
  best=""
  for _ in 1 2 3; do
    "$tr" render "$spd/$n.nff" -o "$out/$n.png" --size "${size}x${size}" --quiet --stats "$out/$n.json"
    r=$(python3 -c "import json;d=json.load(open('$out/$n.json'));print(d['time']['render_s'])")
    if [[ -z $best ]] || awk -v a="$r" -v b="$best" 'BEGIN{exit !(a<b)}'; then best=$r; cp "$out/$n.json" "$out/$n.best.json"; fi
  done
  python3 - "$out/$n.best.json" "$n" <<'PY'
import json, sys
d = json.load(open(sys.argv[1]))
t, s = d["time"], d["scene"]
print(f"| {sys.argv[2]} | {s['primitives']} | {t['load_s']:.3f} | {t['build_s']:.3f} | {t['render_s']:.3f} | {d['nodes_visited'] / d['rays']['eye']:.1f} |")
PY
done
