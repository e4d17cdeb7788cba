#!/usr/bin/env bash
# A Looking Glass quilt's worth of views (48 views of 420x560, 8x6) against one
# mono render of one view: the exact twin method, and the twin method with the
# safe reprojection (section 2.5), with the worst view's PSNR against exact.
#
#   bench/quilt.sh [SCENE.nff] [INTERAXIAL] [BATCH...]
#
# Default scene ../shared/scenes/spd/balls.nff, interaxial 0.02 between
# neighbouring views, batch sizes 4 and 8. One ray per pixel centre
# (--samples 1) everywhere. Runs each configuration once, mono first.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
scene=${1:-../shared/scenes/spd/balls.nff}
b=${2:-0.02}
shift $(( $# > 2 ? 2 : $# )) || true
batches=${*:-4 8}
bin=target/release/twinray
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
common=(--size 420x560 --samples 1 -q)

secs() { local t0 t1; t0=$(date +%s.%N); "$@"; t1=$(date +%s.%N); echo "$t1 - $t0" | bc -l; }

mono=$(secs "$bin" render "$scene" -o "$tmp/mono.exr" "${common[@]}")
printf '%-28s %8.2f s  %6.2fx mono\n' "mono, one view" "$mono" 1
for batch in $batches; do
  exact=$(secs "$bin" render "$scene" -o "$tmp/exact.exr" "${common[@]}" --views 48 \
          --interaxial "$b" --views-per-batch "$batch")
  printf '%-28s %8.2f s  %6.2fx mono\n' "48 views exact, batch $batch" "$exact" "$(echo "$exact / $mono" | bc -l)"
  rep=$(secs "$bin" render "$scene" -o "$tmp/rep.exr" "${common[@]}" --views 48 \
          --interaxial "$b" --views-per-batch "$batch" --reproject)
  worst=inf
  for v in $(seq 0 47); do
    p=$("$bin" compare "$tmp/exact_$v.exr" "$tmp/rep_$v.exr" | sed 's/^psnr_db \([^ ]*\).*/\1/')
    worst=$(python3 -c "print(min(float('$worst'), float('$p')))")
  done
  printf '%-28s %8.2f s  %6.2fx mono  worst view %s dB\n' "48 views reproject, batch $batch" "$rep" \
    "$(echo "$rep / $mono" | bc -l)" "$worst"
done
