#!/usr/bin/env bash
# The paper's approximations (sections 2.3-2.5) against the views rendered alone (two mono renders) on
# the SPD scenes and the bundled deep scene: time ratio, and the PSNR and largest
# difference of the worst view against the exact images. The shape of the paper's
# tables 2.3 and 2.4, with the quality columns it did not have, and --fast beside
# them. Prints Markdown;
# writes CSV and a speed-against-quality plot.
#
# usage (from the project root):  bench/approx.sh [SIZES] [INTERAXIALS] [RUNS] [CSV]   (needs ../shared)
#   defaults: SIZES=128,256,512,1024  INTERAXIALS=0,0.05,0.1,0.2  RUNS=3  CSV=docs/approx-bench.csv
set -euo pipefail
sizes=${1:-128,256,512,1024}
ias=${2:-0,0.05,0.1,0.2}
runs=${3:-3}
csv=${4:-docs/approx-bench.csv}
tr=${TWINRAY:-target/release/twinray}
spd=${SPD:-../shared/scenes/spd}
[[ -x $tr ]] || { echo "build first: cargo build --release" >&2; exit 2; }
scenes=()
for n in balls gears mount rings teapot tetra tree; do scenes+=("$spd/$n.nff"); done
scenes+=(scenes/deep.nff)
"$tr" bench-stereo "${scenes[@]}" --sizes "$sizes" --interaxial "$ias" --runs "$runs" \
  --approx none,cut,merge,reproject,paper,fast --csv "$csv"
if python3 -c "import matplotlib" 2>/dev/null; then
  python3 bench/plot_approx.py "$csv" docs/images/approx-speed-quality.png
else
  echo "(matplotlib not installed: no plot; pip install matplotlib)" >&2
fi
