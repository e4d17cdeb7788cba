#!/usr/bin/env bash
# The stereo pair's approximations against two independent renders, in CPU
# seconds (user + sys of the whole command on THREADS threads, default 1, so
# that other work on a shared machine does not count; views written as PFM):
# the exact twin method and --fast (with --samples 1, as here: the epipolar
# rows; with other samplings the cut, merged rays and shared shading), with
# the fast pair's worst PSNR and largest difference against the exact one.
#
# usage (from the project root, after cargo build --release):
#   bench/pair-fast.sh [SIZE] [INTERAXIAL] [SCENE...]   (defaults 1024, 0.1, the SPD scenes)
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
size=${1:-1024}
b=${2:-0.1}
shift $(( $# > 2 ? 2 : $# )) || true
spd=${SPD:-../shared/scenes/spd}
scenes=("$@")
if [[ ${#scenes[@]} -eq 0 ]]; then
  for n in balls gears mount rings teapot tetra tree; do scenes+=("$spd/$n.nff"); done
fi
bin=${TWINRAY:-target/release/twinray}
threads=${THREADS:-1}
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
common=(--size "${size}x${size}" --samples 1 -q --threads "$threads" --stereo --interaxial "$b")
cpu() { /usr/bin/time -f "%U %S" -o "$tmp/time" "$@" 2>/dev/null; read -r u s < "$tmp/time"; python3 -c "print($u + $s)"; }
worst() {
  local w=inf m=0 p x
  for e in L R; do
    read -r p x < <("$bin" compare "$tmp/exact_$e.pfm" "$tmp/$1_$e.pfm" | sed 's/^psnr_db \([^ ]*\) *max_abs \([^ ]*\).*/\1 \2/')
    w=$(python3 -c "print(min(float('$w'), float('$p')))"); m=$(python3 -c "print(max($m, $x))")
  done
  echo "$w $m"
}
echo "| scene | independent CPU s | exact twin | --fast | PSNR fast (dB, worst view) | max abs fast |"
echo "|---|---:|---:|---:|---:|---:|"
for scene in "${scenes[@]}"; do
  name=$(basename "$scene" .nff)
  ind=$(cpu "$bin" render "$scene" -o "$tmp/ind.pfm" "${common[@]}" --method independent)
  ex=$(cpu "$bin" render "$scene" -o "$tmp/exact.pfm" "${common[@]}")
  fa=$(cpu "$bin" render "$scene" -o "$tmp/fast.pfm" "${common[@]}" --fast)
  read -r pf mf < <(worst fast)
  r() { python3 -c "print(f'{$1 / $ind:.2f}')"; }
  echo "| $name | $ind | $(r "$ex") | $(r "$fa") | $pf | $mf |"
done
