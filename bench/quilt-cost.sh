#!/usr/bin/env bash
# Issue 16's headline as a user meets it: a 48-view 8x6 quilt of 420x560 views
# written as one PNG, against one mono view written as a PNG, by each binary in
# turn (ROUNDS rounds, alternated), one thread, --samples 1. Prints for each
# render --stats render_s and the CPU seconds (user + sys) of the whole
# command, and each quilt's ratios to the same binary's mono render of that
# round (the median of three mono renders by render_s); the quilts of every binary are compared with the first's (`cmp`).
# A binary may carry flags after commas (`target/release/twinray,--fast`).
#
# usage (from the project root):
#   bench/quilt-cost.sh ROUNDS BIN[,FLAG...] ... -- SCENE...
#   e.g. bench/quilt-cost.sh 3 /tmp/before,--fast \
#          target/release/twinray,--fast -- ../shared/scenes/spd/{tetra,tree}.nff
# VIEWS (default 48), QUILT (default 8x6), SIZE (default 420x560) and
# INTERAXIAL (default 0.02) override the quilt.
set -euo pipefail
source "$(dirname "$0")/binaries.sh"
rounds=$1
shift
split_binaries "$@" || { sed -n 2,15p "$0" >&2; exit 2; }
views=${VIEWS:-48} quilt=${QUILT:-8x6} size=${SIZE:-420x560} b=${INTERAXIAL:-0.02}
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
printf '%-8s %5s  %-40s %9s %7s %9s %7s %8s %8s  %s\n' scene round binary mono_s mono_cpu \
  quilt_s q_cpu x_render x_cpu quilt
for scene in "${scenes[@]}"; do
  name=$(basename "$scene" .nff)
  for round in $(seq "$rounds"); do
    for i in "${!bins[@]}"; do
      IFS=, read -r -a cmd <<< "${bins[$i]}"
      # The mono render: the median of three (a few hundredths of a second,
      # where the CPU clock counts in hundredths).
      for k in 1 2 3; do
        measure "${cmd[0]}" render "$scene" -o "$tmp/mono.png" --size "$size"
      done | sort -g | sed -n 2p > "$tmp/mono"
      read -r m_s m_cpu < "$tmp/mono"
      mkdir -p "$tmp/b$i"
      read -r q_s q_cpu < <(measure "${cmd[0]}" render "$scene" -o "$tmp/b$i/q.png" --size "$size" \
        --views "$views" --interaxial "$b" --layout quilt --quilt "$quilt" "${cmd[@]:1}")
      same=-
      if [[ $i -gt 0 ]]; then
        same=identical
        cmp -s "$tmp"/b0/q_*.png "$tmp/b$i"/q_*.png || same=differs
      fi
      python3 - "$name" "$round" "${bins[$i]}" "$m_s" "$m_cpu" "$q_s" "$q_cpu" "$same" <<'PY'
import sys
name, rnd, binary, m_s, m_cpu, q_s, q_cpu, same = sys.argv[1:]
binary = binary[-40:]
m_s, m_cpu, q_s, q_cpu = map(float, (m_s, m_cpu, q_s, q_cpu))
print("%-8s %5s  %-40s %9.4f %7.3f %9.3f %7.3f %8.1f %8.1f  %s" % (
    name, rnd, binary, m_s, m_cpu, q_s, q_cpu, q_s / m_s, q_cpu / max(m_cpu, 0.01), same))
PY
    done
  done
done
