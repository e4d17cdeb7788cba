#!/usr/bin/env bash
# Two or more builds side by side on N views: for each scene, ROUNDS rounds, each
# binary in turn, one line per render with the --stats render_s (one thread,
# --samples 1, 420x560 per view by default). A binary may carry flags after
# commas, as in bench/render-cpu.py (`target/release/twinray,--fast`).
# With CMP=1, the views of every binary are compared with the first's (`cmp`):
# a change that must not move a pixel is checked in the same run.
#
# usage (from the project root):
#   bench/views-ab.sh ROUNDS VIEWS BIN[,FLAG...] BIN[,FLAG...] ... -- SCENE...
#   e.g. bench/views-ab.sh 2 48 /tmp/before,--fast /tmp/after,--fast \
#          -- ../shared/scenes/spd/{balls,gears}.nff
# SIZE (default 420x560) and INTERAXIAL (default 0.02) override the rig.
set -euo pipefail
source "$(dirname "$0")/binaries.sh"
rounds=$1 views=$2
shift 2
split_binaries "$@" || { sed -n 2,13p "$0" >&2; exit 2; }
size=${SIZE:-420x560}
b=${INTERAXIAL:-0.02}
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
render_s() { python3 -c "import json,sys; print(json.load(open(sys.argv[1]))['time']['render_s'])" "$1"; }
for scene in "${scenes[@]}"; do
  name=$(basename "$scene" .nff)
  for round in $(seq "$rounds"); do
    for i in "${!bins[@]}"; do
      IFS=, read -r -a cmd <<< "${bins[$i]}"
      "${cmd[0]}" render "$scene" -o "$tmp/b$i.pfm" --size "$size" --samples 1 --threads 1 \
        --views "$views" --interaxial "$b" -q --stats "$tmp/b$i.json" "${cmd[@]:1}" 2>/dev/null
      line="$name round $round ${bins[$i]} render_s $(render_s "$tmp/b$i.json")"
      if [[ ${CMP:-0} == 1 && $i -gt 0 ]]; then
        same=identical
        for f in "$tmp"/b0_*.pfm; do
          cmp -s "$f" "$tmp/b${i}_${f#"$tmp"/b0_}" || { same="differs (${f##*/})"; break; }
        done
        line+=" views $same"
      fi
      echo "$line"
    done
  done
done
