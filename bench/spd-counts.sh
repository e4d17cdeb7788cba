#!/usr/bin/env bash
# Ray counts of the SPD testing procedure (--spd: 513x513 corner rays, depth 5,
# every reflected and refracted ray spawned) for the SPD databases.
#
# usage (from the project root):  bench/spd-counts.sh      (needs ../shared)
set -euo pipefail
tr=${TWINRAY:-target/release/twinray}
spd=${SPD:-../shared/scenes/spd}
[[ -x $tr ]] || { echo "build first: cargo build --release" >&2; exit 2; }
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
printf '| scene | primitives | eye | eye hit | reflected | refracted | shadow | render (s) |\n|---|---:|---:|---:|---:|---:|---:|---:|\n'
for n in balls gears mount rings teapot tetra tree; do
  "$tr" render "$spd/$n.nff" -o "$out/$n.png" --spd --quiet --stats "$out/$n.json"
  python3 - "$out/$n.json" "$n" <<'PY'
import json, sys
d = json.load(open(sys.argv[1]))
r = d["rays"]
print(f"| {sys.argv[2]} | {d['scene']['primitives']} | {r['eye']} | {r['eye_hit']} | {r['reflected']} | {r['refracted']} | {r['shadow']} | {d['time']['render_s']:.3f} |")
PY
done
