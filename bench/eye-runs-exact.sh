#!/usr/bin/env bash
# Eye runs against --method independent on the SPD scenes: differing pixels.
# usage (from the project root, after cargo build --release): bench/eye-runs-exact.sh
# Renders each SPD scene at 420x560, 8 and 48 views, interaxial 0.02, by
# --method independent, --eye-runs and the default batches of 4, and counts
# the pixels where each differs from independent (over all views).
set -euo pipefail
B=${TWINRAY:-target/release/twinray}
S=${SPD:-../shared/scenes/spd}
cd "$(dirname "${BASH_SOURCE[0]}")/.."
t=$(mktemp -d)
trap 'rm -rf "$t"' EXIT
for n in balls mount tree tetra gears; do
  for v in 8 48; do
    common=(--size 420x560 --samples 1 -q --views $v --interaxial 0.02 --threads 1)
    $B render $S/$n.nff -o $t/ind.pfm "${common[@]}" --method independent
    $B render $S/$n.nff -o $t/runs.pfm "${common[@]}" --eye-runs
    $B render $S/$n.nff -o $t/b4.pfm "${common[@]}"
    worst_runs=0; worst_b4=0; dr=0; db=0
    for ((i=0;i<v;i++)); do
      r=$($B compare $t/ind_$i.pfm $t/runs_$i.pfm); b=$($B compare $t/ind_$i.pfm $t/b4_$i.pfm)
      dr=$((dr + $(echo "$r" | sed 's/.*differing_pixels \([0-9]*\).*/\1/')))
      db=$((db + $(echo "$b" | sed 's/.*differing_pixels \([0-9]*\).*/\1/')))
    done
    echo "$n N=$v: eye-runs vs independent: $dr differing pixels; b4 (default twin) vs independent: $db"
    rm -f $t/*.pfm
  done
done
