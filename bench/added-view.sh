#!/usr/bin/env bash
# What one more view costs (issue 16's "cost of the N-th added view"): for each
# binary in turn (ROUNDS rounds, alternated), a mono view, N views and 2N views
# of SIZE, one thread, --samples 1, every view written as its own PNG (what a
# user writes); prints the --stats render_s of each and
#   added = (render_s(2N) - render_s(N)) / N / render_s(mono),
# the same by CPU seconds (user + sys) of the whole commands, and the views'
# check: the 2N views of every binary compared with the first's (`cmp`).
# A binary may carry flags after commas (`target/release/twinray,--fast`).
#
# usage (from the project root):
#   bench/added-view.sh ROUNDS BIN[,FLAG...] ... -- SCENE...
#   e.g. bench/added-view.sh 3 /tmp/before,--fast \
#          target/release/twinray,--fast -- ../shared/scenes/spd/{mount,tetra,tree}.nff
# N (default 48), SIZE (default 420x560) and INTERAXIAL (default 0.02) override.
set -euo pipefail
source "$(dirname "$0")/binaries.sh"
rounds=$1
shift
split_binaries "$@" || { sed -n 2,15p "$0" >&2; exit 2; }
n=${N:-48} size=${SIZE:-420x560} b=${INTERAXIAL:-0.02}
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
printf '%-8s %5s  %-40s %8s %8s %8s %8s %8s  %s\n' scene round binary mono_s n_s 2n_s \
  added added_cpu views
for scene in "${scenes[@]}"; do
  name=$(basename "$scene" .nff)
  for round in $(seq "$rounds"); do
    for i in "${!bins[@]}"; do
      IFS=, read -r -a cmd <<< "${bins[$i]}"
      rm -rf "$tmp/v$i" "$tmp/m"
      mkdir -p "$tmp/v$i" "$tmp/m"
      # The mono render: the median of three by render_s.
      for k in 1 2 3; do
        measure "${cmd[0]}" render "$scene" -o "$tmp/m/mono.png" --size "$size"
      done | sort -g | sed -n 2p > "$tmp/mono"
      read -r m_s m_cpu < "$tmp/mono"
      read -r a_s a_cpu < <(measure "${cmd[0]}" render "$scene" -o "$tmp/m/v.png" --size "$size" \
        --views "$n" --interaxial "$b" "${cmd[@]:1}")
      read -r c_s c_cpu < <(measure "${cmd[0]}" render "$scene" -o "$tmp/v$i/v.png" --size "$size" \
        --views $((2 * n)) --interaxial "$b" "${cmd[@]:1}")
      same=-
      if [[ $i -gt 0 ]]; then
        same=identical
        for f in "$tmp"/v0/*.png; do
          cmp -s "$f" "$tmp/v$i/${f##*/}" || { same=differs; break; }
        done
      fi
      python3 - "$name" "$round" "${bins[$i]}" "$n" "$m_s" "$m_cpu" "$a_s" "$a_cpu" "$c_s" \
        "$c_cpu" "$same" <<'PY'
import sys
name, rnd, binary, n = sys.argv[1:5]
m_s, m_cpu, a_s, a_cpu, c_s, c_cpu = map(float, sys.argv[5:11])
n = int(n)
print("%-8s %5s  %-40s %8.4f %8.3f %8.3f %8.3f %8.3f  %s" % (
    name, rnd, binary[-40:], m_s, a_s, c_s, (c_s - a_s) / n / m_s,
    (c_cpu - a_cpu) / n / max(m_cpu, 0.01), sys.argv[11]))
PY
    done
  done
done
