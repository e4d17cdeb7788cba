#!/usr/bin/env bash
# Instructions executed by whole renders (valgrind's callgrind), builds or
# flags side by side on N views at the default sampling, one thread: exact
# where CPU time on a shared machine moves by ±10 %. One line per render.
#
# usage (from the project root):
#   bench/instructions.sh VIEWS BIN[,FLAG...] BIN[,FLAG...] ... -- SCENE...
#   e.g. SIZE=256x256 INTERAXIAL=0.1 bench/instructions.sh 2 \
#          target/release/twinray target/release/twinray,--fast \
#          -- ../shared/scenes/spd/{balls,gears,tree}.nff
# SIZE (default 256x256) and INTERAXIAL (default 0.1) set the rig; FLAGS
# adds flags to every render (e.g. FLAGS="--samples 1").
set -euo pipefail
source "$(dirname "$0")/binaries.sh"
views=${1:?views}
shift
split_binaries "$@" || { sed -n 2,12p "$0" >&2; exit 2; }
command -v valgrind >/dev/null || { echo "valgrind is needed" >&2; exit 2; }
size=${SIZE:-256x256}
b=${INTERAXIAL:-0.1}
read -r -a extra <<< "${FLAGS:-}"
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
echo "# $views views, $size per view, interaxial $b, flags ${FLAGS:-none}, one thread"
for scene in "${scenes[@]}"; do
  name=$(basename "$scene" .nff)
  for bin in "${bins[@]}"; do
    IFS=, read -r -a cmd <<< "$bin"
    n=$(valgrind --tool=callgrind --callgrind-out-file=/dev/null \
      "${cmd[0]}" render "$scene" -o "$tmp/out.png" --size "$size" --views "$views" \
      --interaxial "$b" --threads 1 -q "${extra[@]}" "${cmd[@]:1}" 2>&1 |
      sed -n 's/.*Collected : \([0-9]*\).*/\1/p')
    echo "$name $bin instructions ${n:-failed}"
  done
done
