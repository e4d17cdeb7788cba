#!/usr/bin/env bash
# What the second eye of a panorama costs, beside a flat pair's: for each
# scene, the best of ROUNDS whole-process CPU seconds (user + system, one
# thread, --samples 1) of
#   a mono pinhole view and a pinhole pair (--interaxial B, parallel), and
#   a mono equirectangular view and an ODS pair (--interaxial B),
# every image SIZE (default 4096x2048 per eye), and the ratios
#   flat = pair / (2 x mono),  ods = ODS pair / (2 x equirect).
# The twin method's promise: ods <= flat. FROM,AT (optional) put the camera
# inside the scene for every render (e.g. FROM=0,-2.2,1 AT=0,0,0.8 for
# scenes/example.nff).
#
# usage (from the project root):
#   bench/pano-pair.sh ROUNDS SCENE...
#   e.g. bench/pano-pair.sh 3 scenes/example.nff ../shared/scenes/spd/balls.nff
# SIZE, B (default 0.064) and TWINRAY (default target/release/twinray) override.
set -euo pipefail
rounds=${1:?usage: bench/pano-pair.sh ROUNDS SCENE...}
shift
[[ $# -ge 1 ]] || { sed -n 2,16p "$0" >&2; exit 2; }
tr=${TWINRAY:-target/release/twinray}
size=${SIZE:-4096x2048} b=${B:-0.064}
[[ -x $tr ]] || { echo "build first: cargo build --release --bin twinray" >&2; exit 2; }
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
place=()
[[ -n ${FROM:-} ]] && place+=(--from "$FROM")
[[ -n ${AT:-} ]] && place+=(--at "$AT")

# cpu ARGS...: the best of ROUNDS CPU seconds of one render.
cpu() {
  local best=
  for _ in $(seq "$rounds"); do
    /usr/bin/time -f '%U %S' -o "$tmp/time" "$tr" render "$@" "${place[@]}" \
      --size "$size" --samples 1 --threads 1 -q
    read -r u s < "$tmp/time"
    best=$(python3 -c "import sys; v=float(sys.argv[1])+float(sys.argv[2]); b=sys.argv[3]; print(v if not b else min(v, float(b)))" "$u" "$s" "$best")
  done
  echo "$best"
}

printf '%-10s %9s %9s %7s  %9s %9s %7s\n' scene mono_s pair_s flat equi_s ods_s ods
for scene in "$@"; do
  name=$(basename "$scene" .nff)
  mono=$(cpu "$scene" -o "$tmp/m.png")
  pair=$(cpu "$scene" -o "$tmp/p.png" --stereo --interaxial "$b" --convergence inf)
  equi=$(cpu "$scene" -o "$tmp/e.png" --projection equirect)
  ods=$(cpu "$scene" -o "$tmp/o.png" --projection ods --stereo --interaxial "$b")
  python3 - "$name" "$mono" "$pair" "$equi" "$ods" <<'PY'
import sys
name = sys.argv[1]
mono, pair, equi, ods = map(float, sys.argv[2:6])
print("%-10s %9.2f %9.2f %7.3f  %9.2f %9.2f %7.3f" % (
    name, mono, pair, pair / (2 * mono), equi, ods, ods / (2 * equi)))
PY
done
