#!/usr/bin/env bash
# What mirrors and glass cost a multi-view render (issue 16): for each NFF
# scene, one thread, --samples 1, --stats render_s,
#   mono    one view of the scene (the median of three);
#   views   N views (VIEWS, default 48) as a quilt, with the binary's flags;
#   plain   the same N views with every material's Ks and T set to 0: the same
#           geometry, lights and diffuse shading, no mirror, glass or highlight;
#   floor   the same N views of the scene's view alone (its lines before the
#           first material, and one small triangle out of sight): every sample
#           background, the cost before any visibility or shading;
# and each against mono; "mirror part" = (views - plain) / mono.
#
# usage (from the project root):
#   bench/mirror-part.sh BIN[,FLAG...] -- SCENE.nff...
#   e.g. bench/mirror-part.sh target/release/twinray,--fast -- \
#          ../shared/scenes/spd/{balls,rings,gears,mount,teapot}.nff
# VIEWS, QUILT (default 8x6), SIZE (default 420x560) and INTERAXIAL (default
# 0.02) override.
set -euo pipefail
source "$(dirname "$0")/binaries.sh"
split_binaries "$@" || { sed -n 2,20p "$0" >&2; exit 2; }
views=${VIEWS:-48} quilt=${QUILT:-8x6} size=${SIZE:-420x560} b=${INTERAXIAL:-0.02}
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
IFS=, read -r -a cmd <<< "${bins[0]}"
quilt_s() {
  measure "${cmd[0]}" render "$1" -o "$tmp/q.png" --size "$size" --views "$views" \
    --interaxial "$b" --layout quilt --quilt "$quilt" "${cmd[@]:1}" | cut -d' ' -f1
}
printf '%-10s %9s %9s %9s %9s %8s %8s %8s %12s\n' scene mono_s views_s plain_s floor_s \
  x_views x_plain x_floor mirror_part
for scene in "${scenes[@]}"; do
  name=$(basename "$scene" .nff)
  awk '/^f /{$6=0; $8=0} {print}' "$scene" > "$tmp/plain.nff"
  { awk '/^f /{exit} {print}' "$scene"; printf 'f 1 1 1 1 0 0 0 1\np 3\n1e4 1e4 1e4\n1e4 1e4 1.0001e4\n1e4 1.0001e4 1e4\n'; } \
    > "$tmp/floor.nff"
  for k in 1 2 3; do
    measure "${cmd[0]}" render "$scene" -o "$tmp/m.png" --size "$size" | cut -d' ' -f1
  done | sort -g | sed -n 2p > "$tmp/mono"
  mono=$(cat "$tmp/mono")
  all=$(quilt_s "$scene") plain=$(quilt_s "$tmp/plain.nff") floor=$(quilt_s "$tmp/floor.nff")
  python3 - "$name" "$mono" "$all" "$plain" "$floor" <<'PY'
import sys
name, m, a, p, f = sys.argv[1], *map(float, sys.argv[2:])
print("%-10s %9.4f %9.3f %9.3f %9.3f %8.1f %8.1f %8.1f %12.1f" % (
    name, m, a, p, f, a / m, p / m, f / m, (a - p) / m))
PY
done
