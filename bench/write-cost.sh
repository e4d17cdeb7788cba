#!/usr/bin/env bash
# What writing a many-view render costs: for each binary in turn (ROUNDS
# rounds, alternated), 48 views of 420x560 of SCENE (--samples 1,
# --fast) written as one portrait quilt PNG and as 48 separate PNGs;
# prints --stats' render_s and write_s, the command's wall and system CPU time
# and its peak RSS (GNU time), and checks with `cmp` that every binary wrote
# the first one's files.
#
# usage (from the project root):
#   bench/write-cost.sh ROUNDS SCENE BIN BIN ...
#   e.g. bench/write-cost.sh 3 ../shared/scenes/spd/tetra.nff /tmp/before target/release/twinray
set -euo pipefail
rounds=$1 scene=$2
shift 2
[[ $# -ge 1 ]] || { sed -n 2,12p "$0" >&2; exit 2; }
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
common=(--samples 1 --fast --quiet)
printf '%-24s %-9s %9s %8s %7s %7s %8s\n' binary output render_s write_s wall_s sys_s peak_MB
for r in $(seq 1 "$rounds"); do
    i=0
    for bin in "$@"; do
        i=$((i + 1))
        for out in quilt separate; do
            if [[ $out == quilt ]]; then
                flags=(--layout quilt --quilt portrait)
            else
                flags=(--size 420x560 --views 48 --interaxial 0.02)
            fi
            dir=$tmp/$out-$i
            mkdir -p "$dir"
            /usr/bin/time -f '%e %S %M' -o "$tmp/time" "$bin" render "$scene" -o "$dir/v.png" \
                "${flags[@]}" "${common[@]}" --stats "$tmp/stats.json"
            read -r wall sys rss < "$tmp/time"
            python3 - "$tmp/stats.json" "$bin" "$out" "$wall" "$sys" "$rss" <<'PY'
import json, sys
t = json.load(open(sys.argv[1]))["time"]
print("%-24s %-9s %9.3f %8.3f %7s %7s %8.0f" % (sys.argv[2][-24:], sys.argv[3], t["render_s"],
      t["write_s"], sys.argv[4], sys.argv[5], int(sys.argv[6]) / 1024))
PY
            if [[ $i -gt 1 ]]; then
                for f in "$tmp/$out-1"/*.png; do
                    cmp -s "$f" "$dir/$(basename "$f")" || { echo "DIFFERS: $out $(basename "$f")"; exit 1; }
                done
            fi
        done
    done
done
