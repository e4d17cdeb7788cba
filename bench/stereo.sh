#!/usr/bin/env bash
# The exact stereo pair against its views rendered alone (two mono renders, each
# view's own camera) on the SPD scenes, by `twinray bench-stereo`: the shape of
# the paper's tables 2.1 and 2.2. Prints Markdown; writes CSV and a plot.
#
# usage (from the project root):  bench/stereo.sh [SIZES] [INTERAXIALS]   (needs ../shared)
#   defaults: SIZES=128,256,512,1024  INTERAXIALS=0,0.05,0.1,0.2
set -euo pipefail
sizes=${1:-128,256,512,1024}
ias=${2:-0,0.05,0.1,0.2}
tr=${TWINRAY:-target/release/twinray}
spd=${SPD:-../shared/scenes/spd}
[[ -x $tr ]] || { echo "build first: cargo build --release" >&2; exit 2; }
scenes=()
for n in balls gears mount rings teapot tetra tree; do scenes+=("$spd/$n.nff"); done
"$tr" bench-stereo "${scenes[@]}" --sizes "$sizes" --interaxial "$ias" --runs 3 --csv docs/stereo-bench.csv
if python3 -c "import matplotlib" 2>/dev/null; then
  python3 bench/plot_stereo.py docs/stereo-bench.csv docs/images/stereo-ratio.png
else
  echo "(matplotlib not installed: no plot; pip install matplotlib)" >&2
fi
