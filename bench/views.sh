#!/usr/bin/env bash
# What does the N-th view cost? For each scene and each number of views N, the
# CPU time of rendering N views divided by that of one mono view, measured in
# one run, mono first; and each approximate mode's worst PSNR and largest
# difference against the exact views. One ray per pixel centre (--samples 1)
# everywhere. Writes CSV; with matplotlib, the plot docs/images/views-cost.png.
# MODES (default "exact fast"): exact (the twin method) and fast (--fast: with
# --samples 1, as here, the epipolar rows); the CSV's cache_ columns are the
# fast method's shading cache (`--stats`' fast.cache), its eye_pass_s the
# --stats eye_pass_cpu_s (thread time of the eye pass).
# ROUNDS (default 1) repeats each scene's measurements, interleaved (mono,
# then every N and mode, then again), one CSV line per round (column round).
# PLOT (default docs/images/views-cost.png; empty: none) is the plot written.
#
# Time: CPU seconds (user + sys) of the whole command, on THREADS threads
# (default 1), so that other work on a shared machine does not count; the
# views are written as PFM (raw floats: writing costs next to nothing). The
# command's load, build and render are in it; its wall seconds and the
# --stats render_s are in the CSV too.
#
# usage (from the project root, after cargo build --release):
#   bench/views.sh [SIZE] [VIEWS] [INTERAXIAL] [CSV] [SCENE...]
#   defaults: SIZE=210x280  VIEWS=1,2,4,8,16,32,48,96  INTERAXIAL=0.02
#             CSV=docs/views-bench.csv  SCENES=balls mount tetra tree gears (../shared)
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
size=${1:-210x280}
counts=${2:-1,2,4,8,16,32,48,96}
b=${3:-0.02}
csv=${4:-docs/views-bench.csv}
shift $(( $# > 4 ? 4 : $# )) || true
spd=${SPD:-../shared/scenes/spd}
scenes=("$@")
if [[ ${#scenes[@]} -eq 0 ]]; then
  for n in balls mount tetra tree gears; do scenes+=("$spd/$n.nff"); done
fi
bin=${TWINRAY:-target/release/twinray}
threads=${THREADS:-1}
modes=${MODES:-exact fast}
rounds=${ROUNDS:-1}
plot=${PLOT-docs/images/views-cost.png}
[[ -x $bin ]] || { echo "build first: cargo build --release" >&2; exit 2; }
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
common=(--size "$size" --samples 1 -q --threads "$threads")

# CPU seconds of a command (user + sys), its wall seconds in $tmp/wall.
cpu() { /usr/bin/time -f "%U %S %e" -o "$tmp/time" "$@"; read -r u s e < "$tmp/time"; echo "$e" > "$tmp/wall"; python3 -c "print($u + $s)"; }
# A render's --stats render_s, and a counter of it.
render_s() { python3 -c "import json,sys; print(json.load(open(sys.argv[1]))['time']['render_s'])" "$1"; }
counter() { python3 -c "import json,sys; print(json.load(open(sys.argv[1])).get('fast', {}).get('cache', {}).get(sys.argv[2], 0))" "$1" "$2"; }
shadow_rays() { python3 -c "import json,sys; print(json.load(open(sys.argv[1]))['rays']['shadow'])" "$1"; }
secondary_rays() { python3 -c "import json,sys; r=json.load(open(sys.argv[1]))['rays']; print(r['reflected'] + r['refracted'])" "$1"; }

eye_pass() { python3 -c "import json,sys; print(json.load(open(sys.argv[1]))['time'].get('eye_pass_cpu_s') or '')" "$1"; }
echo "scene,size,threads,views,mode,cpu_s,per_mono,wall_s,render_s,psnr_db_worst,max_abs,shadow_rays,cache_hits,cache_entries,cache_fallbacks,cache_edge_refusals,cache_colour_hits,secondary_rays,round,eye_pass_s" > "$csv"
for scene in "${scenes[@]}"; do
 name=$(basename "$scene" .nff)
 for round in $(seq "$rounds"); do
  mono=$(cpu "$bin" render "$scene" -o "$tmp/mono.pfm" "${common[@]}" --stats "$tmp/mono.json" 2>/dev/null)
  echo "$name,$size,$threads,0,mono,$mono,1,$(cat "$tmp/wall"),$(render_s "$tmp/mono.json"),,,$(shadow_rays "$tmp/mono.json"),0,0,0,0,0,$(secondary_rays "$tmp/mono.json"),$round,$(eye_pass "$tmp/mono.json")" >> "$csv"
  for n in ${counts//,/ }; do
    rm -f "$tmp"/*_*.pfm
    rig=(--views "$n" --interaxial "$b")
    [[ $n -eq 1 ]] && rig=()
    for mode in $modes; do
      extra=()
      [[ $mode != exact && $n -eq 1 ]] && continue
      [[ $mode == fast ]] && extra=(--fast)
      s=$(cpu "$bin" render "$scene" -o "$tmp/$mode.pfm" "${common[@]}" "${rig[@]}" "${extra[@]}" \
        --stats "$tmp/$mode.json" 2>/dev/null)
      wall=$(cat "$tmp/wall")
      worst=inf; maxabs=0
      if [[ $mode != exact && $n -gt 1 && " $modes " == *" exact "* ]]; then
        # exact_0.pfm ... (a pair: exact_L.pfm, exact_R.pfm); one line per view.
        for e in "$tmp"/exact_*.pfm; do
          "$bin" compare "$e" "$tmp/${mode}_${e#"$tmp"/exact_}"
        done > "$tmp/compare"
        read -r worst maxabs < <(sed 's/^psnr_db \([^ ]*\) *max_abs \([^ ]*\).*/\1 \2/' "$tmp/compare" \
          | python3 -c "import sys; r=[l.split() for l in sys.stdin]; print(min(float(a) for a, _ in r), max(float(b) for _, b in r))")
      fi
      shadow=$(shadow_rays "$tmp/$mode.json")
      hits=$(counter "$tmp/$mode.json" hits)
      entries=$(counter "$tmp/$mode.json" entries)
      fb=$(counter "$tmp/$mode.json" fallbacks)
      edge=$(counter "$tmp/$mode.json" edge_refusals)
      whole=$(counter "$tmp/$mode.json" colour_hits)
      ratio=$(python3 -c "print(f'{$s / $mono:.3f}')")
      echo "$name,$size,$threads,$n,$mode,$s,$ratio,$wall,$(render_s "$tmp/$mode.json"),$worst,$maxabs,$shadow,$hits,$entries,$fb,$edge,$whole,$(secondary_rays "$tmp/$mode.json"),$round,$(eye_pass "$tmp/$mode.json")" >> "$csv"
      printf '%-8s %4s views %-10s %7.3f CPU s %8s x mono  worst %s dB  max %s\n' "$name" "$n" "$mode" "$s" "$ratio" "$worst" "$maxabs"
    done
  done
 done
done
if [[ -z $plot ]]; then
  :
elif python3 -c "import matplotlib" 2>/dev/null; then
  python3 bench/plot_views.py "$csv" "$plot"
else
  echo "(matplotlib not installed: no plot; pip install matplotlib)" >&2
fi
